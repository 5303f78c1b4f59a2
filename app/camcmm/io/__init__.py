"""File formats: read and write point clouds, meshes, height maps and images.

    read(path, unit=None)  -> PointCloud | TriangleMesh | HeightMap | Image | CadModel   (lengths in mm;
                              STEP/IGES as camcmm.cad.CadModel, in mm from the file's own unit)
    write(obj, path, binary=True, unit="mm")
    info(path, unit=None)  -> dict, JSON-able summary (with ``unit_check`` and ``warnings``)
    read_stated(path, unit=None) -> (object, the unit stated by the caller or the file, or None)
    unit_decision(obj, stated, expected=None) -> camcmm.units.UnitDecision (ask or not)
    with_unit(obj, unit)   -> the object as if read in ``unit``
    FORMATS                -> extension -> what it holds and what camcmm does with it
    read_calibration(path) -> dict; write_calibration(path, cal)  (camera calibrations,
                              OpenCV YAML or JSON; see camcmm.io.calibration)

The format follows the extension (any case). Lengths always come back in mm; the
object's ``source_unit`` records the unit of the file: the ``unit`` argument if given,
else what the file declares (a ``comment unit m`` in PLY, ``# unit m`` in text, PCD
and OBJ files, E57 is metres by definition), else mm. Every problem with a file raises
:class:`~camcmm.errors.InputError` with a one-line message that names the file.

Open3D, OpenCV and pye57 are imported only inside the functions that need them, so
``import camcmm.io`` stays light. One format per module: ply, pcd, text (xyz/txt/csv),
e57, stl, obj, image; height maps: x3p and sdf (read and written here), the
instruments' formats through SurfaceTopography (topography, imported when used).
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

import numpy as np

from ..cad import EXTENSIONS as CAD_EXTENSIONS
from ..cad import CadModel, read_cad
from ..errors import CamcmmError, InputError
from ..model import HeightMap, Image, PointCloud, TriangleMesh
from ..units import UnitDecision, decide_unit, object_span, to_mm_factor, unit_key
from ._common import Raw, atomic_path, canonical_unit
from .calibration import check_calibration, read_calibration, write_calibration
from .topography import VENDOR, summary

_CLOUD, _MESH, _IMAGE, _MAP, _CAD = "pointcloud", "mesh", "image", "heightmap", "cad"


def _fmt(
    name: str,
    kinds: list[str],
    writable: bool,
    description: str,
    *,
    binary: bool = False,
    colors: bool = False,
    normals: bool = False,
    fields: bool = False,
    unit: str = "mm",
) -> dict[str, Any]:
    return {
        "name": name,
        "description": description,
        "readable": True,
        "writable": writable,
        "kinds": kinds,
        "binary": binary,
        "colors": colors,
        "normals": normals,
        "fields": fields,
        "default_unit": unit,
    }


_TEXT = "point list as text (x y z [r g b] [nx ny nz] [more columns]), ',' ';' tab or space separated"
_IMG = "camera image (OpenCV, depth and channels kept)"
_IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")

#: Supported extensions (lower case, with the dot) -> description. ``binary``: the
#: ``binary`` argument of :func:`write` chooses between a binary and a text encoding;
#: ``colors``/``normals``/``fields``: what the format keeps besides the coordinates;
#: ``default_unit``: the unit assumed when neither the file nor the caller says.
FORMATS: dict[str, dict[str, Any]] = {
    ".ply": _fmt(
        "PLY",
        [_CLOUD, _MESH],
        True,
        "Stanford polygon file, ascii or binary",
        binary=True,
        colors=True,
        normals=True,
        fields=True,
    ),
    ".pcd": _fmt(
        "PCD",
        [_CLOUD],
        True,
        "Point Cloud Library file, ascii, binary or binary_compressed "
        "(writes float32 coordinates, as PCL and Open3D expect)",
        binary=True,
        colors=True,
        normals=True,
        fields=True,
    ),
    ".xyz": _fmt("XYZ", [_CLOUD], True, _TEXT, colors=True, normals=True, fields=True),
    ".txt": _fmt("TXT", [_CLOUD], True, _TEXT, colors=True, normals=True, fields=True),
    ".csv": _fmt("CSV", [_CLOUD], True, _TEXT, colors=True, normals=True, fields=True),
    ".e57": _fmt(
        "E57",
        [_CLOUD],
        True,
        "ASTM E57 scanner file (metres by definition; colours and intensity kept)",
        colors=True,
        fields=True,
        unit="m",
    ),
    ".stl": _fmt("STL", [_MESH], True, "STL triangle mesh, ascii or binary (binary stores float32)", binary=True),
    ".obj": _fmt("OBJ", [_MESH], True, "Wavefront OBJ mesh (vertices, faces, vertex normals)", normals=True),
    **{
        ext: _fmt(ext[1:].upper().replace("JPEG", "JPG").replace("TIFF", "TIF"), [_IMAGE], True, _IMG)
        for ext in _IMAGE_EXTS
    },
    ".x3p": _fmt("X3P", [_MAP], True, "ISO 25178-72 height map (zip of XML and binary; metres)", unit="m"),
    ".sdf": _fmt("SDF", [_MAP], True, "ISO 25178-71 height map, ascii or binary (metres)", binary=True, unit="m"),
    **{
        ext: {**_fmt(what, [_MAP], False, f"{what} height map (read through SurfaceTopography)"), "name": what}
        for ext, (_key, what) in VENDOR.items()
    },
    # CAD B-reps: read as camcmm.cad.CadModel (OpenCascade), in mm whatever the file's unit
    **{
        ext: _fmt(what, [_CAD], False, f"{what} CAD model (B-rep, read with OpenCascade; exact faces)")
        for ext, what in CAD_EXTENSIONS.items()
    },
}


#: Extension -> the module of this package that reads and writes it.
_MODULES = {
    ".ply": "ply",
    ".pcd": "pcd",
    ".xyz": "text",
    ".txt": "text",
    ".csv": "text",
    ".e57": "e57",
    ".stl": "stl",
    ".obj": "obj",
    **{ext: "image" for ext in _IMAGE_EXTS},
    ".x3p": "x3p",
    ".sdf": "sdf",
    **{ext: "topography" for ext in VENDOR},
}


def _format(path: Path) -> dict[str, Any]:
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        known = ", ".join(sorted(FORMATS))
        what = f"extension {path.suffix!r}" if path.suffix else "no extension"
        raise InputError(f"{path.name}: unknown file format ({what}); camcmm reads {known}")
    return fmt


def _module(path: Path):
    return importlib.import_module(f"{__name__}.{_MODULES[path.suffix.lower()]}")


def _kind(obj: Any) -> str:
    if isinstance(obj, PointCloud):
        return _CLOUD
    if isinstance(obj, TriangleMesh):
        return _MESH
    if isinstance(obj, Image):
        return _IMAGE
    if isinstance(obj, HeightMap):
        return _MAP
    if isinstance(obj, CadModel):
        return _CAD
    raise InputError(
        f"cannot write a {type(obj).__name__}: camcmm.io writes PointCloud, TriangleMesh, HeightMap and Image"
    )


def _read(path: str | Path, unit: str | None) -> tuple[Any, dict[str, Any], Raw | None]:
    p = Path(path)
    fmt = _format(p)
    if not p.exists():
        raise InputError(f"{p.name}: file not found ({p})")
    if not p.is_file():
        raise InputError(f"{p.name}: not a file ({p})")
    if p.stat().st_size == 0:
        raise InputError(f"{p.name}: the file is empty (0 bytes)")
    if fmt["kinds"] == [_CAD]:  # a CAD file states its unit; OpenCascade converts it to mm
        return read_cad(p), fmt, None
    if unit is not None:  # a bad unit fails before the read
        unit = canonical_unit(unit) or unit
        factor = to_mm_factor(unit)
    else:
        factor = None
    try:
        raw = _module(p).read(p, p.name)
    except CamcmmError:
        raise
    except MemoryError:
        raise InputError(f"{p.name}: not enough memory to read the file") from None
    except Exception as exc:  # a library's own error, reworded to name the file
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise InputError(f"{p.name}: cannot read {fmt['name']} file ({reason})") from exc
    if isinstance(raw, Image):
        return raw, fmt, None
    if isinstance(raw, HeightMap):
        return (raw if unit is None else with_unit(raw, unit)), fmt, None
    return _build(raw, p.name, fmt, unit, factor), fmt, raw


def _build(raw: Raw, name: str, fmt: dict[str, Any], unit: str | None, factor: float | None):
    source: str | None
    if unit is not None:
        source = unit.strip().lower().replace("µ", "u")
    elif raw.unit is not None:
        source = canonical_unit(raw.unit)
        if source is None:
            raise InputError(
                f"{name}: the file declares the unit {raw.unit!r}, which camcmm does not know; "
                f"pass unit= (m, mm, um, ...) to say what it is"
            )
        factor = to_mm_factor(source)
    else:
        source = fmt["default_unit"]
        factor = to_mm_factor(source)
    points = raw.points * factor if factor != 1.0 else raw.points
    if raw.faces is None and fmt["kinds"] == [_MESH]:
        raw.faces = np.zeros((0, 3), np.int64)
    if raw.faces is None:
        return PointCloud(points, raw.colors, raw.normals, raw.fields, raw.field_units, name, source)
    fields = dict(raw.fields)
    if raw.colors is not None:  # a mesh has no colour slot; keep them rather than drop them
        fields.update(red=raw.colors[:, 0], green=raw.colors[:, 1], blue=raw.colors[:, 2])
    return TriangleMesh(points, raw.faces, raw.normals, fields, raw.field_units, name, source)


def read(path: str | Path, unit: str | None = None) -> PointCloud | TriangleMesh | Image | CadModel:
    """Read a point cloud, mesh, image or CAD model (STEP/IGES: a
    :class:`~camcmm.cad.CadModel`, in mm from the file's own unit); the format follows the
    extension.

    ``unit`` is the length unit of the file's coordinates when you know better than
    the file ("m", "mm", "um", ...). Clouds and meshes come back in mm with
    ``source_unit`` set; ``name`` is the file name. Raises InputError naming the file.
    """
    return _read(path, unit)[0]


def stated_unit(raw: Raw | None, fmt: dict[str, Any], unit: str | None) -> str | None:
    """The unit stated for a file's coordinates: the caller's ``unit``, else the file's
    own (a unit comment; E57 is metres by definition), else None (read as mm, unstated)."""
    if unit is not None:
        return canonical_unit(unit) or unit.strip().lower().replace("µ", "u")
    if raw is not None and raw.unit is not None:
        return canonical_unit(raw.unit)
    return None if fmt["default_unit"] == "mm" else fmt["default_unit"]


def read_stated(path: str | Path, unit: str | None = None) -> tuple[Any, str | None]:
    """As :func:`read`, with the unit stated for the coordinates (:func:`stated_unit`;
    None when neither the file nor the caller says). Give both to
    :func:`camcmm.units.decide_unit` to know whether to ask."""
    obj, fmt, raw = _read(path, unit)
    if isinstance(obj, (HeightMap, CadModel)):  # every height-map and CAD format states its unit
        return obj, obj.source_unit
    return obj, (None if isinstance(obj, Image) else stated_unit(raw, fmt, unit))


def unit_decision(obj: Any, stated: str | None, expected: float | None = None, what: str = "part") -> UnitDecision:
    """:func:`camcmm.units.decide_unit` for a cloud or mesh as read (its size and ``source_unit``)."""
    return decide_unit(
        object_span(obj),
        stated,
        unit=getattr(obj, "source_unit", None) or "mm",
        expected=expected,
        name=str(getattr(obj, "name", "") or "the file"),
        what=what,
    )


def with_unit(obj: Any, unit: str) -> Any:
    """The cloud or mesh as if read in ``unit``: coordinates rescaled from its
    ``source_unit`` and ``source_unit`` set (fields keep their own units)."""
    unit = canonical_unit(unit) or unit_key(unit)
    k = to_mm_factor(unit) / to_mm_factor(getattr(obj, "source_unit", "mm") or "mm")
    if isinstance(obj, PointCloud):
        return PointCloud(
            obj.points * k, obj.colors, obj.normals, dict(obj.fields), dict(obj.field_units), obj.name, unit
        )
    if isinstance(obj, TriangleMesh):
        return TriangleMesh(
            obj.vertices * k, obj.faces, obj.vertex_normals, dict(obj.fields), dict(obj.field_units), obj.name, unit
        )
    if isinstance(obj, HeightMap):  # one unit for the steps and the heights, as the formats have
        o = obj.origin
        return HeightMap(
            obj.heights * k, obj.dx * k, obj.dy * k, obj.intensity, (o[0] * k, o[1] * k), obj.name, unit, obj.meta
        )
    raise InputError(f"{getattr(obj, 'name', 'item')}: a {type(obj).__name__} has no length unit")


def write(
    obj: PointCloud | TriangleMesh | HeightMap | Image, path: str | Path, binary: bool = True, unit: str = "mm"
) -> None:
    """Write a cloud, mesh, height map (or image) to ``path``; the format follows the extension.

    ``binary`` picks the binary encoding where the format has both (PLY, PCD, STL, SDF);
    ``unit`` is the length unit of the written coordinates (E57, X3P and SDF are always
    metres; a height map's intensity is not kept by X3P or SDF). The
    file is written under a temporary name in the same folder and then renamed, so
    ``path`` never holds a half-written file.
    """
    p = Path(path)
    fmt = _format(p)
    kind = _kind(obj)
    if kind == _CAD:
        raise InputError(f"{p.name}: camcmm does not write CAD models; keep the STEP/IGES file itself")
    if not fmt["writable"] or kind not in fmt["kinds"]:
        can = ", ".join(ext for ext, f in FORMATS.items() if f["writable"] and kind in f["kinds"])
        if kind in fmt["kinds"]:  # an instrument's format: read, not written
            raise InputError(f"{p.name}: camcmm reads {fmt['name']} but does not write it; write it as one of {can}")
        raise InputError(f"{p.name}: {fmt['name']} cannot hold a {kind}; write it as one of {can}")
    unit = canonical_unit(unit) or unit
    factor = to_mm_factor(unit)
    unit = unit.strip().lower().replace("µ", "u")
    if not p.parent.is_dir():
        raise InputError(f"{p.name}: cannot write, the folder {p.parent} does not exist")
    try:
        with atomic_path(p) as tmp:
            _module(p).write(obj, tmp, binary=binary, unit=unit, factor=factor, name=p.name)
    except CamcmmError:
        raise
    except Exception as exc:
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise InputError(f"{p.name}: cannot write {fmt['name']} file ({reason})") from exc


def info(path: str | Path, unit: str | None = None) -> dict[str, Any]:
    """A JSON-able summary of a file: counts, bounding box in mm, units, fields, size."""
    obj, fmt, raw = _read(path, unit)
    p = Path(path)
    out: dict[str, Any] = {"file": p.name, "format": fmt["name"], "kind": _kind(obj)}
    if raw is not None and raw.encoding:
        out["encoding"] = raw.encoding
    if isinstance(obj, HeightMap):
        out.update(summary(obj))
        out["warnings"] = [] if obj.n_valid else [f"{p.name}: the height map has no valid point"]
    elif isinstance(obj, CadModel):
        out.update(obj.summary())
        out.update(kind=_CAD, unit="mm", bbox={"min": obj.bounds[0].tolist(), "max": obj.bounds[1].tolist()})
        out["warnings"] = []
    elif isinstance(obj, Image):
        d = obj.data
        out.update(
            width=int(d.shape[1]),
            height=int(d.shape[0]),
            channels=1 if d.ndim == 2 else int(d.shape[2]),
            dtype=str(d.dtype),
        )
    else:
        if isinstance(obj, PointCloud):
            out["n_points"] = obj.n_points
            has_colors, has_normals = obj.colors is not None, obj.normals is not None
            empty = obj.n_points == 0
        else:
            out.update(n_vertices=obj.n_vertices, n_faces=obj.n_faces)
            has_colors, has_normals = False, obj.vertex_normals is not None
            empty = obj.n_vertices == 0
        lo, hi = (np.full(3, np.nan), np.full(3, np.nan)) if empty else obj.bounds
        out["bbox"] = {
            "min": [None if empty else float(v) for v in lo],
            "max": [None if empty else float(v) for v in hi],
        }
        out.update(
            unit="mm",
            source_unit=obj.source_unit,
            fields=list(obj.fields),
            has_colors=has_colors,
            has_normals=has_normals,
        )
        check = unit_decision(obj, stated_unit(raw, fmt, unit))
        out["unit_check"] = check.to_json()
        out["warnings"] = [check.reason] if check.asks else []
    out["bytes"] = p.stat().st_size
    return out


__all__ = [
    "FORMATS",
    "check_calibration",
    "info",
    "read",
    "read_calibration",
    "read_stated",
    "stated_unit",
    "unit_decision",
    "with_unit",
    "write",
    "write_calibration",
]
