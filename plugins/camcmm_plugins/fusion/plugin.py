"""Host entry of ``fusion.csi`` (plugin.yaml)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import HeightMap, InputError, PointCloud, read, read_yaml

from . import pipeline

#: what a file given as a map holds instead, in words (as the host names a wrong kind)
_KINDS = {"PointCloud": "a point cloud", "TriangleMesh": "a triangle mesh", "Image": "an image"}


def load_maps(csi) -> tuple[list[HeightMap], list[str]]:
    """HeightMaps and their names from paths or HeightMap objects (one or a list)."""
    items = csi if isinstance(csi, (list, tuple)) else [csi]
    if not items:
        raise InputError("csi: no height map given")
    maps, names = [], []
    for it in items:
        hm = read(it) if isinstance(it, (str, Path)) else it
        name = str(it) if isinstance(it, (str, Path)) else getattr(it, "name", "height map")
        if not isinstance(hm, HeightMap):
            kind = _KINDS.get(type(hm).__name__, f"a {type(hm).__name__}")
            raise InputError(f"{name}: this is {kind}, not a height map (.x3p .sdf .dat .opd .plu ...)")
        if hm.n_valid < 16:
            raise InputError(f"{name}: {hm.n_valid} valid points, too few for a fusion")
        maps.append(hm)
        names.append(name)
    return maps, names


def load_datum(datum) -> dict | None:
    """The datum plane {"point": [x, y, z], "normal": [nx, ny, nz]} from a dict or a JSON file."""
    if datum is None:
        return None
    name = str(datum) if isinstance(datum, (str, Path)) else "datum"
    d = read_yaml(datum) if isinstance(datum, (str, Path)) else datum
    try:
        p = np.asarray(d["point"], dtype=float).reshape(3)
        n = np.asarray(d["normal"], dtype=float).reshape(3)
    except (KeyError, TypeError, ValueError):
        raise InputError(f'{name}: a datum is {{"point": [x, y, z], "normal": [nx, ny, nz]}} (mm)') from None
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(n)) and np.linalg.norm(n) > 0):
        raise InputError(f"{name}: the datum's point and normal must be finite, the normal not zero")
    return {"point": p.tolist(), "normal": n.tolist()}


def fuse_csi(ctx, cloud: PointCloud, csi, datum: dict | None = None, **params: Any) -> dict[str, Any]:
    """fusion.csi: see plugin.yaml and docs/fusion.md."""
    maps, names = load_maps(csi)
    datum = load_datum(datum)
    mr_alg = ctx.algorithm("inspect.material-ratio")

    def material_ratio(d: np.ndarray) -> dict:
        # the difference as a cloud field: inspect.material-ratio analyses it (no second copy of ISO 13565-2 here)
        pc = PointCloud(np.zeros((len(d), 3)), fields={"difference": d}, name="CSI − photogrammetry")
        out = mr_alg(source=pc, field="difference")
        return out["material_ratio"] | {k: out[k] for k in ("Sk", "Spk", "Svk", "Smr1", "Smr2")}

    # the messages name a parameter as the form labels it ("sigma [px]"), not by its key
    words = {p.name: p.label for p in ctx.host.get(ctx.plugin_id).parameters}

    def named(key: str) -> str:
        return words.get(key, key.replace("_", " "))

    out = pipeline.run(
        cloud, maps, names, datum=datum, material_ratio=material_ratio, progress=ctx.progress, named=named, **params
    )
    for w in out["result"]["warnings"]:
        ctx.warn(w)
    return out
