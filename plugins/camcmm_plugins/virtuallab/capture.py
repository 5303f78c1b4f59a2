"""Render a scene's capture sequence and write what a real system would hand over:
frames per camera, the calibration file, plus the truth.

Output folder::

    camera1/frame000.png ...   one PNG per frame and camera (8-bit, or 16-bit for > 8 bits):
    camera2/...                the sequence's frames (exactly what a decoder expects) ...
    camera1/extra/frame000.png ... and, with a sequence, the scene's own ``patterns`` here
    calibration.yaml           the calibration the system *believes* (systematic errors in)
    calibration_true.yaml      the true one
    sequence.yaml              a copy of the fringe sequence file, when the scene names one
    truth.json                 artefact geometry, in the volume frame and in the calibration
                               frame (camera 1), the frames shown and the errors switched on

Frames: the sequence file's frames (patterns from the fringe plugin, ``fringe.patterns``,
at its bit depth), then the scene's own ``patterns`` entries. Each camera and frame has
its own noise stream (numpy SeedSequence of (seed, camera, frame)): reproducible.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from camcmm.api import (
    CameraModel,
    Image,
    InputError,
    check_calibration,
    check_disk,
    get_algorithm,
    human_bytes,
    read,
    write,
    write_calibration,
)

from . import imaging, render, rig
from .scene_file import LabScene, _nonfinite
from .speckle import speckle
from .workpieces import rotation_xyz

#: Fraction of saturated pixels in a frame above which the capture warns.
SATURATION_WARN = 0.005
POINT_KEYS = ("center", "top_center", "base_center", "point", "center_distorted")
DIR_KEYS = ("direction", "normal", "axis")


def _projector_shape(scene: LabScene) -> tuple[int, int]:
    if scene.projector is None:
        raise InputError("the scene shows patterns but has no projector")
    w, h = scene.projector.model.image_size
    return h, w


def scene_frames(scene: LabScene, ctx=None) -> list[dict[str, Any]]:
    """The frames to capture: dicts with ``name``, ``kind``, ``pattern`` (h, w) or None
    (projector dark) and ``lamp`` (the diffuse lamp on)."""
    frames: list[dict[str, Any]] = []
    if scene.sequence is not None:
        seq = scene.sequence
        if isinstance(seq, Path) and not seq.is_file():
            raise InputError(f"sequence {scene.sequence}: file not found")
        fringe = ctx.algorithm("fringe.patterns") if ctx is not None else get_algorithm("fringe.patterns")
        out = fringe(sequence=seq if isinstance(seq, dict) else str(seq))
        size = tuple(int(x) for x in out["projector_size"])
        if scene.projector is None or tuple(scene.projector.model.image_size) != size:
            have = scene.projector.model.image_size if scene.projector is not None else None
            raise InputError(
                f"sequence {seq.name if isinstance(seq, Path) else '(in the scene)'}: patterns of "
                f"{size[0]} x {size[1]} px, "
                f"but the projector shows {have}"
            )
        for k, (pat, desc) in enumerate(zip(np.asarray(out["patterns"]), out["frames"])):
            frames.append(
                {
                    "name": desc.get("name", f"frame {k}"),
                    "kind": desc.get("kind", "pattern"),
                    "pattern": pat,
                    "lamp": False,
                    "source": "sequence",
                }
            )
    for i, entry in enumerate(scene.patterns):
        what = f"patterns[{i}]"
        if entry in ("white", "black"):
            shape = _projector_shape(scene)
            frames.append(
                {
                    "name": entry,
                    "kind": entry,
                    "lamp": False,
                    "pattern": np.full(shape, 1.0 if entry == "white" else 0.0),
                }
            )
        elif entry == "diffuse":
            frames.append({"name": "diffuse", "kind": "diffuse", "pattern": None, "lamp": True})
        elif entry == "dark":
            frames.append({"name": "dark", "kind": "dark", "pattern": None, "lamp": False})
        elif isinstance(entry, dict) and "speckle" in entry:
            sp = dict(entry["speckle"] or {})
            try:
                pat = speckle(
                    _projector_shape(scene),
                    float(sp.get("grain", 6.0)),
                    int(sp.get("seed", 0)),
                    float(sp.get("mean", 0.3)),
                )
            except ValueError as exc:
                raise InputError(f"{what}: {exc}") from None
            frames.append({"name": f"speckle {i}", "kind": "speckle", "pattern": pat, "lamp": False})
        elif isinstance(entry, dict) and "image" in entry:
            p = Path(entry["image"])
            img = read(p if p.is_absolute() else scene.base / p)
            if not isinstance(img, Image):
                raise InputError(f"{what}: {entry['image']} is not an image")
            data = img.data if img.data.ndim == 2 else img.data[..., :3].mean(axis=2)
            want = _projector_shape(scene)  # (h, w)
            if data.shape != want:
                raise InputError(
                    f"{what}: {entry['image']} is {data.shape[1]} x {data.shape[0]} px; the projector "
                    f"shows {want[1]} x {want[0]}"
                )
            frames.append({"name": p.name, "kind": "image", "pattern": img.data, "lamp": False})
        else:
            raise InputError(f"{what}: {entry!r}; use white, black, dark, diffuse, {{speckle: ...}} or {{image: FILE}}")
    if not frames:
        raise InputError("the scene shows nothing: give a sequence file or patterns")
    return frames


def _camera_sel(errors: dict, key: str, cams: list[CameraModel]) -> list[int]:
    which = errors[key].get("camera", "all") if isinstance(errors[key], dict) else "all"
    if which == "all":
        return list(range(len(cams)))
    for i, c in enumerate(cams):
        if which == c.name or (isinstance(which, int) and which == i + 1):
            return [i]
    raise InputError(f"errors.{key}.camera {which!r}: no such device ({', '.join(c.name for c in cams)})")


def calibration(scene: LabScene, with_errors: bool = True) -> dict[str, Any]:
    """The calibration dict (api.write_calibration) of the scene's devices in camera 1's
    frame; ``with_errors`` applies the scene's systematic errors (what the system
    believes)."""
    first = scene.cameras[0].model
    devs = [d.model for d in scene.cameras] + ([scene.projector.model] if scene.projector is not None else [])
    cams = [rig.relative_to(first, c) for c in devs]
    e = scene.errors if with_errors else {}
    if "focal_length" in e:
        for i in _camera_sel(e, "focal_length", cams):
            K = cams[i].camera_matrix.copy()
            K[0, :2] *= 1 + float(e["focal_length"].get("relative", 0.0))  # fx and the skew term
            K[1, 1] *= 1 + float(e["focal_length"].get("relative", 0.0))
            cams[i].camera_matrix = K
    if "principal_point" in e:
        for i in _camera_sel(e, "principal_point", cams):
            cams[i].camera_matrix[:2, 2] += np.asarray(e["principal_point"].get("shift", [0, 0]), float)
    if "distortion" in e:
        for i in _camera_sel(e, "distortion", cams):
            dlt = np.asarray(e["distortion"].get("delta", []), float).ravel()
            dc = np.zeros(max(len(cams[i].dist_coeffs), len(dlt)))
            dc[: len(cams[i].dist_coeffs)] = cams[i].dist_coeffs
            dc[: len(dlt)] += dlt
            cams[i].dist_coeffs = dc
    if "rotation" in e:
        for i in _camera_sel(e, "rotation", cams):
            if i == 0:
                raise InputError("errors.rotation: camera 1 is the calibration frame; perturb another device")
            cams[i].rotation = rotation_xyz(e["rotation"].get("angles_deg", [0, 0, 0])) @ cams[i].rotation
    if "baseline" in e:
        s = 1 + float(e["baseline"].get("relative", 0.0))
        for c in cams[1:]:
            c.translation = c.translation * s
    cal: dict[str, Any] = {
        "cameras": cams,
        "source": "camcmm virtual lab",
        "systematic_errors": {k: v for k, v in e.items()} if e else {},
    }
    if len(cams) > 1:
        cal["R"], cal["T"] = cams[1].rotation, cams[1].translation
    # a systematic error may leave no camera (focal_length relative -2, baseline relative -1)
    return check_calibration(cal, "calibration with the systematic errors" if e else "calibration")


def _transform(obj: Any, R: np.ndarray, t: np.ndarray) -> Any:
    if isinstance(obj, dict):
        out = {}
        for k, v in obj.items():
            if k in POINT_KEYS and np.shape(v) == (3,):
                out[k] = (R @ np.asarray(v, float) + t).tolist()
            elif k in DIR_KEYS and np.shape(v) == (3,):
                out[k] = (R @ np.asarray(v, float)).tolist()
            elif k == "axes" and np.shape(v) == (3, 3):
                out[k] = (np.asarray(v, float) @ R.T).tolist()
            else:
                out[k] = _transform(v, R, t)
        return out
    if isinstance(obj, list):
        return [_transform(v, R, t) for v in obj]
    return obj


def truth(scene: LabScene, frames: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """Artefact geometry in the volume frame and in the calibration frame (camera 1)."""
    R, t = scene.cameras[0].model.rotation, scene.cameras[0].model.translation
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, t
    return {
        "scene": scene.name,
        "unit": "mm",
        "frame": "artefacts: measuring volume (origin at its centre, +z to the sensor); "
        "artefacts_calibration: camera 1, the calibration's world frame",
        "volume_to_calibration": M.tolist(),
        "artefacts": scene.artefacts,
        "artefacts_calibration": _transform(scene.artefacts, R, t),
        "errors": scene.errors,
        "seed": scene.seed,
        "frames": [{k: v for k, v in f.items() if k != "pattern"} for f in (frames or [])],
    }


def prepare_views(scene: LabScene, progress: Callable[[float, str], None] | None = None) -> list[render.View]:
    views = []
    proj = scene.projector.model if scene.projector is not None else None
    for i, cam in enumerate(scene.cameras):
        if progress:
            progress(i / max(len(scene.cameras), 1), f"casting rays for {cam.name}")
        views.append(
            render.prepare(
                scene.primitives,
                scene.albedo,
                cam.model,
                proj,
                scene.lighting,
                scene.supersample,
                projector_lens=scene.projector.lens if scene.projector is not None else None,
            )
        )
    return views


def render_frame(
    scene: LabScene, view: render.View, cam_index: int, frame_index: int, frame: dict[str, Any], noise: bool = True
) -> np.ndarray:
    """One digital image (uint8/uint16) of camera ``cam_index`` for ``frame``."""
    dev = scene.cameras[cam_index]
    L = render.radiance(view, frame["pattern"], scene.lighting, frame.get("lamp", False))
    L = imaging.optics(L, view.depth, dev.model, dev.lens)
    rng = np.random.default_rng(np.random.SeedSequence([scene.seed, cam_index, frame_index])) if noise else None
    return imaging.expose(L, scene.sensor, rng)


def render_all(
    scene: LabScene,
    frames: list[dict[str, Any]],
    views: list[render.View] | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> dict[str, list[np.ndarray]]:
    """All frames of all cameras: {camera name: [image, ...]}."""
    views = views or prepare_views(scene, progress)
    out: dict[str, list[np.ndarray]] = {}
    n = len(scene.cameras) * len(frames)
    for i, dev in enumerate(scene.cameras):
        imgs = []
        for k, f in enumerate(frames):
            if progress:
                progress((i * len(frames) + k) / n, f"rendering {dev.name} frame {k + 1}/{len(frames)}")
            imgs.append(render_frame(scene, views[i], i, k, f))
        out[dev.name] = imgs
    return out


def capture(scene: LabScene, out: str | Path, ctx=None) -> dict[str, Any]:
    """Render the scene's sequence into ``out`` (see the module docstring)."""
    prog = ctx.progress if ctx is not None else None
    d = Path(out)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out {out}: cannot create the folder ({exc.strerror})") from None
    frames = scene_frames(scene, ctx)
    # refuse what cannot be written before hours of rendering: raw frame bytes (noisy
    # frames compress little) and a truth that JSON cannot hold
    px = sum(int(c.model.image_size[0]) * int(c.model.image_size[1]) for c in scene.cameras)
    depth = 1 if scene.sensor.bits <= 8 else 2
    check_disk(
        f"{len(frames)} frames x {len(scene.cameras)} cameras (~{human_bytes(px * depth)} per frame)",
        float(len(frames)) * px * depth,
        d,
    )
    _json_text(truth(scene, frames))
    views = prepare_views(scene, (lambda f, m: prog(0.3 * f, m)) if prog else None)
    files: dict[str, list[str]] = {}
    warnings = visibility(scene, views)
    saturated: dict[str, float] = {}
    n = len(scene.cameras) * len(frames)
    for i, (dev, view) in enumerate(zip(scene.cameras, views)):
        cd = d / dev.name
        (cd / "extra").mkdir(parents=True, exist_ok=True)
        for old in [*cd.glob("frame*.png"), *(cd / "extra").glob("frame*.png")]:
            old.unlink()  # a shorter sequence must not leave stale frames
        files[dev.name] = []
        n_seq = sum(f.get("source") == "sequence" for f in frames)
        for k, f in enumerate(frames):
            if prog:
                prog(0.3 + 0.7 * (i * len(frames) + k) / n, f"rendering {dev.name} frame {k + 1}/{len(frames)}")
            extra = n_seq > 0 and f.get("source") != "sequence"
            p = (cd / "extra" / f"frame{k - n_seq:03d}.png") if extra else cd / f"frame{k:03d}.png"
            img = render_frame(scene, view, i, k, f)
            write(Image(img, name=p.name), p)
            files[dev.name].append(str(p))
            saturated[dev.name] = max(saturated.get(dev.name, 0.0), float(np.mean(img >= scene.sensor.max_dn)))
    for name, frac in saturated.items():
        if frac > SATURATION_WARN:
            warnings.append(
                f"{name}: up to {100 * frac:.1f} % of the pixels saturate in a frame; "
                "lower sensor.exposure or lighting.projector"
            )
    write_calibration(d / "calibration.yaml", calibration(scene, True))
    write_calibration(d / "calibration_true.yaml", calibration(scene, False))
    if isinstance(scene.sequence, dict):
        (d / "sequence.yaml").write_text(yaml.safe_dump(scene.sequence, sort_keys=False), encoding="utf-8")
    elif scene.sequence is not None:
        shutil.copyfile(scene.sequence, d / "sequence.yaml")
    tr = truth(scene, frames)
    tr["coverage"] = {
        dev.name: {
            "surface": float(v.coverage.mean()),
            "lit": float(v.lit.mean()),
            "artefact_pixels": _pixels_per_artefact(scene, v),
        }
        for dev, v in zip(scene.cameras, views)
    }
    tr["warnings"] = warnings
    for w in warnings:
        if ctx is not None:
            ctx.warn(w)
    (d / "truth.json").write_text(_json_text(tr), encoding="utf-8")
    if prog:
        prog(1.0, "written")
    return {
        "out": str(d),
        "cameras": [c.name for c in scene.cameras],
        "n_frames": len(frames),
        "files": files,
        "calibration": str(d / "calibration.yaml"),
        "truth": str(d / "truth.json"),
        "sequence": str(d / "sequence.yaml") if scene.sequence is not None else None,
        "coverage": tr["coverage"],
        "warnings": warnings,
    }


def _json_text(doc: dict[str, Any]) -> str:
    """truth.json's text; a NaN or infinity (not JSON) is an error naming where it is."""
    try:
        return json.dumps(doc, indent=1, allow_nan=False)
    except ValueError:
        hit = _nonfinite(doc, limit=float("inf"))
        where = f"{hit[0]} = {float(hit[1])}" if hit else "a value"
        raise InputError(f"truth.json: {where} is not a finite number") from None


def _pixels_per_artefact(scene: LabScene, view: render.View) -> dict[str, int]:
    """Pixels of each artefact (by label) in a view (at the pixel centres)."""
    prim = view.primitive[view.primitive >= 0]
    counts = (
        np.bincount(scene.owner[prim], minlength=len(scene.artefacts))
        if len(prim)
        else np.zeros(len(scene.artefacts), int)
    )
    return {a["label"]: int(c) for a, c in zip(scene.artefacts, counts)}


def visibility(scene: LabScene, views: list[render.View]) -> list[str]:
    """Warnings for artefacts no camera sees, or that the projector lights nowhere."""
    out = []
    for j, a in enumerate(scene.artefacts):
        if a.get("kind") == "plane":
            continue
        seen = [int(np.sum(scene.owner[v.primitive[v.primitive >= 0]] == j)) for v in views]
        if not any(seen):
            out.append(f"artefact {a['label']!r} is outside every camera's view (or hidden)")
        elif min(seen) == 0:
            names = [d.name for d, k in zip(scene.cameras, seen) if k == 0]
            out.append(f"artefact {a['label']!r} is not seen by {', '.join(names)}")
    return out
