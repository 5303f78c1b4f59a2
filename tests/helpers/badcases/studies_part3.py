"""Bad inputs of ``camcmm study speckle`` and of ``camcmm verify`` with VDI/VDE 2634
part-3 plans (issue 26).

The study file is validated as one schema before anything is created or listed: each
problem one line naming the file, the key path (``capture.simulated.n_images``) and the
value. No case runs a reconstruction: every study here is refused by that validation,
but for the one whose every case fails (images of 8 x 8 px, refused by the
reconstruction's first check), which exits 3 naming the study and the failed cases.

The part-3 plans measure a ball plate exact by construction (three spheres of 0.37 x
5 mm whose centres are 0.37 x the calibrated 5.942 / 7.956 / 9.957 mm apart: a
reconstruction at scale 0.37), scaled by the calibrated lengths; wrong lengths (x 10,
x 0.1, negative, NaN, missing, too few, not a triangle), wrong counts, clouds that do not
match and bad scaling keys are refused in one line, or the measurement is (the verdict
incomplete, the reason in ``warnings``); as every part-3 plan here lacks the sphere
measurements (its verdict is incomplete anyway), tests/standards/test_part3_bad_plans.py
checks that each case exiting 0 has a warning naming what its ``names`` say.

Ids start with ``sp-``: ``sp-study-`` the speckle study, ``sp-part3-`` part-3 plans.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from helpers.badinputs import ALIAS_BOMB, BAD_UTF8, Case, _xyz_text, ply_binary, png

STUDY = "STUDY.yaml"
#: one artefact, material and condition: the smallest study (simulated by default)
ONE = "artefacts: [am_pyramid]\nmaterials: [abs]\nconditions: [off]\n"
IMAGE_ENTRY = "    - {{artefact: am_pyramid, material: abs, condition: off, folder: {folder}{extra}}}\n"


def _images(folder: str, n: int = 3, data: bytes | None = None) -> dict[str, bytes]:
    return {f"{folder}/{k}.png": data if data is not None else _tiny() for k in range(n)}


@functools.cache
def _tiny() -> bytes:
    return png(8, 8)


def _with_images(folder: str = "img", extra: str = "", head: str = ONE) -> str:
    return head + "capture:\n  images:\n" + IMAGE_ENTRY.format(folder=folder, extra=extra)


def _study_cases() -> list[Case]:
    cases: list[Case] = []

    def sc(cid: str, text: str | bytes, names: tuple[str, ...], files: dict[str, bytes] | None = None) -> None:
        data = text.encode() if isinstance(text, str) else text
        cases.append(
            Case(f"sp-study-{cid}", ("study", "speckle", STUDY, "--json"), {STUDY: data, **(files or {})}, names)
        )

    # the file itself
    sc("empty", b"", (STUDY,))
    sc("a-list", "- am_pyramid\n- abs\n", (STUDY,))
    sc("a-number", "42\n", (STUDY,))
    sc("junk", np.random.default_rng(3).integers(0, 256, 3000, dtype=np.uint8).tobytes(), (STUDY,))
    sc("bad-utf8", BAD_UTF8 * 10, (STUDY,))
    sc("not-yaml", "artefacts: [unclosed\n", (STUDY,))
    sc("alias-bomb", ALIAS_BOMB, (STUDY, "alias"))
    sc("duplicate-key", ONE + "materials: [nylon12]\n", (STUDY, "materials"))
    sc("unknown-key", ONE + "speed: fast\n", (STUDY, "speed"))
    cases.append(Case("sp-study-missing", ("study", "speckle", "none.yaml"), {}, ("none.yaml",)))
    cases.append(Case("sp-study-a-folder", ("study", "speckle", "d"), {"d/": b""}, ("d",)))
    # strings (or lists) where a mapping belongs
    sc("capture-string", ONE + "capture: simulated\n", (STUDY, "capture"))
    sc("capture-list", ONE + "capture: [simulated]\n", (STUDY, "capture"))
    sc("capture-empty", ONE + "capture: {}\n", (STUDY, "capture"))
    sc("capture-both", ONE + "capture: {simulated: {}, images: []}\n", (STUDY, "capture"))
    sc("capture-unknown", ONE + "capture: {rendered: {}}\n", (STUDY, "capture.rendered"))
    sc("simulated-string", ONE + "capture: {simulated: fast}\n", (STUDY, "capture.simulated"))
    sc("reconstruct-string", ONE + "reconstruct: big\n", (STUDY, "reconstruct"))
    sc("align-list", ONE + "align: [auto]\n", (STUDY, "align"))
    sc("coverage-number", ONE + "coverage: 3\n", (STUDY, "coverage"))
    sc("sizes-string", "artefacts: [{name: am_sphere, sizes: big}]\nmaterials: [abs]\n", (STUDY, "sizes"))
    sc("images-string", ONE + "capture: {images: img}\n", (STUDY, "capture.images"))
    sc("image-entry-string", ONE + "capture: {images: [img]}\n", (STUDY, "capture.images[0]"))
    sc("pairs-string", _with_images(extra=", pairs: three"), (STUDY, "pairs"), _images("img"))
    # every key's type and range (the declarations of the plugins the settings go to)
    for key, value in (
        ("n_images", "0"),
        ("n_images", "-3"),
        ("n_images", "many"),
        ("n_images", "1e9"),
        ("n_images", "true"),
        ("downscale", "0"),
        ("downscale", ".nan"),
        ("elevation", "100"),
        ("arc_deg", "0"),
        ("supersample", "99"),
        ("seed", "-1"),
        ("distance", ".inf"),
        ("n_pictures", "3"),
        ("f_number", "null"),
    ):
        cid = f"simulated-{key}-{value.strip('.').replace('-', 'minus')}"
        sc(cid, ONE + f"capture: {{simulated: {{{key}: {value}}}}}\n", (STUDY, f"capture.simulated.{key}"))
    for key, value in (
        ("max_image_size", "10"),
        ("max_image_size", "big"),
        ("dense", "maybe"),
        ("camera_model", "FISHEYE"),
        ("scheduler", "'tcp://127.0.0.1:1'"),
        ("scale", "'lengths:/etc/shadow'"),
        ("turntable_window", "-5"),
    ):
        sc(f"reconstruct-{key}-{value.strip(chr(39))[:12]}", ONE + f"reconstruct: {{{key}: {value}}}\n", (STUDY, key))
    for key, value in (
        ("method", "magic"),
        ("inlier_distance", "-1"),
        ("min_overlap", "2"),
        ("region", "[1, 2]"),
        ("max_iterations", "0"),
        ("kernel", "gauss"),
    ):
        sc(f"align-{key}-{value}", ONE + f"align: {{{key}: {value}}}\n", (STUDY, f"align.{key}"))
    for key, value in (("samples", "5"), ("samples", "1e12"), ("distance", "-1"), ("distance", "far")):
        sc(f"coverage-{key}-{value}", ONE + f"coverage: {{{key}: {value}}}\n", (STUDY, f"coverage.{key}"))
    # names: unknown, twice, none
    sc("artefact-unknown", "artefacts: [am_cube]\n", (STUDY, "am_cube"))
    sc("artefact-twice", "artefacts: [am_sphere, am_sphere]\nmaterials: [abs]\n", (STUDY, "am_sphere"))
    sc("artefacts-empty", "artefacts: []\n", (STUDY, "artefacts"))
    sc("artefact-no-name", "artefacts: [{sizes: {diameter: 20}}]\n", (STUDY, "artefacts[0].name"))
    sc("artefact-key-unknown", "artefacts: [{name: am_sphere, size: {}}]\n", (STUDY, "artefacts[0].size"))
    sc("material-unknown", "materials: [steel]\n", (STUDY, "steel"))
    sc("material-number", "materials: [5]\n", (STUDY, "materials[0]"))
    sc("material-twice", "materials: [abs, abs]\n", (STUDY, "abs"))
    sc("condition-unknown", "conditions: [sideways]\n", (STUDY, "sideways"))
    sc("condition-twice", "conditions: [on, on]\n", (STUDY, "conditions[1]"))
    sc("name-list", ONE + "name: [a, b]\n", (STUDY, "name"))
    sc("name-too-long", ONE + f"name: {'x' * 300}\n", (STUDY, "name"))
    # artefact sizes: not numbers, not finite, far too large, or no part at all
    for cid, sizes, names in (
        ("sizes-nan", "{diameter: .nan}", ("sizes.diameter",)),
        ("sizes-huge", "{diameter: 1e300}", ("sizes.diameter",)),
        ("sizes-text", "{diameter: wide}", ("sizes.diameter",)),
        ("sizes-nested-text", "{plate: [a, b]}", ("sizes.plate",)),
        ("sizes-no-part", "{centre_height: 99}", ("centre_height", "sizes")),
        ("sizes-unknown", "{height: 3}", ("height", "sizes")),
    ):
        sc(cid, f"artefacts: [{{name: am_sphere, sizes: {sizes}}}]\nmaterials: [abs]\nconditions: [off]\n", names)
    # the work folder: a file, under a file, a link to a file, no folder name at all
    sc("work-a-file", ONE + "work: taken\n", (STUDY, "work"), {"taken": b"x"})
    sc("work-under-a-file", ONE + "work: taken/sub/w\n", (STUDY, "work"), {"taken": b"x"})
    sc("work-link-to-file", ONE + "work: link\n", (STUDY, "work"), {"taken": b"x", "link": b"->taken"})
    sc("work-empty", ONE + "work: ''\n", (STUDY, "work"))
    sc("work-list", ONE + "work: [a]\n", (STUDY, "work"))
    sc("work-nul", ONE + 'work: "a\\0b"\n', (STUDY, "work"))
    # image folders: missing, a file, empty, too few, not images, no folder, twice, no case
    sc("images-missing", _with_images("gone"), (STUDY, "gone"))
    sc("images-a-file", _with_images("img"), (STUDY, "img"), {"img": b"x"})
    sc("images-empty", _with_images("img"), (STUDY, "img"), {"img/": b""})
    sc("images-two", _with_images("img"), (STUDY, "img"), _images("img", 2))
    sc("images-only-text", _with_images("img"), (STUDY, "img"), {f"img/{k}.txt": b"x" for k in range(5)})
    sc("images-not-images", _with_images("img"), (STUDY, "2.png"), {**_images("img", 2), "img/2.png": b"text"})
    sc(
        "images-no-folder",
        ONE + "capture: {images: [{artefact: am_pyramid, material: abs, condition: off}]}\n",
        (STUDY, "folder"),
    )
    sc("images-folder-number", _with_images("5"), (STUDY, "5"))
    sc("images-none-for-case", ONE + "capture: {images: []}\n", (STUDY, "am_pyramid-abs-off"))
    sc(
        "images-case-twice",
        _with_images() + IMAGE_ENTRY.format(folder="img", extra=""),
        (STUDY, "images[1]"),
        _images("img"),
    )
    sc("images-condition-unknown", _with_images().replace("condition: off", "condition: maybe"), (STUDY, "maybe"))
    sc(
        "pairs-too-few",
        _with_images(extra=", pairs: {measured: [[0,0,0]], nominal: [[0,0,0]]}"),
        (STUDY, "pairs"),
        _images("img"),
    )
    sc(
        "pairs-nan",
        _with_images(extra=", pairs: {measured: [[0,0,.nan],[1,0,0],[0,1,0]], nominal: [[0,0,0],[1,0,0],[0,1,0]]}"),
        (STUDY, "pairs"),
        _images("img"),
    )
    sc(
        "pairs-counts",
        _with_images(
            extra=", pairs: {measured: [[0,0,0],[1,0,0],[0,1,0],[1,1,0]], nominal: [[0,0,0],[1,0,0],[0,1,0]]}"
        ),
        (STUDY, "pairs"),
        _images("img"),
    )
    # every case fails (8 x 8 px images: the reconstruction refuses them at once): exit 3
    both = ONE.replace("conditions: [off]", "conditions: [off, on]")
    text = _with_images("a", head=both) + IMAGE_ENTRY.format(folder="b", extra="").replace("off,", "on,")
    sc("all-cases-fail", text, (STUDY, "every case failed"), {**_images("a"), **_images("b")})
    return cases


# -- part 3 ---------------------------------------------------------------------------------
L_CAL = [5.942, 7.956, 9.957]  # thesis ch. 4.3
SCALE = 0.37


@functools.cache
def plate(scale: float = SCALE, n: int = 1200) -> bytes:
    """The ball plate exact by construction at ``scale`` (PLY): |c1c2| = L1, |c2c3| = L2,
    |c3c1| = L3 (x scale), spheres of scale x 5 mm, points exactly on them."""
    l1, l2, l3 = (scale * x for x in L_CAL)
    x = (l3**2 - l2**2 + l1**2) / (2 * l1)
    centres = np.array([(0.0, 0.0, 0.0), (l1, 0.0, 0.0), (x, math.sqrt(l3**2 - x**2), 0.0)])
    v = np.random.default_rng(7).normal(size=(3, n, 3))
    v /= np.linalg.norm(v, axis=2, keepdims=True)
    return ply_binary((centres[:, None, :] + scale * 2.5 * v).reshape(-1, 3))


def _part3(**over) -> bytes:
    import yaml

    doc = {
        "standard": "vdi2634-3",
        "system": {"name": "turntable", "measuring_volume": [30, 30, 30]},
        "mpe": {"PF": 0.06, "PS": 0.03, "SD": 0.04},
        "artefacts": {
            "sphere": {"diameter": 10.0, "uncertainty": 0.0008, "k": 2},
            "ball_plate": {"sphere_diameter": 5.0, "lengths": L_CAL, "uncertainty": 0.0003, "k": 2},
        },
        "scaling": {"ball_plate": "lengths"},
        "measurements": {"ball_plate": ["bp.ply"]},
    }
    for key, value in over.items():
        if key.startswith("bp_"):  # a ball-plate key
            plate_d = doc["artefacts"]["ball_plate"]  # type: ignore[index]
            if value is None:
                plate_d.pop(key[3:], None)
            else:
                plate_d[key[3:]] = value
        else:
            doc[key] = value
    return yaml.safe_dump(doc, sort_keys=False).encode()


def _part3_cases() -> list[Case]:
    cases: list[Case] = []

    def pc(cid: str, plan: bytes, names: tuple[str, ...], files: dict[str, bytes] | None = None) -> None:
        f = {"plan.yaml": plan, "bp.ply": plate(), **(files or {})}
        cases.append(Case(f"sp-part3-{cid}", ("verify", "plan.yaml", "--json"), f, names))

    # calibrated lengths: 10 x (the measured plate refuses them), 0.1 x (its spheres would
    # overlap), 1.5 x (a warning), not numbers, too few or many, no triangle
    pc("lengths-x10", _part3(bp_lengths=[10 * x for x in L_CAL]), ("lengths[2]",))
    pc("lengths-x0.1", _part3(bp_lengths=[0.1 * x for x in L_CAL]), ("plan.yaml", "lengths"))
    pc("lengths-x1.5", _part3(bp_lengths=[1.5 * x for x in L_CAL]), ("lengths[2]",))
    pc("lengths-negative", _part3(bp_lengths=[-5.942, 7.956, 9.957]), ("plan.yaml", "lengths[0]"))
    pc("lengths-zero", _part3(bp_lengths=[0, 7.956, 9.957]), ("plan.yaml", "lengths[0]"))
    pc("lengths-nan", _part3(bp_lengths=[5.942, float("nan"), 9.957]), ("plan.yaml", "lengths[1]"))
    pc("lengths-inf", _part3(bp_lengths=[5.942, 7.956, float("inf")]), ("plan.yaml", "lengths[2]"))
    pc("lengths-text", _part3(bp_lengths=[5.942, "long", 9.957]), ("plan.yaml", "long"))
    pc("lengths-missing", _part3(bp_lengths=None), ("plan.yaml", "lengths"))
    pc("lengths-two", _part3(bp_lengths=L_CAL[:2]), ("plan.yaml", "lengths"))
    pc("lengths-four", _part3(bp_lengths=L_CAL + [12.0]), ("plan.yaml", "lengths"))
    pc("lengths-string", _part3(bp_lengths="5.942 7.956 9.957"), ("plan.yaml", "lengths"))
    pc("lengths-no-triangle", _part3(bp_lengths=[5.942, 7.956, 20.0]), ("plan.yaml", "triangle"))
    pc("lengths-other-plate", _part3(bp_lengths=[5.942, 9.957, 9.957]), ("bp.ply",))
    pc("sphere-diameter-missing", _part3(bp_sphere_diameter=None), ("plan.yaml", "sphere_diameter"))
    pc("sphere-diameter-zero", _part3(bp_sphere_diameter=0), ("plan.yaml", "sphere_diameter"))
    pc("sphere-diameter-x10", _part3(bp_sphere_diameter=0.5), ("lengths[2]",))
    pc("uncertainty-negative", _part3(bp_uncertainty=-0.001), ("plan.yaml", "uncertainty"))
    pc("k-zero", _part3(bp_k=0), ("plan.yaml", "k"))
    pc("volume-nan", _part3(system={"measuring_volume": [30, float("nan"), 30]}), ("plan.yaml", "measuring_volume"))
    pc("volume-small", _part3(system={"measuring_volume": [3, 3, 3]}), ("longer than the measuring volume's diagonal",))
    # scaling keys
    pc("scaling-mode", _part3(scaling={"ball_plate": "stretch"}), ("plan.yaml", "scaling.ball_plate"))
    pc("scaling-test", _part3(scaling={"cube": "lengths"}), ("plan.yaml", "scaling.cube"))
    pc("scaling-all-lengths", _part3(scaling="lengths"), ("plan.yaml", "scaling.ball_bar"))
    pc("scaling-list", _part3(scaling=["lengths"]), ("plan.yaml", "scaling"))
    pc(
        "scaling-radii-no-plate",
        _part3(artefacts={"sphere": {"diameter": 10.0}}, scaling={"sphere": "radii"}, measurements={}),
        ("plan.yaml", "ball_plate"),
    )
    # counts
    pc("repeats-zero", _part3(repeats=0), ("plan.yaml", "repeats"))
    pc("repeats-text", _part3(repeats="three"), ("plan.yaml", "three"))
    pc("measurements-string", _part3(measurements={"ball_plate": "bp.ply"}), ("plan.yaml", "measurements.ball_plate"))
    pc("measurements-unknown-test", _part3(measurements={"ball_plates": ["bp.ply"]}), ("plan.yaml", "ball_plates"))
    pc("no-plate-artefact", _part3(artefacts={"sphere": {"diameter": 10.0}}), ("plan.yaml", "ball_plate"))
    # clouds that do not match the plan
    sphere = np.random.default_rng(2).normal(size=(2000, 3))
    sphere = 5.0 * sphere / np.linalg.norm(sphere, axis=1, keepdims=True)
    pc("cloud-one-sphere", _part3(), ("bp.ply",), {"bp.ply": ply_binary(sphere)})
    pc("cloud-five-points", _part3(), ("bp.ply",), {"bp.ply": ply_binary(sphere[:5])})
    pc("cloud-junk", _part3(), ("bp.ply",), {"bp.ply": np.random.default_rng(5).bytes(900)})
    pc("cloud-missing", _part3(measurements={"ball_plate": ["gone.ply"]}), ("gone.ply",))
    pc(
        "cloud-nan",
        _part3(measurements={"ball_plate": ["bp.xyz"]}),
        ("bp.xyz",),
        {"bp.xyz": _xyz_text(sphere[:300]) + b"nan 0 0\n"},
    )
    return cases


def cases() -> list[Case]:
    return _study_cases() + _part3_cases()
