"""Import of reconstructions made elsewhere: a COLMAP model (text or binary) or an Agisoft
Metashape / PhotoScan export (delimited point cloud and/or camera XML) — the thesis's own
data path (ch. 4.5: clouds reconstructed in PhotoScan and exported).

Everything comes out in one convention: OpenCV cameras (px, the centre of the top-left
pixel at (0, 0)) and world-to-camera poses ``x_cam = R X + t``; coordinates are the
file's, whose scale is the reconstruction's own unless a chunk transform sets one.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, PathRefused, PointCloud, checked_path, read

from . import colmap_model, metashape
from .cameras import COLMAP_PARAMS, opencv_from_colmap

#: Delimited clouds (and PLY, Metashape's other export), read by camcmm.api.read: x y z
#: [r g b] [nx ny nz], a header by name, colours and normals told apart by content, extra
#: columns kept as fields, a "# unit m" comment honoured.
CLOUD_SUFFIXES = (".txt", ".xyz", ".csv", ".ply")

ARBITRARY_SCALE = (
    "{name}: the coordinates are in the reconstruction's own arbitrary scale (not mm); "
    "scale them (spheres, lengths or a bar) before measuring lengths"
)


def read_reconstruction(path) -> dict[str, Any]:
    """Read a reconstruction made elsewhere.

    Parameters
    ----------
    path : a COLMAP model folder (cameras/images/points3D as .txt or .bin, or a folder
        holding ``sparse/0``), one of its files, a Metashape/PhotoScan point cloud
        (.txt/.xyz/.csv: x y z [r g b] [nx ny nz], read by camcmm.api.read; a camera XML with the same stem, or the
        only Agisoft XML beside it, is read too) or a camera XML alone.

    Returns
    -------
    dict ``cloud`` (PointCloud, coordinates as in the file; for a COLMAP dense workspace
    its ``fused.ply``, the model's points then in ``sparse``), ``camera`` (the first
    camera) and ``cameras`` [{model, fx, fy, cx, cy, dist, width, height}] (OpenCV
    convention, px), ``views`` [{image, R, t, centre, camera}] (``x_cam = R X + t``,
    R (3, 3) and t, centre (3,) as lists; camera: index into cameras), ``n_points``,
    ``source`` {format, path}, ``warnings``.

    Raises
    ------
    InputError : one line naming the file and the line or field at fault.
    """
    # checked before it is looked at: a confined run (the server) refuses a path outside
    # its folders alike whether it exists or not
    p = checked_path(path, "reconstruction")
    if not p.exists():
        raise InputError(f"{p}: no such file or folder")
    if p.is_file() and p.stem in colmap_model.FILES and p.suffix.lower() in (".txt", ".bin"):
        p = p.parent
    if p.is_dir():
        found = colmap_model.model_folder(p)
        if found is None:
            raise InputError(
                f"{p}: not a COLMAP model folder (cameras, images, points3D as .txt or .bin, or sparse/0 inside)"
            )
        return _from_colmap(checked_path(found[0], "COLMAP model"), found[1], given=p)  # sparse/ may be a link
    if p.suffix.lower() == ".xml":
        cloud = next((c for s in CLOUD_SUFFIXES if (c := p.with_suffix(s)).is_file()), None)
        return _from_metashape(cloud, p)
    if p.suffix.lower() in CLOUD_SUFFIXES:
        return _from_metashape(p, _xml_beside(p))
    raise InputError(f"{p}: not a COLMAP model or Metashape export (expected a folder, .txt/.xyz/.csv/.ply or .xml)")


def _xml_beside(cloud: Path) -> Path | None:
    """The camera XML of a cloud: same stem, else the only Agisoft XML in its folder."""
    same = cloud.with_suffix(".xml")
    if same.is_file():
        return same
    agisoft = []
    for x in sorted(cloud.parent.glob("*.xml")):
        try:
            root = next(ET.iterparse(x, events=("start",)))[1]
        except (ET.ParseError, OSError, StopIteration):
            continue
        if root.tag in ("document", "chunk"):
            agisoft.append(x)
    return agisoft[0] if len(agisoft) == 1 else None


def _view(name: str, R: np.ndarray, t: np.ndarray, camera: int) -> dict[str, Any]:
    return {
        "image": name,
        "R": np.asarray(R, float).tolist(),
        "t": np.asarray(t, float).tolist(),
        "centre": (-np.asarray(R).T @ np.asarray(t)).tolist(),
        "camera": camera,
    }


def colmap_camera(model: str, width: int, height: int, params: np.ndarray, warnings: list[str]) -> dict[str, Any]:
    """OpenCV description of a COLMAP camera (cx, cy moved by -0.5 px: COLMAP puts the
    centre of the top-left pixel at (0.5, 0.5), OpenCV at (0, 0))."""
    if model in COLMAP_PARAMS:
        cam = opencv_from_colmap(model, params)
        cam.pop("K", None)
    else:
        # fisheye and FOV models: pinhole part as OpenCV's, the rest kept as COLMAP's
        warnings.append(f"camera model {model} has no OpenCV pinhole equivalent; its distortion is COLMAP's own")
        p = [float(v) for v in params]
        f2 = model in colmap_model.TWO_FOCAL
        fx, fy, cx, cy = (p[0], p[1], p[2], p[3]) if f2 else (p[0], p[0], p[1], p[2])
        cam = {"model": model, "fx": fx, "fy": fy, "cx": cx - 0.5, "cy": cy - 0.5, "dist": p[4 if f2 else 3 :]}
    cam.update(width=int(width), height=int(height))
    return cam


def _dense_ply(given: Path, folder: Path) -> Path | None:
    """COLMAP's fused dense cloud of a dense workspace (``dense/0/fused.ply`` beside
    ``dense/0/sparse``), named by the folder given or the model folder's parent."""
    for d in (given, folder.parent):
        try:  # the parent may lie outside a confined run's folders: then it is not looked at
            ply = checked_path(d / "fused.ply", "dense cloud")
        except PathRefused:
            continue
        if ply.is_file():
            return ply
    return None


def _from_colmap(folder: Path, ext: str, given: Path | None = None) -> dict[str, Any]:
    m = colmap_model.read_model(folder, ext)
    warnings: list[str] = []
    ids = sorted(m.cameras)
    cameras = [colmap_camera(*m.cameras[c], warnings) for c in ids]
    views = [_view(name, R, t, ids.index(cid)) for _, name, cid, R, t in m.images]
    if not views:
        warnings.append(f"{folder}: the model has no registered image")
    cloud = PointCloud(
        m.xyz,
        m.rgb,
        fields={"track_length": m.track.astype(np.float64), "reprojection_error": m.error},
        field_units={"reprojection_error": "px"},
        name=folder.name if folder.name not in ("0", "sparse") else f"{folder.parent.name}/{folder.name}",
    )
    warnings.append(ARBITRARY_SCALE.format(name=folder))
    fmt = "colmap-" + ("binary" if ext == "bin" else "text")
    dense = _dense_ply(given or folder, folder)
    if dense is None:
        return _result(cloud, cameras, views, fmt, folder, warnings)
    out = _result(read(dense), cameras, views, fmt, folder, warnings)
    out.update(sparse=cloud, n_points_sparse=cloud.n_points)
    out["source"]["cloud"] = str(dense)
    return out


def _from_metashape(cloud_path: Path | None, xml: Path | None) -> dict[str, Any]:
    warnings: list[str] = []
    if cloud_path is not None:
        cloud = read(cloud_path)
        if not isinstance(cloud, PointCloud):  # pragma: no cover - text files are clouds
            raise InputError(f"{cloud_path}: not a point cloud")
    else:
        cloud = PointCloud(np.zeros((0, 3)), name=xml.name if xml else "cloud")
        warnings.append(f"{xml}: cameras only; no point cloud beside it (same name, .txt/.xyz/.csv/.ply)")
    cameras, views, scaled = [], [], False
    if xml is not None:
        x = metashape.read_cameras_xml(xml)
        cameras, scaled, warnings = x["cameras"], x["scaled"], warnings + x["warnings"]
        views = [_view(v["image"], v["R"], v["t"], v["camera"]) for v in x["views"]]
    name = cloud_path or xml
    if scaled:
        warnings.append(
            f"{xml}: the chunk transform sets a scale (Metashape works in metres): the coordinates are "
            "kept as in the file; check their unit"
        )
    else:
        warnings.append(ARBITRARY_SCALE.format(name=name))
    paths = [str(p) for p in (cloud_path, xml) if p is not None]
    return _result(cloud, cameras, views, "metashape", paths[0] if len(paths) == 1 else paths, warnings)


def _result(cloud, cameras, views, fmt: str, path, warnings: list[str]) -> dict[str, Any]:
    return {
        "cloud": cloud,
        "camera": cameras[0] if cameras else None,
        "cameras": cameras,
        "views": views,
        "n_points": cloud.n_points,
        "n_views": len(views),
        "source": {"format": fmt, "path": str(path) if not isinstance(path, list) else path},
        "warnings": warnings,
    }


def import_reconstruction(ctx, path) -> dict[str, Any]:
    """Plugin entry ``photogrammetry.import``: :func:`read_reconstruction` with its
    warnings passed to the run's result."""
    ctx.progress(0.05, "reading the reconstruction")
    out = read_reconstruction(path)
    for w in out["warnings"]:
        ctx.warn(w)
    meta = {k: v for k, v in out.items() if k not in ("cloud", "sparse", "warnings")}
    return {"cloud": out["cloud"], "reconstruction": meta}
