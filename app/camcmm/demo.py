"""The demo project: simulated measurements a new user can open at once.

The clouds are generated here with known geometry (so every figure the demo shows can
be checked): a partially covered sphere scan with noise, a flat with a slight bow, a
ball bar, and the ball's nominal twice: exact, as a STEP sphere (OpenCascade), and as a
5120-facet mesh whose chords lie up to 11.4 µm inside the sphere (a comparison with it
carries that bias and says so; with the STEP it carries none). Seeded, so the demo is the
same on every machine.

Beside them the demo holds a finished VDI/VDE 2634 part 2 acceptance test: the
virtual lab (plugin ``virtuallab.acceptance-set``) simulates every measurement the
standard asks for — noise, partial coverage as a stereo fringe-projection system sees
it, and a systematic distortion of the measuring volume like the one of thesis ch.
3.3.1 — and the standard plugin (``vdi2634-2``) evaluates each one, summarises and
writes the report. The core knows neither plugin: both are found through the host by
the task they provide, and the test runs through the headless acceptance task
(:class:`camcmm.tasks.acceptance.Wizard`) exactly as an operator runs it in the GUI:
setup, one import per position, the report. If a plugin is missing the demo still
creates the rest and says so. The test's state is the wizard's own, under the project
state key ``acceptance.current``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .errors import CamcmmError, InputError
from .host import default_host
from .model import PointCloud, TriangleMesh
from .project import Project
from .tasks.acceptance import FORM_KEYS, STATE_KEY, Wizard

SEED = 2634
ACCEPTANCE_STATE = STATE_KEY
#: what the demo runs, found by the task a plugin declares (``provides``, docs/manifest.md):
#: a lab's own plugin for a task replaces camcmm's (``PluginHost.provider``)
STANDARD_TASK = "area-scanning-acceptance-test"
SIMULATOR_TASK = "acceptance-set-simulation"
#: The simulated system: noise like the thesis's stereo fringe projection (ch. 5.3:
#: 20-30 um standard deviation of the radial deviations), a small global scale error,
#: a radial term and a repeatable periodic pattern (ch. 3.3.1, 3.3.2: local scale that
#: varies through the volume, so sphere sizes vary more than ball-bar lengths).
#: The measuring volume is 90 mm cubed (L0 = 155.9 mm) so that the thesis's artefacts meet
#: every artefact rule of VDI/VDE 2634-2 (rules.py): in the virtual lab's default 100 mm cube
#: (L0 = 173.2 mm) the 49.944 mm ball bar is shorter than 0.3 L0 = 51.96 mm; here 0.3 L0 =
#: 46.77 mm, the sphere (20 mm) lies in 0.02..0.2 L0 = 3.12..31.18 mm, the flat (150 mm) is
#: longer than 0.5 L0 = 77.94 mm. A showcase test must pass the standard it demonstrates.
DEMO_VOLUME = [90.0, 90.0, 90.0]
SIMULATION = {
    "measuring_volume": DEMO_VOLUME,
    "n_sphere": 20_000,
    "n_ball_bar": 15_000,
    "n_flat": 40_000,
    "noise": 0.02,
    "scale_error": 1e-4,
    "quadratic": 5e-4,
    "amplitude": 0.012,
    "wavelength": 40.0,
    "seed": SEED,
}


def _sphere_scan(rng: np.random.Generator, center, radius: float, n: int, noise: float, cap_deg: float = 120.0):
    """Points spread uniformly over the cap of a sphere a scanner sees from +z (polar
    angle 0..``cap_deg``), with normal noise of ``noise`` mm along the radius.
    Returns the points and each point's radial deviation (mm)."""
    cos_min = np.cos(np.radians(cap_deg))
    u = rng.uniform(cos_min, 1.0, n)  # uniform on the cap's area
    phi = rng.uniform(0.0, 2 * np.pi, n)
    s = np.sqrt(1.0 - u**2)
    dirs = np.column_stack([s * np.cos(phi), s * np.sin(phi), u])
    r = radius + rng.normal(0.0, noise, n)
    return np.asarray(center) + dirs * r[:, None], r - radius


def _flat(rng: np.random.Generator, length: float, width: float, n: int, noise: float, bow: float):
    x = rng.uniform(-length / 2, length / 2, n)
    y = rng.uniform(-width / 2, width / 2, n)
    z = bow * (1.0 - (2 * x / length) ** 2) + rng.normal(0.0, noise, n)
    return np.column_stack([x, y, z])


def _icosphere(radius: float, subdivisions: int = 4) -> TriangleMesh:
    """A sphere mesh by subdividing an icosahedron (exact vertices on the sphere)."""
    t = (1 + 5**0.5) / 2
    v = np.array(
        [
            [-1, t, 0],
            [1, t, 0],
            [-1, -t, 0],
            [1, -t, 0],
            [0, -1, t],
            [0, 1, t],
            [0, -1, -t],
            [0, 1, -t],
            [t, 0, -1],
            [t, 0, 1],
            [-t, 0, -1],
            [-t, 0, 1],
        ],
        float,
    )
    f = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ]
    )
    for _ in range(subdivisions):
        edges = np.sort(np.vstack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = len(v) + inverse.reshape(3, -1).T  # midpoint index of edges 01, 12, 20
        v = np.vstack([v, v[unique].mean(axis=1)])
        a, b, c = f.T
        ab, bc, ca = mid.T
        f = np.vstack([np.column_stack(x) for x in ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))])
    v = v / np.linalg.norm(v, axis=1, keepdims=True) * radius
    return TriangleMesh(v, f, name="sphere nominal (CAD)")


def create_demo(directory: str | Path, acceptance: bool = True) -> dict[str, Any]:
    """Create (or re-open) the demo project in ``directory``; returns a summary dict.

    A project made before the acceptance test or the exact STEP nominal existed gets them
    added."""
    directory = Path(directory)
    with Project.open_or_create(directory, name="camcmm demo") as project:
        if not project.measurements():
            _clouds(project)
        if not any(m["name"] == STEP_NOMINAL for m in project.measurements()):
            _step_nominal(project)  # also into a demo made before the exact nominal existed
        notes = []
        if acceptance and project.get_state(ACCEPTANCE_STATE) is None:
            notes = _acceptance_test(project)
        return _summary(project, notes)


def _clouds(project: Project) -> None:
    rng = np.random.default_rng(SEED)
    pts, dev = _sphere_scan(rng, (10.0, -5.0, 40.0), 10.0, 60_000, 0.004)
    sphere = PointCloud(
        pts, fields={"radial_deviation": dev}, field_units={"radial_deviation": "mm"}, name="sphere scan (20 mm ball)"
    )
    a, _ = _sphere_scan(rng, (-25.0, 0.0, 0.0), 10.0, 40_000, 0.005)
    b, _ = _sphere_scan(rng, (24.944, 0.0, 0.0), 10.0, 40_000, 0.005)
    ballbar = PointCloud(np.vstack([a, b]), name="ball bar (49.944 mm)")
    flat = PointCloud(_flat(rng, 150.0, 60.0, 80_000, 0.003, 0.010), name="flat (150 x 60 mm)")
    for cloud, kind in (
        (sphere, "pointcloud"),
        (ballbar, "pointcloud"),
        (flat, "pointcloud"),
        (_icosphere(10.0), "mesh"),
    ):
        project.add_measurement(cloud.name, project.add_object(cloud, cloud.name), kind=kind)


#: The name of the demo's exact nominal (a STEP sphere of radius 10 mm about the origin).
STEP_NOMINAL = "exact sphere (STEP)"  # not "sphere nominal ...": tests pick the mesh by that text


def _step_nominal(project: Project) -> None:
    """The ball's exact nominal, written as STEP by OpenCascade and kept as the file itself
    (read back by camcmm.cad.read_cad): compared with it, the scan's deviations carry no
    facet error."""
    from .cad.write import sphere_step

    try:
        with tempfile.TemporaryDirectory(prefix="camcmm-demo-") as tmp:
            h = project.add_file(sphere_step(Path(tmp) / "sphere nominal.step", 10.0))
    except (ImportError, InputError):  # no OpenCascade: the demo keeps its mesh nominal
        return
    project.add_measurement(STEP_NOMINAL, h, kind="cad", meta={"summary": "STEP CAD model, 1 face (sphere, 20 mm)"})


def _summary(project: Project, notes: list[str] | None = None) -> dict[str, Any]:
    out: dict[str, Any] = {
        "project": str(project.path),
        "name": project.name,
        "measurements": [{"id": m["id"], "name": m["name"], "kind": m["kind"]} for m in project.measurements()],
    }
    state = project.get_state(ACCEPTANCE_STATE)
    if state and state.get("summary_result") is not None:
        summary = project.result(state["summary_result"])
        out["acceptance"] = {
            "standard": state["standard"],
            "summary_result": state["summary_result"],
            "verdict": summary["outputs"].get("verdict"),
            "verdict_guarded": summary["outputs"].get("verdict_guarded"),
            "parameters": {
                k: {"value": v.get("value"), "mpe": v.get("mpe"), "verdict": v.get("verdict")}
                for k, v in summary["outputs"].get("parameters", {}).items()
            },
        }
    out["notes"] = list(notes or [])
    return out


# -- the acceptance test ----------------------------------------------------------------------
def _acceptance_test(project: Project) -> list[str]:
    """Simulate, evaluate and report a complete part-2 test into the project; returns
    notes for the operator (e.g. a missing plugin). Never raises for a plugin problem:
    the rest of the demo stays usable."""
    host = default_host()
    try:
        standard, simulator = host.provider(STANDARD_TASK).id, host.provider(SIMULATOR_TASK).id
        with tempfile.TemporaryDirectory(prefix="camcmm-demo-") as tmp:
            gen = host.run(
                simulator, {}, {"directory": str(Path(tmp) / "measurements"), "standard": standard, **SIMULATION}
            )
            plan, folder = gen.outputs["plan_dict"], Path(gen.outputs["plan"]).parent
            wizard = run_plan(project, host, standard, plan, folder, system_meta={"simulated_by": simulator})
    except CamcmmError as exc:
        return [f"no acceptance test in the demo: {exc}"]
    failed = [f"{key}: {msg}" for key, msg in ((wizard.state or {}).get("errors") or {}).items()]
    return [f"demo acceptance test: {x}" for x in failed]


def run_plan(
    project: Project, host: Any, standard: str, plan: dict[str, Any], folder: Path, system_meta: dict | None = None
) -> Wizard:
    """A whole acceptance test through the wizard, as an operator would run it: set up
    from a plan (the simulator's ``plan.yaml``: system, MPEs, artefacts, options), import
    each file of ``plan["measurements"]`` (names in ``folder``, in position order; a list
    of names per position for repeats) at its position, and finish with the report."""
    wizard = Wizard(project, host)
    reqs = {r["test"]: r for r in wizard.standard(standard).requirements(plan)}
    tests = list(plan["measurements"])
    artefacts = {}
    for test in tests:
        art = reqs[test].get("artefact") or {"id": test}
        artefacts[test] = {
            **plan["artefacts"][test],
            "_id": f"{standard}:{art['id']}",
            "_name": art.get("name") or f"{test.replace('_', ' ')} (simulated)",
        }
    wizard.setup(
        standard,
        plan["system"]["name"],
        plan["system"]["measuring_volume"],
        plan["mpe"],
        artefacts,
        tests=tests,
        options={k: v for k, v in plan.items() if k not in FORM_KEYS and k != "name"},
        system_meta=system_meta,
    )
    for test in tests:
        positions = wizard.requirement(test)["positions"]
        for position, entry in zip(positions, plan["measurements"][test]):
            names = entry if isinstance(entry, list) else [entry]
            for repeat, name in enumerate(names, start=1):
                wizard.import_measurement(test, position["id"], folder / name, repeat=repeat)
    wizard.report()
    return wizard
