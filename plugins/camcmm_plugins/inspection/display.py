"""What a viewer of a comparison shows besides the deviations themselves: tolerance
bands, the spacing of a cloud and a section through the part.

Plain functions on numpy arrays (mm); the host entries ``inspect.bands`` and
``inspect.section`` (in :mod:`.plugin`) wrap them so that a GUI gets these numbers
through the plugin host instead of computing them itself.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError

AXES = ("x", "y", "z")
#: Band codes: below −tolerance, within ±tolerance, above +tolerance, not a number.
BELOW, WITHIN, ABOVE, INVALID = -1, 0, 1, 2


# =============================================================================== bands
def band_codes(dev: Any, tolerance: float) -> np.ndarray:
    """Per value (N,) int8: -1 below −tolerance, 0 within ±tolerance (inclusive, as
    the statistics count it), +1 above, 2 not a number. ``tolerance`` in the unit of
    ``dev`` (mm)."""
    d = np.asarray(dev, dtype=float)
    t = abs(float(tolerance))
    codes = np.zeros(d.shape, dtype=np.int8)
    with np.errstate(invalid="ignore"):
        codes[d > t] = ABOVE
        codes[d < -t] = BELOW
    codes[~np.isfinite(d)] = INVALID
    return codes


def band_counts(codes: Any) -> dict[str, int]:
    """How many values are below, within, above ±tolerance and not a number, from the
    codes of :func:`band_codes`."""
    n = np.bincount((np.asarray(codes, dtype=np.int8) + 1).astype(np.intp), minlength=4)
    return {"below": int(n[0]), "within": int(n[1]), "above": int(n[2]), "invalid": int(n[3])}


def within_share(counts: dict[str, int]) -> float:
    """The share (0..1) of the finite values within ±tolerance."""
    finite = max(counts["below"] + counts["within"] + counts["above"], 1)
    return counts["within"] / finite


# =============================================================================== spacing
def point_spacing(points: Any, queries: int = 5000, seed: int = 0) -> float:
    """Median nearest-neighbour distance of a cloud (mm), over a seeded sample of
    ``queries`` points against the whole (N, 3) cloud (an unbalanced KD-tree: two
    million points in about 0.4 s). Exact for regular grids as for scattered points,
    unlike a spacing measured on a subset and rescaled. 0 for fewer than two points."""
    from scipy.spatial import cKDTree

    P = np.asarray(points, dtype=float)
    n = len(P)
    if n < 2:
        return 0.0
    rng = np.random.default_rng(seed)
    tree = cKDTree(P, balanced_tree=False, compact_nodes=False)
    q = P if n <= queries else P[rng.choice(n, queries, replace=False)]
    d, _ = tree.query(q, k=2)
    nn = d[:, 1]
    nn = nn[nn > 0]
    return float(np.median(nn)) if nn.size else 0.0


# =============================================================================== section
def _chain(segments: list[tuple[Any, Any]], where: dict[Any, np.ndarray]) -> list[np.ndarray]:
    """Join segments (pairs of point keys) that share a key into polylines."""
    nbrs: dict[Any, list[int]] = {}
    for i, (a, b) in enumerate(segments):
        nbrs.setdefault(a, []).append(i)
        nbrs.setdefault(b, []).append(i)
    used = np.zeros(len(segments), dtype=bool)
    lines = []
    # open chains start at an end (a key of one segment); closed loops anywhere
    starts = [k for k, v in nbrs.items() if len(v) == 1] + list(nbrs)
    for start in starts:
        key, chain = start, [start]
        while True:
            nxt = next((i for i in nbrs[key] if not used[i]), None)
            if nxt is None:
                break
            used[nxt] = True
            a, b = segments[nxt]
            key = b if a == key else a
            chain.append(key)
        if len(chain) >= 2:
            lines.append(np.asarray([where[k] for k in chain], dtype=float))
    return lines


def mesh_section(vertices: Any, faces: Any, axis: int, position: float) -> list[np.ndarray]:
    """The cut of a triangle mesh by the plane ``coord[axis] = position``: polylines of
    (k, 3) points (mm). A vertex on the plane is a point of the cut; a triangle lying
    in the plane adds nothing (its neighbours draw its outline)."""
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    d = V[:, axis] - float(position)
    sd = np.sign(d)
    fd = sd[F]
    # only triangles with a vertex on each side, or touching the plane with an edge/vertex
    hit = ~((fd > 0).all(axis=1) | (fd < 0).all(axis=1) | (fd == 0).all(axis=1))
    where: dict[Any, np.ndarray] = {}
    segments: list[tuple[Any, Any]] = []
    for tri in F[hit]:
        keys = []
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            if sd[a] == 0:
                k: Any = ("v", int(a))
                where.setdefault(k, V[a])
                keys.append(k)
            if sd[a] * sd[b] < 0:
                k = ("e", int(min(a, b)), int(max(a, b)))
                if k not in where:
                    t = d[a] / (d[a] - d[b])
                    p = V[a] + t * (V[b] - V[a])
                    p[axis] = position
                    where[k] = p
                keys.append(k)
        keys = list(dict.fromkeys(keys))
        if len(keys) == 2:
            segments.append((keys[0], keys[1]))
    return _chain(segments, where)


def section(
    axis: int | str,
    position: float,
    points: Any,
    dev: Any,
    half_width: float,
    nominal: Any = None,
    nominal_points: Any = None,
    max_points: int = 6000,
    seed: int = 0,
) -> dict[str, Any]:
    """A cut through the part by the plane ``coord[axis] = position`` (mm).

    ``nominal``: a mesh (anything with ``vertices`` (V, 3) and ``faces`` (F, 3)),
    cut into polylines; ``nominal_points`` (M, 3): a nominal cloud, whose points
    within the slab are kept. The measured ``points`` (N, 3) within ±``half_width``
    of the plane come with their deviations ``dev`` (N,) (at most ``max_points``, a
    seeded subset). Returns 2-D coordinates on the plane's other two axes:
    ``{"axis", "position", "u", "v" (axis names), "nominal": [(k, 2) arrays],
    "nominal_points": (m, 2), "measured": (n, 2), "deviation": (n,), "n_in_slab",
    "half_width", "foot": (n, 2), "normal": (n, 2)}``: with a mesh, each measured point's
    closest point on the cut and the in-plane unit normal there, turned to the side a
    positive deviation lies on (the deviation whiskers start at ``foot`` and run along
    ``normal`` × deviation); without one both are (0, 2).
    """
    ax = AXES.index(axis) if isinstance(axis, str) else int(axis)
    u, v = [a for a in range(3) if a != ax]
    P = np.asarray(points, dtype=float)
    d = np.asarray(dev, dtype=float)
    hw = abs(float(half_width))
    inside = np.nonzero(np.abs(P[:, ax] - position) <= hw)[0]
    n_in = int(inside.size)
    if inside.size > max_points:
        inside = np.sort(np.random.default_rng(seed).choice(inside, max_points, replace=False))
    lines: list[np.ndarray] = []
    if nominal is not None:
        V = np.asarray(nominal.vertices, dtype=float)
        if V[:, ax].min() <= position <= V[:, ax].max():
            lines = [pl[:, [u, v]] for pl in mesh_section(V, nominal.faces, ax, position)]
    nom_pts = np.zeros((0, 2))
    if nominal_points is not None:
        Q = np.asarray(nominal_points, dtype=float)
        sel = np.nonzero(np.abs(Q[:, ax] - position) <= hw)[0]
        if sel.size > max_points:
            sel = np.random.default_rng(seed + 1).choice(sel, max_points, replace=False)
        nom_pts = Q[sel][:, [u, v]]
    m2 = P[inside][:, [u, v]]
    foot, normal = outline_feet(m2, d[inside], lines)
    return {
        "foot": foot,
        "normal": normal,
        "axis": AXES[ax],
        "position": float(position),
        "u": AXES[u],
        "v": AXES[v],
        "nominal": lines,
        "nominal_points": nom_pts,
        "measured": m2,
        "deviation": d[inside],
        "n_in_slab": n_in,
        "half_width": hw,
    }


def outline_feet(points: Any, dev: Any, lines: list[np.ndarray], chunk: int = 512) -> tuple[np.ndarray, np.ndarray]:
    """For 2-D ``points`` (n, 2) with deviations ``dev`` (n,): the closest point on the
    polylines ``lines`` (each (k, 2)) and the unit normal of that segment, turned so that
    a positive deviation lies along it (the side the point is on, times the deviation's
    sign). Both (0, 2) without lines. Chunked: n × segments distances at a time."""
    X = np.asarray(points, dtype=float).reshape(-1, 2)
    segs = [np.stack([pl[:-1], pl[1:]], axis=1) for pl in lines if len(pl) >= 2]
    if not segs or not len(X):
        return np.zeros((0, 2)), np.zeros((0, 2))
    S = np.concatenate(segs)  # (m, 2 ends, 2)
    a, t = S[:, 0], S[:, 1] - S[:, 0]
    tt = np.maximum(np.einsum("ij,ij->i", t, t), 1e-300)
    foot, tang = np.empty_like(X), np.empty_like(X)
    for i in range(0, len(X), chunk):
        x = X[i : i + chunk]
        s = np.clip(np.einsum("nmj,mj->nm", x[:, None, :] - a[None], t) / tt, 0.0, 1.0)
        q = a[None] + s[..., None] * t[None]
        k = np.argmin(np.einsum("nmj,nmj->nm", x[:, None, :] - q, x[:, None, :] - q), axis=1)
        foot[i : i + chunk] = q[np.arange(len(x)), k]
        tang[i : i + chunk] = t[k]
    nrm = np.column_stack([-tang[:, 1], tang[:, 0]])
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1), 1e-300)[:, None]
    side = np.sign(np.einsum("ij,ij->i", X - foot, nrm))
    sign = np.sign(np.nan_to_num(np.asarray(dev, dtype=float)))
    turn = np.where(side == 0, 1.0, side) * np.where(sign == 0, 1.0, sign)
    return foot, nrm * turn[:, None]


def deviation_field(cloud: Any) -> np.ndarray:
    """The field ``deviation`` (mm) of a cloud; InputError naming the cloud without it."""
    dev = (getattr(cloud, "fields", None) or {}).get("deviation")
    if dev is None:
        raise InputError(
            f"{getattr(cloud, 'name', 'cloud')}: no field 'deviation' "
            "(a cloud made by inspect.compare or inspect.deviations has it)"
        )
    return np.asarray(dev, dtype=float)
