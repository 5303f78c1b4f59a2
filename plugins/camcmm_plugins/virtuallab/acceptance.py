"""A complete simulated acceptance test: every measurement a VDI/VDE 2634 plan asks
for, written as point-cloud files with the plan (plan.yaml) and the truth (truth.json).

Positions come from the standard plugin itself (``requirements()`` through the host),
so the virtual lab places its artefacts exactly where the standard — and the wizard —
asks the operator to. Artefacts and MPEs are the thesis's: part 2 the stereo
fringe-projection system of ch. 5 (20 mm sphere, 49.944 mm ball bar, 150 x 60 mm flat,
MPEs 0.186/0.143/0.096/0.243 mm); part 3 the turntable system of ch. 4 (10 mm sphere,
ball plate 5.942/7.956/9.957 mm of 5 mm spheres). The part-3 MPEs are examples for a
virtual system (the thesis states expanded uncertainties, not MPEs).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from camcmm.api import ParameterError, PluginError, PointCloud, write

from .distortion import VolumeDistortion
from .plugin import build_scene, make_sensor
from .simulate import simulate

PART2: dict[str, Any] = {
    "volume": [100.0, 100.0, 100.0],
    "noise": 0.02,
    "sensor": "stereo_fringe",
    "system": "Virtual stereo fringe projection (camcmm virtual lab)",
    "mpe": {"PF": 0.186, "PS": 0.143, "SD": 0.096, "F": 0.243},
    "artefacts": {
        "sphere": {"diameter": 20.001, "uncertainty": 0.001, "k": 2},
        "ball_bar": {"length": 49.944, "uncertainty": 0.0008, "k": 2, "sphere_diameter": 20.0},
        "flat": {"length": 150.0, "width": 60.0, "flatness": 0.0026},
    },
}
PART3: dict[str, Any] = {
    "volume": [30.0, 30.0, 30.0],
    "noise": 0.008,
    "sensor": "turntable",
    "system": "Virtual turntable photogrammetry with laser speckle (camcmm virtual lab)",
    "mpe": {"PF": 0.060, "PS": 0.030, "SD": 0.040},
    "artefacts": {
        "sphere": {"diameter": 10.0, "uncertainty": 0.0008, "k": 2},
        "ball_plate": {
            "sphere_diameter": 5.0,
            "sphere_diameter_uncertainty": 0.0008,
            "lengths": [5.942, 7.956, 9.957],
            "uncertainty": 0.0003,
            "k": 2,
        },
    },
}
FLAT3 = {"length": 60.0, "width": 50.0, "flatness": 0.001}


def _positions(ctx, standard: str) -> dict[str, list[dict[str, Any]]]:
    try:
        std = ctx.host.load(standard)
        reqs = std.requirements()
    except Exception as exc:
        raise PluginError(
            f"virtuallab.acceptance-set lays out positions as the standard plugin {standard!r} "
            f"asks, but it is not usable: {exc}"
        ) from None
    return {r["test"]: r["positions"] for r in reqs}


def _scene_args(test: str, pos: dict[str, Any], vol: np.ndarray, art: dict[str, Any]) -> dict[str, Any]:
    centre = np.asarray(pos.get("where", [0, 0, 0]), float) * vol
    common = {
        "center": centre,
        "direction": pos.get("direction", [1, 0, 0]),
        "normal": pos.get("normal"),
        "diameter": 1.0,
        "length": 1.0,
        "width": 1.0,
        "lengths": (6.0, 8.0, 10.0),
        "scale_diameter": 1.0,
        "rotation": pos.get("rotation", 0.0),
        "tilt": pos.get("tilt", 0.0),
    }
    if test == "sphere":
        common["diameter"] = art["sphere"]["diameter"]
        if "ball_plate" in art:  # part 3: scale spheres beside the probing sphere (thesis ch. 4.5.1)
            common["scale_diameter"] = art["ball_plate"]["sphere_diameter"]
            return {"artefact": "sphere_with_scale", **common}
        return {"artefact": "sphere", **common}
    if test == "ball_bar":
        common.update(diameter=art["ball_bar"]["sphere_diameter"], length=art["ball_bar"]["length"])
    elif test == "flat":
        common.update(length=art["flat"]["length"], width=art["flat"]["width"])
    elif test == "ball_plate":
        common.update(diameter=art["ball_plate"]["sphere_diameter"], lengths=art["ball_plate"]["lengths"])
    return {"artefact": test, **common}


def acceptance_set(
    ctx,
    directory: str,
    standard: str = "vdi2634-2",
    measuring_volume=None,
    n_sphere: int = 20000,
    n_ball_bar: int = 20000,
    n_flat: int = 50000,
    n_ball_plate: int = 15000,
    noise: float | None = None,
    noise_model: str = "normal",
    scale_error: float = 0.0,
    quadratic: float = 0.0,
    amplitude: float = 0.0,
    wavelength: float = 40.0,
    random_scale: bool = False,
    repeats: int = 3,
    flats: bool = False,
    format: str = "ply",
    seed: int = 2634,
) -> dict[str, Any]:
    """Write the measurement set and plan.yaml into ``directory``."""
    part3 = standard == "vdi2634-3"
    base = PART3 if part3 else PART2
    vol = np.asarray(measuring_volume or base["volume"], float)
    noise = base["noise"] if noise is None else noise
    art = json.loads(json.dumps(base["artefacts"]))
    if part3 and flats:
        art["flat"] = dict(FLAT3)
    out = Path(directory)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError(f"directory {directory!r}: cannot create it ({exc})") from None
    layout = _positions(ctx, standard)
    dist = VolumeDistortion(
        scale_error, np.zeros(3), quadratic, amplitude, wavelength, reference_radius=float(np.linalg.norm(vol)) / 2
    )
    counts = {"sphere": n_sphere, "ball_bar": 2 * n_ball_bar, "flat": n_flat, "ball_plate": n_ball_plate}
    tests = [t for t in ("sphere", "ball_bar", "flat", "ball_plate") if t in art]
    n_rep = repeats if part3 else 1
    rng = np.random.default_rng(seed)
    jobs = [(t, i, pos, r) for t in tests for i, pos in enumerate(layout[t]) for r in range(n_rep)]
    measurements: dict[str, list] = {t: [] for t in tests}
    truths: dict[str, Any] = {}
    files = []
    for j, (test, i, pos, r) in enumerate(jobs):
        ctx.progress(j / len(jobs), f"simulating {pos['id']}")
        g = float(np.exp(rng.uniform(np.log(0.3), np.log(3.0)))) if (part3 and random_scale) else 1.0
        sensor = make_sensor(base["sensor"], (pos.get("camera") or {}).get("azimuth", 0.0))
        scene, truth = build_scene(**_scene_args(test, pos, vol, art))
        pts, _, truth = simulate(
            scene, truth, sensor, counts[test], noise, noise_model, dist, g, "mm", seed + 7919 * j + 1
        )
        name = f"{test.replace('_', '')}_{i + 1:02d}" + (f"_r{r + 1}" if part3 else "") + f".{format}"
        write(PointCloud(pts, name=name), out / name)
        truth.update({"test": test, "position": pos["id"], "repeat": r + 1})
        truths[name] = truth
        files.append(str(out / name))
        if part3:
            if r == 0:
                measurements[test].append([])
            measurements[test][-1].append(name)
        else:
            measurements[test].append(name)
    plan = {
        "standard": standard,
        "system": {"name": base["system"], "measuring_volume": vol.tolist()},
        "mpe": dict(base["mpe"], **({"F": 0.060} if part3 and flats else {})),
        "artefacts": art,
        "measurements": measurements,
        "outliers": ({"sphere": "percent:5", "ball_plate": "percent:5", "flat": "vdi2634"} if part3 else "vdi2634"),
        "simulation": {
            "noise": noise,
            "noise_model": noise_model,
            "sensor": base["sensor"],
            "seed": seed,
            "distortion": dist.to_dict(),
            "random_scale": bool(random_scale),
        },
    }
    if part3:
        plan.update({"scaling": {"sphere": "radii", "ball_plate": "lengths"}, "repeats": n_rep})
    (out / "plan.yaml").write_text(yaml.safe_dump(plan, sort_keys=False), encoding="utf-8")
    (out / "truth.json").write_text(json.dumps(truths, indent=1), encoding="utf-8")
    ctx.progress(1.0, "written")
    return {"plan": str(out / "plan.yaml"), "plan_dict": plan, "files": files, "truth": truths}
