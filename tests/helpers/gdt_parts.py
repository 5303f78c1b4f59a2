"""A synthetic part for the GD&T tests (issue 27): a block with datum faces, a bore whose
axis is offset by chosen vectors, a tilted side, a bowed bottom and a boss, sampled as a
measured cloud with optional noise and a rigid pose (a part delivered in a scanner's frame).

The block is 80 × 60 × 30 mm, plan coordinates: A the bottom (z = 0), B the side y = 0,
C the side x = 0, D the side x = 80 (tilted by ``tilt_d``: x = 80 + tilt_d·z), T the top
(z = 30), H1 a bore Ø10 through the block at (20, 30) whose axis meets z = 0 at
(20, 30) + ``bore_bottom`` and z = 30 at (20, 30) + ``bore_top``, P1 a boss Ø16 at
(60, 30) standing 10 mm on T, P1T its top (z = 40).

Every surface is sampled only ``margin`` (1 mm) inside its edges and the faces around the
bore and the boss keep 1 mm clear of them (an edge break), so a band of up to 0.5 mm about
one nominal surface never takes a neighbour's points: selection is not what these parts
test. Points are uniform by area (``density`` per mm², at least ``n_min`` a surface),
seeded; ``noise`` (mm, standard deviation) is added along each surface's normal.

Analytic answers (noise-free):
- position of H1 to A|B|C = 2·max(|bore_bottom|, |bore_top|) (the axis within the
  block's 30 mm); for the defaults 2·|(0.05, 0.03)| = 0.116619 mm;
- perpendicularity of H1 to A = |bore_top − bore_bottom| = 0.05 mm for the defaults: the
  axis' projection on A is a segment that long, so the smallest cylinder perpendicular to
  A holding the axis (a diametral zone) has that diameter;
- flatness of A = ``ripple_a`` (every second point of A raised by it into the material,
  the four corners at both levels), minimum zone: no tilted zone is narrower, and the
  datum A (outer tangent plane) stays z = 0; ``bow_a`` bends A instead
  (z = 4·bow_a·(x/80)(1 − x/80); its minimum zone depends on the sampled x);
- perpendicularity of D to A = tilt_d · 28 mm (the sampled extent z 1 … 29: every face's
  four corners are among its points);
- diameter of H1 = ``bore_diameter``, of P1 = ``boss_diameter``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

L, W, H = 80.0, 60.0, 30.0
BORE_XY = np.array([20.0, 30.0])
BOSS_XY = np.array([60.0, 30.0])
BOSS_H = 10.0
#: The issue's bore: axis offset (0.02, −0.01) mm at the bottom face, (0.05, 0.03) at the top.
BORE_BOTTOM = (0.02, -0.01)
BORE_TOP = (0.05, 0.03)
#: 2·max |offset| for the defaults (mm).
POSITION_H1 = 2 * float(np.hypot(*BORE_TOP))


def rotation(axis, angle_deg: float) -> np.ndarray:
    """The 3×3 rotation by ``angle_deg`` about ``axis`` (Rodrigues)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    t = np.radians(angle_deg)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


def pose(axis=(1.0, 2.0, 3.0), angle_deg: float = 30.0, shift=(300.0, -400.0, 0.0)) -> np.ndarray:
    """A rigid 4×4 transform plan -> delivered frame: rotation about ``axis`` then ``shift`` (mm)."""
    T = np.eye(4)
    T[:3, :3] = rotation(axis, angle_deg)
    T[:3, 3] = shift
    return T


#: The scanner's frame of the tests: 30° about a skew axis, 500 mm away.
SCANNER_POSE = pose()


@dataclass
class Part:
    """A sampled part: ``points`` (N, 3) in the delivered frame, ``surface`` (N,) index into
    ``names``, ``pose`` (4, 4) plan -> delivered (identity when not posed)."""

    points: np.ndarray
    surface: np.ndarray
    names: tuple[str, ...]
    pose: np.ndarray

    def of(self, name: str) -> np.ndarray:
        """The points of one surface (delivered frame)."""
        return self.points[self.surface == self.names.index(name)]

    def plan_points(self) -> np.ndarray:
        """All points back in plan coordinates."""
        R, t = self.pose[:3, :3], self.pose[:3, 3]
        return (self.points - t) @ R

    def write(self, path: str | Path) -> Path:
        """The cloud as a .xyz text file (full precision)."""
        p = Path(path)
        np.savetxt(p, self.points, fmt="%.10f")
        return p


def _count(area: float, density: float, n_min: int) -> int:
    return max(n_min, int(round(area * density)))


def _rect(rng, n, lo, hi):
    return lo + (np.asarray(hi) - np.asarray(lo)) * rng.random((n, 2))


def _outside(uv: np.ndarray, holes: list[tuple[np.ndarray, float]]) -> np.ndarray:
    keep = np.ones(len(uv), bool)
    for c, r in holes:
        keep &= np.hypot(*(uv - c).T) > r
    return keep


def _face(rng, n, lo, hi, holes=()):
    """n points on a rectangle [lo, hi] (2-D) outside the circular ``holes``: its four
    corners (so the sampled extent is exactly the rectangle), the rest uniform."""
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [lo[0], hi[1]], [hi[0], hi[1]]], float)
    out = corners[_outside(corners, list(holes))]
    while len(out) < n:
        uv = _rect(rng, 2 * n, lo, hi)
        out = np.vstack([out, uv[_outside(uv, list(holes))]])
    return out[:n]


def _cylinder(rng, n, base, top, radius, outward_sign=1.0):
    """n points on the cylinder of ``radius`` whose axis runs from ``base`` to ``top``
    (3-D points), with the normal pointing away from the axis × ``outward_sign``."""
    base, top = np.asarray(base, float), np.asarray(top, float)
    a = top - base
    length = np.linalg.norm(a)
    a = a / length
    e1 = np.cross(a, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    s = rng.random(n) * length
    u = rng.random(n) * 2 * np.pi
    radial = np.cos(u)[:, None] * e1 + np.sin(u)[:, None] * e2
    return base + s[:, None] * a + radius * radial, outward_sign * radial


def block(
    density: float = 0.15,
    noise: float = 0.0,
    pose: np.ndarray | None = None,
    bore_bottom=BORE_BOTTOM,
    bore_top=BORE_TOP,
    bore_diameter: float = 10.0,
    boss_diameter: float = 16.0,
    tilt_d: float = 0.0,
    bow_a: float = 0.0,
    ripple_a: float = 0.0,
    margin: float = 1.0,
    n_min: int = 120,
    seed: int = 0,
) -> Part:
    """The sampled block (see the module docstring); ``pose`` plan -> delivered frame."""
    rng = np.random.default_rng(seed)
    m = margin
    r_bore, r_boss = bore_diameter / 2, boss_diameter / 2
    bb = BORE_XY + np.asarray(bore_bottom, float)
    bt = BORE_XY + np.asarray(bore_top, float)
    surfaces: list[tuple[str, np.ndarray, np.ndarray]] = []

    def add(name, pts, normals):
        surfaces.append((name, pts, np.broadcast_to(normals, pts.shape).copy()))

    # A: bottom, z = 4 bow (x/L)(1 - x/L) (+ ripple on every second point, the corners
    # at both levels); the bore's mouth kept clear
    uv = _face(rng, _count(L * W, density, n_min), [m, m], [L - m, W - m], [(bb, r_bore + m)])
    z = 4 * bow_a * (uv[:, 0] / L) * (1 - uv[:, 0] / L)
    if ripple_a:  # the corners (first four) twice: raised copies first, then at level 0
        uv, z = np.vstack([uv[:4], uv]), np.r_[z[:4], z]
        i = np.arange(len(z))
        z = z + ripple_a * ((i < 4) | ((i >= 8) & (i % 2 == 1)))
    add("A", np.c_[uv, z], [0.0, 0.0, -1.0])
    # T: top, clear of the bore and of the boss
    uv = _face(rng, _count(L * W, density, n_min), [m, m], [L - m, W - m], [(bt, r_bore + m), (BOSS_XY, r_boss + m)])
    add("T", np.c_[uv, np.full(len(uv), H)], [0.0, 0.0, 1.0])
    # B: y = 0 (x, z)
    uv = _face(rng, _count(L * H, density, n_min), [m, m], [L - m, H - m])
    add("B", np.c_[uv[:, 0], np.zeros(len(uv)), uv[:, 1]], [0.0, -1.0, 0.0])
    # C: x = 0 (y, z)
    uv = _face(rng, _count(W * H, density, n_min), [m, m], [W - m, H - m])
    add("C", np.c_[np.zeros(len(uv)), uv], [-1.0, 0.0, 0.0])
    # D: x = 80 + tilt_d z (y, z)
    uv = _face(rng, _count(W * H, density, n_min), [m, m], [W - m, H - m])
    nd = np.array([1.0, 0.0, -tilt_d]) / np.hypot(1.0, tilt_d)
    add("D", np.c_[L + tilt_d * uv[:, 1], uv], nd)
    # E: y = 60 (x, z)
    uv = _face(rng, _count(L * H, density, n_min), [m, m], [L - m, H - m])
    add("E", np.c_[uv[:, 0], np.full(len(uv), W), uv[:, 1]], [0.0, 1.0, 0.0])
    # H1: the bore, its axis through (bb, 0) and (bt, H), sampled from z = m to H - m;
    # material outside, so the outward normal points to the axis
    axis = np.array([*(bt - bb), H]) / H
    p, nrm = _cylinder(
        rng,
        _count(np.pi * bore_diameter * H, density, n_min),
        [*bb, 0.0] + m * axis,
        [*bb, 0.0] + (H - m) * axis,
        r_bore,
        -1.0,
    )
    add("H1", p, nrm)
    # P1: the boss on T, z 30 + m .. 40 - m; P1T its top
    p, nrm = _cylinder(
        rng,
        _count(np.pi * boss_diameter * BOSS_H, density, n_min),
        [*BOSS_XY, H + m],
        [*BOSS_XY, H + BOSS_H - m],
        r_boss,
    )
    add("P1", p, nrm)
    uv = _face(rng, _count(4 * r_boss**2, density, n_min), BOSS_XY - r_boss, BOSS_XY + r_boss)
    uv = uv[np.hypot(*(uv - BOSS_XY).T) < r_boss - m]
    add("P1T", np.c_[uv, np.full(len(uv), H + BOSS_H)], [0.0, 0.0, 1.0])

    names = tuple(s[0] for s in surfaces)
    pts = np.vstack([s[1] for s in surfaces])
    nrm = np.vstack([s[2] for s in surfaces])
    surface = np.concatenate([np.full(len(s[1]), i) for i, s in enumerate(surfaces)])
    if noise:
        pts = pts + rng.normal(0.0, noise, len(pts))[:, None] * nrm
    T = np.eye(4) if pose is None else np.asarray(pose, float)
    pts = pts @ T[:3, :3].T + T[:3, 3]
    return Part(pts, surface, names, T)


# --------------------------------------------------------------------------- the plan
def plan_document(
    tolerance_position: float = 0.2,
    bore_diameter: float = 10.0,
    boss_diameter: float = 16.0,
    characteristics: list[dict[str, Any]] | None = None,
    **extra: Any,
) -> dict[str, Any]:
    """The plan of the block, as the YAML document of ``camcmm gdt evaluate`` (mm). Plane
    normals point out of the material (the side of + distances and of a datum's outer
    tangent plane); H1 is a bore (``internal``)."""
    doc: dict[str, Any] = {
        "unit": "mm",
        "band": 0.5,
        "features": {
            "A": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, -1], "box": [[0, 0, -1], [80, 60, 1]]},
            "B": {"type": "plane", "point": [0, 0, 0], "normal": [0, -1, 0], "box": [[0, -1, 0], [80, 1, 30]]},
            "C": {"type": "plane", "point": [0, 0, 0], "normal": [-1, 0, 0], "box": [[-1, 0, 0], [1, 60, 30]]},
            "D": {"type": "plane", "point": [80, 0, 0], "normal": [1, 0, 0], "box": [[79, 0, 0], [81, 60, 30]]},
            "T": {"type": "plane", "point": [0, 0, 30], "normal": [0, 0, 1], "box": [[0, 0, 29], [80, 60, 31]]},
            "H1": {
                "type": "cylinder",
                "point": [20, 30, 0],
                "axis": [0, 0, 1],
                "diameter": bore_diameter,
                "length": 30,
                "internal": True,
            },
            "P1": {
                "type": "cylinder",
                "point": [60, 30, 30],
                "axis": [0, 0, 1],
                "diameter": boss_diameter,
                "length": 10,
            },
        },
        "datums": {"A": "A", "B": "B", "C": "C"},
        "characteristics": characteristics
        if characteristics is not None
        else [
            {"id": "flat-A", "type": "flatness", "feature": "A", "tolerance": 0.05},
            {
                "id": "pos-H1",
                "type": "position",
                "feature": "H1",
                "datums": ["A", "B", "C"],
                "tolerance": tolerance_position,
            },
            {"id": "perp-H1", "type": "perpendicularity", "feature": "H1", "datums": ["A"], "tolerance": 0.1},
            {"id": "perp-D", "type": "perpendicularity", "feature": "D", "datums": ["A"], "tolerance": 0.05},
            {"id": "dia-H1", "type": "diameter", "feature": "H1", "lower": -0.02, "upper": 0.02},
            {"id": "dia-P1", "type": "diameter", "feature": "P1", "lower": -0.05, "upper": 0.05},
        ],
    }
    doc.update(extra)
    return doc


def plan_yaml(doc: dict[str, Any] | None = None) -> str:
    """The plan as YAML text (JSON is YAML; flow style keeps it one line a value)."""
    import yaml

    return yaml.safe_dump(doc if doc is not None else plan_document(), sort_keys=False, default_flow_style=None)


def write_case(folder: str | Path, part: Part | None = None, doc: dict[str, Any] | None = None) -> tuple[Path, Path]:
    """plan.yaml and part.xyz in ``folder``; returns their paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    plan = folder / "plan.yaml"
    plan.write_text(plan_yaml(doc), "utf-8")
    cloud = (part if part is not None else block()).write(folder / "part.xyz")
    return plan, cloud


def dumps(doc: dict[str, Any]) -> str:
    """A plan as JSON text (for a .json plan)."""
    return json.dumps(doc)
