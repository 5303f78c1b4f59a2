"""Entry points of the virtual lab (see plugin.yaml for the parameters)."""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError, ParameterError, PointCloud, TriangleMesh

from . import artefacts
from . import sensor as sensors
from .distortion import VolumeDistortion
from .simulate import simulate


def build_scene(
    artefact: str,
    center,
    direction,
    normal,
    diameter: float,
    length: float,
    width: float,
    lengths,
    scale_diameter: float,
    rotation: float,
    tilt: float,
):
    """(scene, truth) for one artefact; lengths in mm."""
    if artefact == "sphere":
        return artefacts.sphere(center, diameter)
    if artefact == "ball_bar":
        return artefacts.ball_bar(center, direction, length, diameter)
    if artefact == "flat":
        axis, n = artefacts.axes_from(direction, normal)
        return artefacts.flat(center, axis, n, length, width)
    if artefact == "ball_plate":
        return artefacts.ball_plate(center, lengths, diameter, rotation, tilt)
    if artefact == "sphere_with_scale":
        return artefacts.sphere_with_scale(center, diameter, scale_diameter)
    raise ParameterError(f"unknown artefact {artefact!r}")


def make_sensor(kind: str, camera_azimuth: float = 0.0) -> sensors.Sensor:
    if kind == "turntable":
        return sensors.turntable(start_azimuth=camera_azimuth)
    if kind == "full":
        return sensors.full()
    return sensors.stereo_fringe()


def artefact_cloud(
    ctx,
    artefact: str = "sphere",
    center=(0, 0, 0),
    direction=(1, 0, 0),
    normal=None,
    diameter: float = 20.0,
    length: float = 50.0,
    width: float = 60.0,
    lengths=(5.942, 7.956, 9.957),
    scale_diameter: float = 5.0,
    rotation: float = 0.0,
    tilt: float = 0.0,
    sensor: str = "stereo_fringe",
    camera_azimuth: float = 0.0,
    n_points: int = 20000,
    noise: float = 0.01,
    noise_model: str = "normal",
    scale_error: float = 0.0,
    axis_scale=(0, 0, 0),
    quadratic: float = 0.0,
    amplitude: float = 0.0,
    wavelength: float = 40.0,
    measuring_volume=(100, 100, 100),
    reconstruction_scale: float = 1.0,
    unit: str = "mm",
    seed: int = 0,
) -> dict[str, Any]:
    """Simulate one measurement; returns ``cloud`` and ``truth``."""
    ctx.progress(0.05, "building the scene")
    try:
        scene, truth = build_scene(
            artefact, center, direction, normal, diameter, length, width, lengths, scale_diameter, rotation, tilt
        )
    except ValueError as exc:
        raise ParameterError(f"virtuallab.artefact-cloud: {exc}") from None
    dist = VolumeDistortion(
        scale_error,
        np.asarray(axis_scale, float),
        quadratic,
        amplitude,
        wavelength,
        reference_radius=float(np.linalg.norm(measuring_volume)) / 2,
    )
    ctx.progress(0.2, "sampling what the sensor sees")
    pts, lab, truth = simulate(
        scene,
        truth,
        make_sensor(sensor, camera_azimuth),
        n_points,
        noise,
        noise_model,
        dist,
        reconstruction_scale,
        unit,
        seed,
    )
    if len(pts) < n_points:
        ctx.warn(f"the sensor sees only {len(pts)} of the {n_points} points asked for")
    cloud = PointCloud(pts, fields={"primitive": lab.astype(np.float64)}, name=f"simulated {artefact}")
    return {"cloud": cloud, "truth": truth}


def capture(ctx, scene, out: str) -> dict[str, Any]:
    """Render a scene file's capture sequence into ``out`` (virtuallab.capture)."""
    from .capture import capture as run_capture
    from .scene_file import load_scene

    return run_capture(load_scene(scene), out, ctx)


def frame(
    ctx,
    scene,
    camera: str = "camera1",
    pattern=None,
    stage_positions=None,
    stage_units=None,
    camera_model=None,
    size=None,
    exposure_ms: float = 10.0,
    gain_db: float = 0.0,
    pattern_index: int = -1,
    speckle: bool = False,
    frame: int = 0,
    seed: int = -1,
) -> dict[str, Any]:
    """One rendered frame for a simulated camera (virtuallab.frame): the state keywords
    of camcmm_plugins.devices' SimulatedCamera in, ``{"image": array}`` out."""
    from camcmm.api import InputError

    from .lab import system_for
    from .speckle import speckle as speckle_pattern

    lab = system_for(scene)
    if size is not None and tuple(int(x) for x in size) != tuple(
        lab.scene.cameras[lab._index(camera)].model.image_size
    ):
        want = lab.scene.cameras[lab._index(camera)].model.image_size
        raise InputError(
            f"camera {camera!r}: asked for {size[0]} x {size[1]} px, the scene renders {want[0]} x {want[1]}"
        )
    lab.set_stages(dict(stage_positions or {}), dict(stage_units or {}))
    pat = None if pattern is None else np.asarray(pattern)
    if speckle and lab.projector_size is not None:
        sp = lab.scene.speckle
        w, h = lab.projector_size
        spk = speckle_pattern((h, w), float(sp.get("grain", 6.0)), int(sp.get("seed", 0)), float(sp.get("mean", 0.3)))
        if pat is not None and np.issubdtype(pat.dtype, np.integer):
            pat = pat / float(np.iinfo(pat.dtype).max)
        pat = spk if pat is None else np.clip(pat + spk, 0, 1)
    # the scene's exposure is the camera's at 10 ms and 0 dB
    gain = float(exposure_ms) / 10.0 * 10 ** (float(gain_db) / 20.0)
    if seed >= 0:
        lab.frames_taken = int(seed) * 1_000_003 + int(frame)
    img = lab.frame(camera, pat, exposure=lab.scene.sensor.exposure * gain)
    return {"image": img}


def fringe_system(
    ctx,
    placement,
    preset: str = "stereo_fringe",
    method: str = "stereo",
    image_width: int = 640,
    image_height: int = 480,
    seed: int = 0,
    baseline_error: float = 0.0,
    focal_error: float = 0.0,
) -> dict[str, Any]:
    """The simulated stereo fringe system measuring one placement (virtuallab.fringe-system)."""
    from .system import measure

    errors: dict[str, Any] = {}
    if baseline_error:
        errors["baseline"] = {"relative": float(baseline_error)}
    if focal_error:
        errors["focal_length"] = {"camera": "camera1", "relative": float(focal_error)}
    if method == "stereo" and preset != "stereo_fringe":
        raise ParameterError("method stereo needs the preset stereo_fringe (two cameras)")
    return measure(dict(placement), preset, method, (image_width, image_height), seed, errors, ctx=ctx)


def turntable_series(
    ctx,
    out: str,
    artefact: str = "sphere",
    n_images: int = 30,
    arc_deg: float = 180.0,
    elevation: float = 30.0,
    downscale: float = 4.0,
    f_number: float = 8.0,
    magnification: float = 0.0,
    speckle: bool = True,
    wavelength: float = 532.0,
    distance: float = 80.0,
    diffuser: float = 0.25,
    grain: float = 0.0,
    supersample: int = 2,
    depth_of_field: bool = True,
    seed: int = 0,
    material: str = "ti6al4v",
    sizes: dict | None = None,
) -> dict[str, Any]:
    """The chapter-4 turntable series with laser speckle (virtuallab.turntable-series)."""
    from .turntable import SeriesSpec, write_series

    spec = SeriesSpec(
        artefact, n_images, arc_deg, elevation, downscale, f_number, magnification, speckle,
        wavelength, distance, diffuser, grain, 0.3, supersample, depth_of_field, seed,
        material=material, sizes=dict(sizes or {}),
    )  # fmt: skip
    res = write_series(spec, out, ctx.progress)
    for w in res["warnings"]:
        ctx.warn(w)
    return res


def photogrammetry_system(
    ctx,
    placement,
    n_images: int = 30,
    arc: float = 180.0,
    downscale: float = 8.0,
    magnification: float = 0.3333,
    f_number: float = 8.0,
    speckle: bool = True,
    grain: float = 0.0,
    supersample: int = 1,
    max_image_size: int = 1600,
    calibrated: bool = True,
    seed: int = 0,
) -> dict[str, Any]:
    """The simulated chapter-4 photogrammetry system measuring one placement
    (virtuallab.photogrammetry-system; see photo_system.py)."""
    from .photo_system import measure

    opts = {
        "n_images": n_images, "arc": arc, "downscale": downscale, "magnification": magnification,
        "f_number": f_number, "speckle": speckle, "grain": grain, "supersample": supersample,
        "max_image_size": max_image_size, "calibrated": calibrated, "seed": seed,
    }  # fmt: skip
    return measure(dict(placement), opts, ctx)


def am_artefact(ctx, artefact: str = "am_pyramid", sizes: dict | None = None) -> dict[str, Any]:
    """The CAD mesh of an AM test artefact of ch. 6.2 with its face classes (virtuallab.am-artefact)."""

    from . import am_artefacts

    try:
        V, F, cls, used = am_artefacts.build(artefact, sizes)
    except (ValueError, TypeError) as exc:
        raise InputError(str(exc)) from None
    return {
        "mesh": TriangleMesh(V, F, name=artefact),
        "face_class": cls.astype(int).tolist(),
        "face_classes": list(am_artefacts.FACE_CLASSES),
        "class_areas": am_artefacts.class_areas(V, F, cls),
        "sizes_used": used,
    }
