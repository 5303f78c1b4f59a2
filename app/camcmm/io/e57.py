"""ASTM E57 scanner files, through pye57 (imported only when an E57 file is used).

Reading: every scan of the file, moved into the file's coordinate system by its pose
(spherical scans converted to cartesian, points flagged invalid dropped) and stacked:
points (N, 3) float64 in metres (E57 is metric by definition; the caller converts to
mm), ``colorRed/Green/Blue`` -> colours (N, 3) uint8 when every scan has them,
``intensity`` -> the field ``intensity`` when every scan has it.

Writing: one scan; cartesian coordinates always in metres (the standard fixes the
unit, so the ``unit`` argument does not apply) as double precision, because
pye57's own writer stores single precision, 0.1 µm steps at 1 m; colours and the
``intensity`` field are stored, other fields and normals are not (E57 has no standard
place for them).
"""

from __future__ import annotations

import uuid
from pathlib import Path

import numpy as np

from .. import __version__
from ._common import Raw, cloud_columns, fail

_CHUNK = 1_000_000


def read(path: Path, name: str) -> Raw:
    import pye57

    try:
        e57 = pye57.E57(str(path))
    except Exception as exc:
        raise fail(name, f"not a readable E57 file ({_reason(exc)})") from exc
    try:
        # pye57 cannot make buffers for a scan without points; such scans add nothing anyway
        scans = [
            e57.read_scan(i, intensity=True, colors=True, ignore_missing_fields=True, transform=True)
            for i in range(e57.scan_count)
            if e57.get_header(i).point_count > 0
        ]
    except Exception as exc:
        raise fail(name, f"cannot read the E57 scans ({_reason(exc)})") from exc
    finally:
        e57.close()
    if not scans:
        return Raw(np.zeros((0, 3)), unit="m", encoding="binary")
    points = np.vstack([np.column_stack([s["cartesianX"], s["cartesianY"], s["cartesianZ"]]) for s in scans])
    colors = None
    if all("colorRed" in s for s in scans):
        colors = np.vstack([np.column_stack([s["colorRed"], s["colorGreen"], s["colorBlue"]]) for s in scans])
        colors = colors.astype(np.uint8)
    fields = {}
    if all("intensity" in s for s in scans):
        fields["intensity"] = np.concatenate([s["intensity"] for s in scans])
    return Raw(points.astype(np.float64), colors, None, fields, {}, None, "m", "binary")


def _reason(exc: Exception) -> str:
    # libe57 appends a debug dump with file paths to its message; the first part is the reason
    text = " ".join(str(exc).split()).split(" ****")[0] or type(exc).__name__
    return text[:200]


def write(obj, path: Path, *, binary: bool, unit: str, factor: float, name: str) -> None:
    import pye57
    from pye57 import libe57

    pts, colors, _, fields = cloud_columns(obj, 1000.0)  # E57 is metres, whatever ``unit`` says
    n = len(pts)
    intensity = fields.get("intensity")
    e57 = pye57.E57(str(path), mode="w")
    try:
        imf = e57.image_file
        scan = libe57.StructureNode(imf)
        scan.set("guid", libe57.StringNode(imf, f"{{{uuid.uuid4()}}}"))
        scan.set("name", libe57.StringNode(imf, str(obj.name)))
        scan.set("description", libe57.StringNode(imf, f"written by camcmm {__version__}"))
        lo = pts.min(axis=0) if n else np.zeros(3)
        hi = pts.max(axis=0) if n else np.zeros(3)
        bounds = libe57.StructureNode(imf)
        for j, c in enumerate("xyz"):
            bounds.set(f"{c}Minimum", libe57.FloatNode(imf, float(lo[j])))
            bounds.set(f"{c}Maximum", libe57.FloatNode(imf, float(hi[j])))
        scan.set("cartesianBounds", bounds)
        pose = libe57.StructureNode(imf)
        rotation, translation = libe57.StructureNode(imf), libe57.StructureNode(imf)
        for k, val in zip("wxyz", (1.0, 0.0, 0.0, 0.0)):
            rotation.set(k, libe57.FloatNode(imf, val))
        for k in "xyz":
            translation.set(k, libe57.FloatNode(imf, 0.0))
        pose.set("rotation", rotation)
        pose.set("translation", translation)
        scan.set("pose", pose)

        proto = libe57.StructureNode(imf)
        columns: dict[str, np.ndarray] = {}
        for j, c in enumerate("XYZ"):
            proto.set(
                f"cartesian{c}", libe57.FloatNode(imf, float(lo[j]), libe57.E57_DOUBLE, float(lo[j]), float(hi[j]))
            )
            columns[f"cartesian{c}"] = pts[:, j]
        if intensity is not None:
            values = np.asarray(intensity, dtype=np.float64)
            i_lo, i_hi = (float(values.min()), float(values.max())) if n else (0.0, 0.0)
            proto.set("intensity", libe57.FloatNode(imf, i_lo, libe57.E57_DOUBLE, i_lo, i_hi))
            limits = libe57.StructureNode(imf)
            limits.set("intensityMinimum", libe57.FloatNode(imf, i_lo))
            limits.set("intensityMaximum", libe57.FloatNode(imf, i_hi))
            scan.set("intensityLimits", limits)
            columns["intensity"] = values
        if colors is not None:
            limits = libe57.StructureNode(imf)
            for j, c in enumerate(("Red", "Green", "Blue")):
                proto.set(f"color{c}", libe57.IntegerNode(imf, 0, 0, 255))
                limits.set(f"color{c}Minimum", libe57.IntegerNode(imf, 0))
                limits.set(f"color{c}Maximum", libe57.IntegerNode(imf, 255))
                columns[f"color{c}"] = colors[:, j]
            scan.set("colorLimits", limits)
        points = libe57.CompressedVectorNode(imf, proto, libe57.VectorNode(imf, True))
        scan.set("points", points)
        e57.data3d.append(scan)

        capacity = max(1, min(n, _CHUNK))
        buffers = libe57.VectorSourceDestBuffer()
        staging = {}
        for key in columns:
            staging[key] = np.empty(capacity, np.uint8 if key.startswith("color") else np.float64)
            buffers.append(libe57.SourceDestBuffer(imf, key, staging[key], capacity, True, True))
        writer = points.writer(buffers)
        for start in range(0, n, capacity):
            count = min(capacity, n - start)
            for key, col in columns.items():
                staging[key][:count] = col[start : start + count]
            writer.write(count)
        writer.close()
    finally:
        e57.close()
