"""What VDI/VDE 2634 parts 2 and 3 declare (:class:`camcmm.api.StandardDeclaration`):
the quality parameters with their symbols and signs, the artefacts with the plan fields
a lab fills from its calibration certificates, and the tests and positions. The GUI
reads all of this from here; nothing about VDI/VDE 2634 is written in the GUI."""

from __future__ import annotations

from typing import Any

from camcmm.api import ArtefactField, ArtefactKind, PositionSpec, QualityParameter, StandardDeclaration, TestDeclaration

from . import positions

PARAMETERS = (
    QualityParameter(
        "PF",
        "P_F",
        "Probing error form P_F",
        help="range of the radial deviations from the least-squares sphere after the outlier rule",
    ),
    QualityParameter(
        "PS",
        "P_S",
        "Probing error size P_S",
        signed=True,
        help="measured minus calibrated sphere diameter (thesis eq. 2.28)",
    ),
    QualityParameter(
        "SD",
        "SD",
        "Sphere-spacing error SD",
        signed=True,
        help="measured minus calibrated distance of the two sphere centres (eq. 2.29)",
    ),
    QualityParameter(
        "F", "F", "Flatness measurement error F", help="range of the distances to the least-squares plane"
    ),
)
#: Parameter key -> printed symbol, and -> full name (reports, the result JSON).
SYMBOLS = {p.key: p.symbol for p in PARAMETERS}
NAMES = {p.key: p.name for p in PARAMETERS}


def _u(label: str = "Its uncertainty U") -> ArtefactField:
    return ArtefactField("uncertainty", label, min=0.0, help="expanded uncertainty of the calibrated value")


_K = ArtefactField("k", "Coverage factor k", unit="", min=1.0, max=3.0)

ARTEFACTS = (
    ArtefactKind(
        "sphere",
        "Calibrated sphere",
        (
            ArtefactField(
                "diameter", "Diameter (calibrated)", min=0.0, certificate="diameter", uncertainty="uncertainty"
            ),
            _u(),
            _K,
        ),
    ),
    ArtefactKind(
        "ball_bar",
        "Ball bar",
        (
            ArtefactField("length", "Length (calibrated)", min=0.0, certificate="length", uncertainty="uncertainty"),
            _u(),
            _K,
            ArtefactField("sphere_diameter", "Sphere diameter", min=0.0),
        ),
    ),
    ArtefactKind(
        "flat",
        "Flat",
        (
            ArtefactField("length", "Length", min=0.0),
            ArtefactField("width", "Width", min=0.0),
            ArtefactField(
                "flatness", "Flatness (calibrated)", min=0.0, certificate="flatness", uncertainty="flatness_uncertainty"
            ),
            ArtefactField("flatness_uncertainty", "Its uncertainty U", min=0.0),
        ),
    ),
    ArtefactKind(
        "ball_plate",
        "Ball plate (three spheres)",
        (
            ArtefactField("sphere_diameter", "Sphere diameter", min=0.0),
            ArtefactField(
                "lengths",
                "Lengths L1, L2, L3 (calibrated)",
                kind="vector",
                size=3,
                min=0.0,
                certificate="length_{i}",
                uncertainty="uncertainty",
                help="L1 = |c1 c2|, L2 = |c2 c3|, L3 = |c3 c1| (thesis fig. 4.3)",
            ),
            _u("Their uncertainty U"),
            _K,
        ),
    ),
)

REQUIREMENTS = (
    "Sphere diameter 0.02..0.2 L0 (L0: the volume diagonal); ball bar length at least 0.3 L0; flat width at "
    "least 50 mm and length at least 0.5 L0; part 3: the ball plate's longest length at least 0.3 L0.",
    "Artefact form, ball-bar calibration and flatness substantially less than the MPE (read as at most 0.2 MPE).",
)


#: The plan keys besides the setup form's (docs/standards.md "The plan"), declared as
#: parameters (:class:`camcmm.api.Param` dicts) so that the GUI builds a form from them.
#: ``name`` is the plan key (a dotted name is nested: ``options.extract_sphere``);
#: ``label`` and ``labels`` (per choice) are what a person reads. A key left unset keeps
#: the standard's default.
PLAN_OPTIONS: tuple[dict[str, Any], ...] = (
    {
        "name": "outliers",
        "label": "Outlier rule (every test)",
        "type": "choice",
        "choices": ["vdi2634", "none", "percent:5", "sigma:3"],
        "labels": {
            "vdi2634": "VDI/VDE 2634: at most 3 of every 1000 points removed",
            "none": "no points removed",
            "percent:5": "the 5 % farthest points removed (thesis ch. 4.5.1)",
            "sigma:3": "points beyond 3 standard deviations removed",
        },
        "help": "Which points a fit may leave out; a plan may set one rule per test (import it as YAML).",
    },
    {
        "name": "unit",
        "label": "Unit of files that do not state one",
        "type": "choice",
        "choices": ["mm", "m", "um", "in"],
        "labels": {"mm": "mm", "m": "m", "um": "µm", "in": "inch"},
        "help": "A PLY or XYZ file without a unit is read in this unit (default mm).",
    },
    {
        "name": "options.extract_sphere",
        "label": "Sphere clouds still hold their holder: extract the sphere first",
        "type": "bool",
        "help": "Find the sphere in each sphere cloud before the fit (the holder and the table are left out).",
    },
)
#: Part 3 also: repeats (ISO 10360-8) and the scaling of each test (thesis ch. 4.5).
PLAN_OPTIONS_PART3: tuple[dict[str, Any], ...] = (
    {
        "name": "repeats",
        "label": "Repeats of every position",
        "type": "int",
        "min": 1,
        "max": 20,
        "help": "How often each position is measured (ISO 10360-8; default 3).",
    },
    {
        "name": "scaling.sphere",
        "label": "Scaling of the sphere reconstructions",
        "type": "choice",
        "choices": ["none", "radii"],
        "labels": {"none": "none (the system measures in mm)", "radii": "by the calibrated sphere radii"},
        "help": "Thesis ch. 4.5: a reconstruction without scale is scaled by the ball plate's spheres.",
    },
    {
        "name": "scaling.ball_plate",
        "label": "Scaling of the ball-plate reconstructions",
        "type": "choice",
        "choices": ["none", "radii", "lengths"],
        "labels": {
            "none": "none (the system measures in mm)",
            "radii": "by the calibrated sphere radii",
            "lengths": "by the calibrated lengths (eqs. 4.10-4.12)",
        },
        "help": "Thesis ch. 4.5: L1 and L2 scale the reconstruction, L3 is the test length.",
    },
)


def plan_options(part: int) -> list[dict[str, Any]]:
    """The declared plan options of a part (copies: a caller may change them)."""
    return [dict(d) for d in PLAN_OPTIONS + (PLAN_OPTIONS_PART3 if part == 3 else ())]


def declare(sid: str, title: str, part: int, specs, repeats: int) -> StandardDeclaration:
    """The declaration of one part from its test specs (``TestSpec`` of :mod:`.standard`)."""
    tests = tuple(
        TestDeclaration(s.test, s.label, s.test, tuple(s.parameters), s.min_count, repeats, s.required) for s in specs
    )
    pos = []
    for s in specs:
        for p in positions.for_test(s.test, part):
            extra = {k: v for k, v in p.items() if k not in ("id", "label", "hint", "where")}
            pos.append(
                PositionSpec(
                    s.test,
                    p["id"],
                    p["label"],
                    s.test,
                    p.get("hint", ""),
                    repeats,
                    tuple(p.get("where") or (0.0, 0.0, 0.0)),
                    extra,
                )
            )
    used = {s.test for s in specs}
    return StandardDeclaration(
        sid, title, PARAMETERS, tuple(a for a in ARTEFACTS if a.kind in used), tests, tuple(pos), REQUIREMENTS
    )
