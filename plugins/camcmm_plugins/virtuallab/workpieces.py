"""More artefacts for rendered scenes: gauge blocks wrung on a platen, plain boxes, and
triangle meshes (any part or CAD model). Lengths in mm. Each builder returns
``(primitives, truth)`` like those of ``artefacts.py``.

Gauge blocks: rectangular blocks (ISO 3650: cross-section 30 x 9 mm up to 10 mm
length, 35 x 9 mm above) standing on their measuring face on a platen; the gauge
length is the distance from the free measuring face to the platen's surface (the
wrung face). Truth: each block's length, the centre of its free face, and the
platen's surface plane.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .raycast import Box, Mesh
from .scene import _unit


def frame(direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Rows: in-plane axis u (``direction`` made normal to ``normal``), v = n x u, n."""
    n = _unit(normal)
    d = np.asarray(direction, float)
    u = d - (d @ n) * n
    if not np.linalg.norm(u) > 1e-9:
        raise ValueError(f"direction {list(direction)} is parallel to the normal {list(normal)}")
    u = _unit(u)
    return np.vstack([u, np.cross(n, u), n])


def gauge_blocks(
    center, blocks, platen=(200.0, 150.0, 30.0), direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)
) -> tuple[list, dict[str, Any]]:
    """Blocks on a platen whose top surface is centred at ``center``; ``blocks`` is a
    list of {length, at: [a, b] (mm along the platen's axes), size: [w, d] (mm; default
    per ISO 3650), turn (deg about the normal)}; ``platen`` [length, width, thickness]."""
    c = np.asarray(center, float)
    F = frame(direction, normal)
    u, v, n = F
    pl = np.asarray(platen, float)
    prims: list = [Box(c - n * pl[2] / 2, F, pl, "platen")]
    truth_blocks = []
    for i, b in enumerate(blocks):
        L = float(b["length"])
        if not L > 0:
            raise ValueError(f"gauge block {i + 1}: length {L!r} must be > 0 mm")
        w, dep = (float(x) for x in b.get("size", (30.0 if L <= 10 else 35.0, 9.0)))
        a, bb = (float(x) for x in b.get("at", (0.0, 0.0)))
        turn = np.radians(float(b.get("turn", 0.0)))
        bu = np.cos(turn) * u + np.sin(turn) * v
        bf = np.vstack([bu, np.cross(n, bu), n])
        base = c + a * u + bb * v
        prims.append(Box(base + n * L / 2, bf, np.array([w, dep, L], float), f"gauge block {i + 1}"))
        truth_blocks.append(
            {
                "label": f"gauge block {i + 1}",
                "length": L,
                "size": [w, dep],
                "top_center": (base + n * L).tolist(),
                "base_center": base.tolist(),
            }
        )
    return prims, {
        "kind": "gauge_blocks",
        "blocks": truth_blocks,
        "platen": {"point": c.tolist(), "normal": n.tolist(), "size": pl.tolist()},
        "center": c.tolist(),
    }


def box(center, size, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)) -> tuple[list, dict[str, Any]]:
    F = frame(direction, normal)
    b = Box(center, F, size, "box")
    return [b], {"kind": "box", "center": b.center.tolist(), "axes": b.axes.tolist(), "size": b.size.tolist()}


def rotation_xyz(deg) -> np.ndarray:
    """R = Rz Ry Rx of angles (deg) about the world x, y, z axes."""
    ax, ay, az = np.radians(np.asarray(deg, float))
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def mesh(
    vertices, faces, position=(0.0, 0.0, 0.0), rotation_deg=(0.0, 0.0, 0.0), scale: float = 1.0, label: str = "mesh"
) -> tuple[list, dict[str, Any]]:
    """A mesh placed by x' = R (scale x) + position (R from ``rotation_deg``)."""
    R = rotation_xyz(rotation_deg)
    V = (np.asarray(vertices, float) * float(scale)) @ R.T + np.asarray(position, float)
    m = Mesh(V, faces, label)
    return [m], {
        "kind": "mesh",
        "label": label,
        "n_triangles": int(len(m.triangles)),
        "position": list(map(float, position)),
        "rotation_deg": list(map(float, rotation_deg)),
        "scale": float(scale),
        "area": m.area,
    }
