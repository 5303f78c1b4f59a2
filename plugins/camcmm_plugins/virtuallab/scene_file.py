"""The virtual lab's scene file (YAML): artefacts, cameras, projector, lighting, sensor,
the capture sequence and switchable systematic errors. Lengths mm, angles deg, px.

Schema (``version: 1``; every section but ``artefacts`` optional)::

    name: sphere in the stereo fringe system
    seed: 1                                   # noise; each frame and camera its own stream
    artefacts:                                # volume frame: origin at its centre, +z to the sensor
      - {type: sphere, center: [0, 0, 0], diameter: 20.0, stem: true, albedo: 0.8}
      - {type: ball_bar, center: [0, 0, 0], direction: [1, 1, 1], length: 49.944, sphere_diameter: 20}
      - {type: ball_plate, center: [0, 0, 0], lengths: [5.942, 7.956, 9.957], sphere_diameter: 5,
         rotation: 0, tilt: 0}
      - {type: flat, center: [0, 0, 0], direction: [1, 0, 0], normal: [0, 0, 1], length: 150, width: 60}
      - {type: gauge_blocks, center: [0, 0, -30], platen: [200, 150, 30], direction: [1, 0, 0],
         blocks: [{length: 10, at: [-30, 0]}, {length: 25, at: [30, 0], size: [35, 9]}]}
      - {type: box, center: [0, 0, 0], size: [30, 20, 10], direction: [1, 0, 0], normal: [0, 0, 1]}
      - {type: mesh, file: part.stl, position: [0, 0, 0], rotation_deg: [0, 0, 0], scale: 1}
      - {type: plane, center: [0, 0, -60], normal: [0, 0, 1], length: 400, width: 400, albedo: 0.3}
    rig: {preset: stereo_fringe, image_size: [1280, 960]}   # or cameras: [...] and projector: {...}
    cameras: [{name, image_size, focal_length, pixel_pitch, dist_coeffs, position, look_at, ...}]
    projector: {name: projector, image_size: [1280, 800], ...}             # see rig.py for the fields
    lighting: {projector: 0.8, ambient: 0.02, diffuse: 0.0, diffuse_direction: [0, 0, 1],
               background: 0.0, gamma: 1.0, projector_blur: 0.0, falloff: true}
    sensor: {bits: 8, full_well: 20000, read_noise: 10, exposure: 1.0, black_level: 0, shot_noise: true}
    render: {supersample: 2}                  # s x s rays per pixel
    sequence: fringe_sequence.yaml            # a fringe sequence file (the fringe plugin's patterns),
                                              # or the sequence itself as a mapping ...
    patterns:                                 # ... and/or frames listed here, shown after it
      - white
      - black
      - {speckle: {grain: 6, mean: 0.3, seed: 1}}
      - {image: pattern.png}                  # any image at the projector's resolution
      - diffuse                               # projector dark, the diffuse lamp on
    errors:                                   # systematic errors, switched on by listing them
      focal_length: {camera: camera2, relative: 0.01}       # written fx, fy = true x (1 + 0.01)
      baseline: {relative: 0.01}              # written translations (camera 1 frame) x (1 + 0.01)
      principal_point: {camera: camera1, shift: [1.0, 0.0]}  # written (cx, cy) + shift, px
      distortion: {camera: camera1, delta: [0.01, 0, 0, 0, 0]}  # written dist_coeffs + delta
      rotation: {camera: camera2, angles_deg: [0.01, 0, 0]}  # written R = Rz Ry Rx(angles) R
      projector_gamma: 2.2                    # the projector's true response (decoders assume 1)
    stages:                                   # simulated stages carrying the artefacts (lab.py)
      turntable: {type: rotary, axis: [0, 0, 1], origin: [0, 0, 0]}   # deg
      slide: {type: linear, axis: [1, 0, 0]}                        # mm
    speckle: {grain: 6, seed: 0, mean: 0.3}   # what a simulated speckle laser shows

``type: plane`` is a large rectangle (a backdrop or table top) that is not an artefact.
Every artefact accepts ``albedo`` (0..1, default 0.8) and ``label``.

Checked on reading, each with one line naming the entry: every number in the file is
finite and at most ``MAX_NUMBER`` in magnitude; diameters, lengths, widths and mesh scales are
> 0; ``seed`` is a whole number >= 0; sensor ``bits`` 8 .. 16; sensor and lighting levels are
>= 0 (``full_well``, ``gamma`` > 0); image sides are at most ``MAX_SIDE`` px and the
rendering's memory estimate (``RAY_BYTES`` per cast ray, ``PIXEL_BYTES`` per pixel of the
largest image) is within ``camcmm.api.check_budget``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from camcmm.api import CamcmmError, InputError, TriangleMesh, check_budget, check_count, read, read_yaml

from . import artefacts as art
from . import rig, workpieces
from .imaging import Sensor
from .render import Lighting
from .scene import Rectangle

ARTEFACTS = ("sphere", "ball_bar", "ball_plate", "flat", "gauge_blocks", "box", "mesh", "plane")
ERRORS = ("focal_length", "baseline", "principal_point", "distortion", "rotation", "projector_gamma")
#: Largest image side (px) of a scene's camera or projector.
MAX_SIDE = 16384
#: Most entries in a scene's ``patterns`` list.
MAX_PATTERNS = 4096
#: Memory (bytes) per cast ray (the views kept plus the casting batches) and per pixel of
#: the frame being rendered (radiance, defocus levels, noise). Measured: 1.2 GB peak for
#: two 1280 x 960 px cameras at supersample 2 (9.8 M rays); tracemalloc at 640 x 480 px
#: gives ~110 B per pixel for a frame.
RAY_BYTES = 130
PIXEL_BYTES = 350
#: Largest magnitude of any number in a scene file (mm: 1000 km; beyond it the ray
#: casting's squares overflow float64 long before anything is measured).
MAX_NUMBER = 1e9
#: Largest light level, gain or exposure, and electron count (full well, read noise):
#: beyond them the shot noise's Poisson mean overflows.
MAX_LEVEL = 1e3
MAX_ELECTRONS = 1e7


@dataclass
class LabScene:
    """A parsed scene file: primitives with one albedo each, the artefacts' truth (volume
    frame), devices, light, sensor, what to show and the switched-on errors."""

    name: str
    primitives: list
    albedo: np.ndarray
    artefacts: list[dict[str, Any]]
    cameras: list[rig.Device]
    projector: rig.Device | None
    lighting: Lighting
    sensor: Sensor
    supersample: int = 2
    seed: int = 0
    sequence: Path | dict | None = None
    patterns: list = field(default_factory=list)
    errors: dict[str, Any] = field(default_factory=dict)
    base: Path = Path(".")
    source: dict[str, Any] = field(default_factory=dict)
    owner: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # artefact of each primitive
    stages: dict[str, dict[str, Any]] = field(default_factory=dict)
    speckle: dict[str, Any] = field(default_factory=dict)


def _g(d: Mapping, key: str, default, what: str):
    v = d.get(key, default)
    if v is None:
        raise ValueError(f"{what}.{key} is missing")
    return v


def _positive(a: Mapping, key: str, default, what: str) -> float:
    """``a[key]`` as a finite number > 0 (a length in mm, a scale), or ValueError naming it."""
    v = _g(a, key, default, what)
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{what}.{key} {v!r} is not a number") from None
    if not (math.isfinite(x) and 0 < x <= MAX_NUMBER):
        raise ValueError(f"{what}.{key} {v!r} must be a finite number > 0 and <= {MAX_NUMBER:g}")
    return x


def _nonfinite(obj: Any, path: str = "", limit: float = MAX_NUMBER) -> tuple[str, Any] | None:
    """(path, value) of the first NaN, infinite or larger than ``limit`` number in a
    parsed document (seeds apart), or None."""
    if isinstance(obj, Mapping):
        for k, v in obj.items():
            if k == "seed" and isinstance(v, int):  # noise seeds: any whole number >= 0
                continue
            hit = _nonfinite(v, f"{path}.{k}" if path else str(k), limit)
            if hit:
                return hit
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            hit = _nonfinite(v, f"{path}[{i}]", limit)
            if hit:
                return hit
    elif (
        isinstance(obj, (int, float, np.floating)) and not isinstance(obj, bool) and not abs(cast(float, obj)) <= limit
    ):
        return path, obj
    return None


def build_artefact(a: Mapping[str, Any], i: int, base: Path) -> tuple[list, dict[str, Any]]:
    what = f"artefacts[{i}]"
    if not isinstance(a, Mapping) or "type" not in a:
        raise ValueError(f"{what}: expected a mapping with a type ({', '.join(ARTEFACTS)})")
    t = a["type"]
    c = rig._vec(a.get("center", [0.0, 0.0, 0.0]), 3, f"{what}.center")
    if t == "sphere":
        return art.sphere(c, _positive(a, "diameter", None, what), bool(a.get("stem", True)))
    if t == "ball_bar":
        return art.ball_bar(
            c,
            a.get("direction", [1, 0, 0]),
            _positive(a, "length", None, what),
            _positive(a, "sphere_diameter", None, what),
            bool(a.get("bar", True)),
        )
    if t == "ball_plate":
        return art.ball_plate(
            c,
            _g(a, "lengths", None, what),
            _positive(a, "sphere_diameter", None, what),
            float(a.get("rotation", 0.0)),
            float(a.get("tilt", 0.0)),
            bool(a.get("plate", True)),
        )
    if t == "flat":
        axis, n = art.axes_from(a.get("direction", [1, 0, 0]), a.get("normal"))
        return art.flat(c, axis, n, _positive(a, "length", None, what), _positive(a, "width", None, what))
    if t == "plane":
        r = Rectangle(
            c,
            a.get("direction", [1, 0, 0]),
            a.get("normal", [0, 0, 1]),
            _positive(a, "length", 500.0, what),
            _positive(a, "width", 500.0, what),
            a.get("label", "plane"),
            measured=False,
        )
        return [r], {"kind": "plane", "center": r.center.tolist(), "normal": r.normal.tolist()}
    if t == "gauge_blocks":
        return workpieces.gauge_blocks(
            c,
            _g(a, "blocks", None, what),
            a.get("platen", (200.0, 150.0, 30.0)),
            a.get("direction", [1, 0, 0]),
            a.get("normal", [0, 0, 1]),
        )
    if t == "box":
        return workpieces.box(c, _g(a, "size", None, what), a.get("direction", [1, 0, 0]), a.get("normal", [0, 0, 1]))
    if t == "mesh":
        if "file" in a:
            p = Path(a["file"])
            m = read(p if p.is_absolute() else base / p, unit=a.get("unit"))
            if not isinstance(m, TriangleMesh):
                raise ValueError(f"{what}.file {a['file']!r} holds no triangle mesh")
            V, F = m.vertices, m.faces
        else:
            V, F = _g(a, "vertices", None, what), _g(a, "faces", None, what)
        return workpieces.mesh(
            V,
            F,
            a.get("position", [0, 0, 0]),
            a.get("rotation_deg", [0, 0, 0]),
            _positive(a, "scale", 1.0, what),
            a.get("label", "mesh"),
        )
    raise ValueError(f"{what}.type {t!r}: use one of {', '.join(ARTEFACTS)}")


def _dataclass_from(cls, d: Mapping[str, Any] | None, what: str):
    if d is not None and not isinstance(d, Mapping):
        raise ValueError(f"{what}: expected a mapping, got {d!r}")
    d = dict(d or {})
    known = set(cls.__dataclass_fields__)
    unknown = sorted(set(d) - known)
    if unknown:
        raise ValueError(f"{what}.{unknown[0]}: unknown entry; use {', '.join(sorted(known))}")
    return cls(**d)


def scene_from_dict(doc: Mapping[str, Any], base: Path = Path(".")) -> LabScene:
    """A LabScene from a parsed scene document (ValueError names the entry)."""
    if not isinstance(doc, Mapping):
        raise ValueError("expected a mapping at the top level")
    bad = _nonfinite(doc)
    if bad:
        raise ValueError(f"{bad[0]} {bad[1]!r} is not a finite number of at most {MAX_NUMBER:g}")
    seed = doc.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed {seed!r} must be a whole number >= 0")
    arts = doc.get("artefacts")
    if not isinstance(arts, list) or not arts:
        raise ValueError("artefacts: a list of at least one artefact is needed")
    prims, albedo, truths, owner = [], [], [], []
    for i, a in enumerate(arts):
        p, tr = build_artefact(a, i, base)
        rho = float(a.get("albedo", 0.8))
        if not 0 <= rho <= 1:
            raise ValueError(f"artefacts[{i}].albedo {rho!r} must lie in 0..1")
        tr["label"] = a.get("label", tr.get("label", f"{a['type']} {i + 1}"))
        tr["albedo"] = rho
        prims += p
        albedo += [rho] * len(p)
        owner += [i] * len(p)
        truths.append(tr)
    r = doc.get("rig")
    if doc.get("cameras"):
        cam_d, proj_d = list(doc["cameras"]), doc.get("projector")
    elif r is not None:
        r = dict(r)
        cam_d, proj_d = rig.preset(r.pop("preset", "stereo_fringe"), r)
        if doc.get("projector") is not None:
            proj_d = {**proj_d, **doc["projector"]}
    else:
        cam_d, proj_d = rig.preset("stereo_fringe", {})
    cams = [rig.device_from_dict(c, f"camera{i + 1}") for i, c in enumerate(cam_d)]
    if len({c.name for c in cams}) != len(cams):
        raise ValueError("cameras: names must differ (they name the image folders)")
    proj = rig.device_from_dict(proj_d, "projector") if proj_d else None
    light = _dataclass_from(Lighting, doc.get("lighting"), "lighting")
    errors = _errors(doc.get("errors"))
    if "projector_gamma" in errors:
        light.gamma = _positive(errors, "projector_gamma", None, "errors")
    _check_levels(
        light, "lighting", ("projector", "ambient", "diffuse", "background", "projector_blur"), ("gamma",), MAX_LEVEL
    )
    sensor = _dataclass_from(Sensor, doc.get("sensor"), "sensor")
    # frames are 8- or 16-bit images read at their type's full scale: below 8 bits a frame
    # would use 2^bits of 256 grey levels and decode as nearly dark
    if isinstance(sensor.bits, bool) or not isinstance(sensor.bits, int) or not 8 <= sensor.bits <= 16:
        raise ValueError(f"sensor.bits {sensor.bits!r}: use a whole number 8 .. 16 (a camera's digitisation)")
    _check_levels(sensor, "sensor", ("exposure",), (), MAX_LEVEL)
    _check_levels(sensor, "sensor", ("read_noise", "black_level"), ("full_well",), MAX_ELECTRONS)
    render = doc.get("render") or {}
    if not isinstance(render, Mapping):
        raise ValueError(f"render: expected a mapping {{supersample: N}}, got {render!r}")
    ss = render.get("supersample", 2)
    if isinstance(ss, bool) or not isinstance(ss, int) or not 1 <= ss <= 8:
        raise ValueError(f"render.supersample {ss!r}: use a whole number 1 .. 8")
    seq = doc.get("sequence")
    pats = doc.get("patterns") or []
    if not isinstance(pats, list):
        raise ValueError("patterns: expected a list")
    check_count("patterns: the number of entries", len(pats), MAX_PATTERNS)
    _check_size(cams, proj, ss, len(pats))
    return LabScene(
        str(doc.get("name", "virtual lab scene")),
        prims,
        np.asarray(albedo),
        truths,
        cams,
        proj,
        light,
        sensor,
        ss,
        seed,
        dict(seq)
        if isinstance(seq, Mapping)
        else ((base / seq) if seq and not Path(seq).is_absolute() else (Path(seq) if seq else None)),
        pats,
        errors,
        base,
        dict(doc),
        np.asarray(owner, np.int64),
        _stages(doc.get("stages")),
        dict(doc.get("speckle") or {}),
    )


def _check_levels(obj, what: str, non_negative: tuple[str, ...], positive: tuple[str, ...], maximum: float) -> None:
    """Light levels, noise and gains: numbers >= 0 (``positive``: > 0) up to ``maximum``;
    ValueError names the field."""
    for key in non_negative + positive:
        v = getattr(obj, key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{what}.{key} {v!r} is not a finite number")
        if v < 0 or (key in positive and v == 0) or v > maximum:
            raise ValueError(f"{what}.{key} {v!r} must be {'> 0' if key in positive else '>= 0'} and <= {maximum:g}")


def _errors(d: Any) -> dict[str, Any]:
    """The switched-on systematic errors, each of the shape the module docstring gives."""
    if d is None:
        return {}
    if not isinstance(d, Mapping):
        raise ValueError(f"errors: expected a mapping {{name: settings}}, got {d!r}")
    bad = sorted(set(d) - set(ERRORS))
    if bad:
        raise ValueError(f"errors.{bad[0]}: unknown error; use {', '.join(ERRORS)}")
    shapes = {
        "focal_length": ("relative", 1),
        "baseline": ("relative", 1),
        "principal_point": ("shift", 2),
        "distortion": ("delta", None),
        "rotation": ("angles_deg", 3),
    }
    for name, v in d.items():
        if name == "projector_gamma":
            continue
        key, n = shapes[name]
        if not isinstance(v, Mapping):
            raise ValueError(f"errors.{name}: expected a mapping with {key}, got {v!r}")
        x = v.get(key, 0.0)
        items = x if isinstance(x, (list, tuple)) else [x]
        if (
            (n is not None and (len(items) != n or (n == 1 and isinstance(x, (list, tuple)))))
            or not 1 <= len(items) <= 12
            or not all(isinstance(a, (int, float)) and not isinstance(a, bool) for a in items)
        ):
            raise ValueError(f"errors.{name}.{key} {x!r}: expected {n or 'up to 12'} number(s)")
        if key == "relative" and not -1 < x < 1:
            raise ValueError(f"errors.{name}.relative {x!r} must lie between -1 and 1")
    return dict(d)


def _check_size(cams: list, proj, supersample: int, n_patterns: int) -> None:
    """Image sides and the rendering's memory estimate, before any ray is cast."""
    devs = cams + ([proj] if proj is not None else [])
    for d in devs:
        w, h = d.model.image_size
        check_count(f"{d.name}.image_size width", w, MAX_SIDE)
        check_count(f"{d.name}.image_size height", h, MAX_SIDE)
    px = [int(c.model.image_size[0]) * int(c.model.image_size[1]) for c in cams]
    ppx = int(proj.model.image_size[0]) * int(proj.model.image_size[1]) if proj is not None else 0
    # rays of every camera are kept at once; one frame is rendered at a time; a white,
    # black or speckle entry of ``patterns`` is a float64 image at the projector's size
    need = RAY_BYTES * supersample**2 * sum(px) + PIXEL_BYTES * max(px, default=0) + 8.0 * ppx * n_patterns
    sizes = ", ".join(f"{c.name} {c.model.image_size[0]} x {c.model.image_size[1]} px" for c in cams)
    check_budget(f"rendering {sizes} at supersample {supersample}", need)


def _stages(d) -> dict[str, dict[str, Any]]:
    if d is None:
        return {}
    if not isinstance(d, Mapping):
        raise ValueError("stages: expected a mapping {name: {type, axis, origin}}")
    for name, v in d.items():
        if not isinstance(v, Mapping) or v.get("type", "linear") not in ("linear", "rotary"):
            raise ValueError(f"stages.{name}: expected {{type: linear|rotary, axis: [x, y, z], origin: [x, y, z]}}")
        if not np.linalg.norm(np.asarray(v.get("axis", [1, 0, 0]), float)) > 0:
            raise ValueError(f"stages.{name}.axis has zero length")
    return {str(k): dict(v) for k, v in d.items()}


def load_scene(path: str | Path) -> LabScene:
    """Read and check a scene file; InputError names the file and the bad entry."""
    p = Path(path)
    doc = read_yaml(p)
    try:
        return scene_from_dict(doc, p.parent)
    except (ValueError, TypeError, KeyError, CamcmmError) as exc:
        raise InputError(f"{p}: {exc}") from None
