"""What VDI/VDE 2634 parts 2 and 3 declare (:class:`camcmm.api.StandardDeclaration`):
the quality parameters with their symbols and signs, the artefacts with the plan fields
a lab fills from its calibration certificates, and the tests and positions. The GUI
reads all of this from here; nothing about VDI/VDE 2634 is written in the GUI."""

from __future__ import annotations

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
