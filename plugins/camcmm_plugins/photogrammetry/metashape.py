"""Reading the camera XML of Agisoft Metashape / PhotoScan (File > Export > Export
Cameras, "Agisoft XML"); the exported point cloud is read by camcmm's own text reader.

Written by hand: no maintained library reads the XML (it is Agisoft's own schema).

Conventions converted here (Metashape user manual, appendix "Camera models"; Agisoft KB
"What do camera calibration results mean"):

* ``u = w/2 + cx + x' (f + b1) + y' b2``, ``v = h/2 + cy + y' f`` with (u, v) from the
  image's top-left *corner*: cx, cy are offsets from the image centre. OpenCV counts from
  the centre of the top-left pixel, so ``cx_cv = w/2 + cx - 0.5`` (likewise cy),
  ``fx = f + b1``, ``fy = f``, skew ``b2``.
* Metashape's P1 multiplies ``r² + 2y²`` in v — it is OpenCV's p2 and P2 is OpenCV's p1.
  K4 (an r⁸ term) has no place in OpenCV's model: refused with a warning if non-zero.
* ``camera/transform`` is the 4x4 camera-to-chunk transform (camera axes as OpenCV's:
  x right, y down, z forward); the camera's component's ``transform`` (Metashape 1.6+) or
  else ``chunk/transform`` (rotation R_c, translation T_c, scale s) takes chunk coordinates
  to the exported world: ``X = s R_c X_chunk + T_c``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError

from .cameras import check_intrinsics


def _floats(el, path: Path, what: str, n: int) -> np.ndarray:
    try:
        v = np.array([float(x) for x in (el.text or "").split()])
    except ValueError:
        raise InputError(f"{path}: {what}: not numbers") from None
    if len(v) != n:
        raise InputError(f"{path}: {what}: expected {n} numbers, found {len(v)}")
    if not np.isfinite(v).all():
        raise InputError(f"{path}: {what}: {v[~np.isfinite(v)][0]:g} is not a finite number")
    return v


def _attr(el, name: str, path: Path, what: str) -> int:
    """A whole-number attribute (``<resolution width=...>``), refused in one line naming
    the element and the value when missing or not a whole number."""
    text = el.get(name)
    if text is None:
        raise InputError(f"{path}: {what} <{el.tag}> lacks {name}")
    try:
        return int(text.strip())
    except ValueError:
        raise InputError(f"{path}: {what} <{el.tag} {name}={text!r}>: not a whole number") from None


def _num(calib, tag: str, path: Path, default: float | None = 0.0) -> float:
    el = calib.find(tag)
    if el is None:
        if default is None:
            raise InputError(f"{path}: calibration lacks <{tag}>")
        return default
    return float(_floats(el, path, f"<{tag}>", 1)[0])


def _camera(sensor, path: Path, warnings: list[str]) -> dict[str, Any]:
    label = sensor.get("label", sensor.get("id", "?"))
    # a sensor may hold its initial and its adjusted calibration: the adjusted one counts
    calibs = sensor.findall("calibration")
    calib = next((c for c in calibs if c.get("class") == "adjusted"), calibs[0] if calibs else None)
    res = (calib if calib is not None and calib.find("resolution") is not None else sensor).find("resolution")
    if res is None:
        raise InputError(f"{path}: sensor {label!r} has no <resolution>")
    where = f"sensor {label!r}"
    w, h = _attr(res, "width", path, where), _attr(res, "height", path, where)
    if calib is None:
        raise InputError(f"{path}: sensor {label!r} has no <calibration> (cameras not aligned?)")
    kind = calib.get("type", sensor.get("type", "frame"))
    if kind != "frame":
        warnings.append(f"{path}: sensor {label!r} is a {kind} camera; only frame cameras map to OpenCV")
    if calib.find("f") is not None:
        f = _num(calib, "f", path, None)
        fx, fy = f + _num(calib, "b1", path), f
        cx, cy = w / 2 + _num(calib, "cx", path) - 0.5, h / 2 + _num(calib, "cy", path) - 0.5
    else:  # PhotoScan before 1.3: fx fy and cx cy from the corner
        fx, fy = _num(calib, "fx", path, None), _num(calib, "fy", path, None)
        cx, cy = _num(calib, "cx", path, None) - 0.5, _num(calib, "cy", path, None) - 0.5
    skew = _num(calib, "b2", path) + _num(calib, "skew", path)
    if skew:
        warnings.append(f"{path}: sensor {label!r} has skew b2 = {skew:g} px, which OpenCV's model drops")
    k = {t: _num(calib, t, path) for t in ("k1", "k2", "k3", "k4", "p1", "p2")}
    # the calibration readers' camera checks (f -7000, a 0 px wide sensor ...), by the sensor's label
    check_intrinsics(f"{path}: sensor", label, fx, fy, cx, cy, (w, h))
    if k["k4"]:
        warnings.append(f"{path}: sensor {label!r} has k4 = {k['k4']:g} (r^8), which OpenCV's model lacks; dropped")
    return {
        "model": "OPENCV",
        "fx": fx,
        "fy": fy,
        "cx": cx,
        "cy": cy,
        "dist": [k["k1"], k["k2"], k["p2"], k["p1"], k["k3"]],
        "width": w,
        "height": h,
        "skew": skew,
        "label": label,
    }


def similarity(owner, path: Path, what: str) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(R, T, s) of ``owner/transform`` (a chunk's or a component's: ``X = s R x + T``),
    or None when it has none."""
    tr = owner.find("transform")
    if tr is None:
        return None
    rot, trans, sc = tr.find("rotation"), tr.find("translation"), tr.find("scale")
    R = np.eye(3) if rot is None else _floats(rot, path, f"{what} <rotation>", 9).reshape(3, 3)
    T = np.zeros(3) if trans is None else _floats(trans, path, f"{what} <translation>", 3)
    s = 1.0 if sc is None else float(_floats(sc, path, f"{what} <scale>", 1)[0])
    if s <= 0 or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise InputError(f"{path}: {what} <transform> is not a rotation with a positive scale")
    return R, T, s


def read_cameras_xml(path: Path) -> dict[str, Any]:
    """Cameras and views of a Metashape/PhotoScan camera XML, in the exported world frame.

    Returns dict ``cameras`` [OpenCV camera dicts], ``views`` [{image, R, t, centre,
    camera}] (``x_cam = R X + t``), ``scaled`` (the chunk transform sets a scale),
    ``warnings``.
    """
    warnings: list[str] = []
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise InputError(f"{path}: not a readable camera XML ({exc})") from None
    chunks = root.findall("chunk") if root.tag == "document" else ([root] if root.tag == "chunk" else [])
    chunk = chunks[0] if chunks else None
    if len(chunks) > 1:
        warnings.append(f"{path}: {len(chunks)} chunks; the first is read")
    if chunk is None:
        raise InputError(f"{path}: no <chunk> (not an Agisoft camera XML)")
    sensors = {s.get("id"): s for s in chunk.iter("sensor")}
    cams = {sid: _camera(s, path, warnings) for sid, s in sensors.items()}
    # Metashape 1.6+ keeps the transform per component (cameras name theirs), older
    # versions one per chunk; each takes the cameras' frame to the exported world.
    ct = similarity(chunk, path, "chunk")
    comps = {c.get("id"): similarity(c, path, f"component {c.get('id')!r}") for c in chunk.iter("component")}
    if ct is not None and any(v is not None for v in comps.values()):
        warnings.append(f"{path}: both a chunk and a component transform; each camera's component's is used")
    views, used = [], []
    for cam in chunk.iter("camera"):
        tr = cam.find("transform")
        label = cam.get("label", cam.get("id", "?"))
        if tr is None:
            continue  # not aligned
        if cam.get("sensor_id") not in cams:
            raise InputError(f"{path}: camera {label!r} names sensor {cam.get('sensor_id')!r}, which is absent")
        M = _floats(tr, path, f"camera {label!r} <transform>", 16).reshape(4, 4)
        Rcc, tcc = M[:3, :3], M[:3, 3]  # camera to chunk
        if not np.allclose(Rcc @ Rcc.T, np.eye(3), atol=1e-6) or np.linalg.det(Rcc) < 0:
            raise InputError(f"{path}: camera {label!r} <transform> is not a rigid motion")
        tf = comps.get(cam.get("component_id")) or ct
        used.append(tf)
        if tf is not None:
            Rc, Tc, s = tf
            Rcw, centre = Rc @ Rcc, s * Rc @ tcc + Tc  # camera to world
        else:
            Rcw, centre = Rcc, tcc
        R = Rcw.T
        views.append({"image": label, "R": R, "t": -R @ centre, "centre": centre, "camera": cam.get("sensor_id")})
    if not views:
        raise InputError(f"{path}: no aligned camera (no <camera> with a <transform>)")
    order = list(cams)
    for v in views:
        v["camera"] = order.index(v["camera"])
    scaled = any(tf is not None and tf[2] != 1.0 for tf in used)
    return {"cameras": [cams[k] for k in order], "views": views, "scaled": scaled, "warnings": warnings}
