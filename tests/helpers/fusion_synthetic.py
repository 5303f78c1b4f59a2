"""Exact-by-construction data for the fusion tests and benchmark (issue 17): a coin-like
relief (mm of form, µm texture) coloured by a smooth texture, sampled as a scaled, moved
photogrammetry cloud and as a rotated, shifted, tilted CSI height map."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from camcmm.api import HeightMap, PointCloud

# the construction is the plugin's own (its sample pair, ``camcmm fuse sample``): one copy
from camcmm_plugins.fusion.sample import (  # noqa: E402, F401
    BLOB_SIGN,
    RNG_BLOBS,
    WAVES,
    affine,
    csi_map,
    photo_cloud,
    rx,
    ry,
    rz,
    surface,
    texture,
    truth_in_fused_frame,
)

# -- a real height map as both sides (tests/fusion/test_fusion_real.py, the fuse browser test) --
FILES = {"test_1.dat": "shaded", "test_1.opd": "auto", "test_2.opd": "auto", "test_1.plu": "auto"}
SCALE = 1.03
POSE = affine(rz(np.radians(20)) @ rx(np.radians(5)), [1.0, 2.0, 3.0])


def make_case(path: Path, grey: str):
    from camcmm.api import read
    from camcmm_plugins.fusion.prepare import shade

    hm = read(path)
    ny, nx = hm.shape
    g = hm.intensity if (hm.intensity is not None and grey != "shaded") else shade(hm.heights, hm.dx, hm.dy)
    i, j = np.mgrid[0:ny:2, 0:nx:2]
    i, j = i.ravel(), j.ravel()
    ok = hm.valid[i, j] & np.isfinite(g[i, j])
    i, j = i[ok], j[ok]
    p = np.column_stack([hm.origin[0] + j * hm.dx, hm.origin[1] + i * hm.dy, hm.heights[i, j]])
    lo, hi = np.percentile(g[i, j], [1, 99])
    gv = np.clip((g[i, j] - lo) / (hi - lo) * 255, 0, 255).astype(np.uint8)
    cloud = PointCloud(
        SCALE * p @ POSE[:3, :3].T + POSE[:3, 3], colors=np.repeat(gv[:, None], 3, 1), name=f"{path.name}.ply"
    )
    a, b = ny // 5, nx // 5
    crop = HeightMap(
        hm.heights[a : ny - a, b : nx - b],
        hm.dx,
        hm.dy,
        intensity=None if hm.intensity is None else hm.intensity[a : ny - a, b : nx - b],
        origin=(hm.origin[0] + b * hm.dx, hm.origin[1] + a * hm.dy),
        name=path.name,
    )
    return cloud, crop
