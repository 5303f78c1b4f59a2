"""Uncertainty of the characteristics (gdt/uncertainty.py): noise on the points moves the
values by what u predicts.

Coverage: over 200 simulated parts (small clouds, Gaussian noise along the surfaces'
normals) the interval value ± 2u holds the true value in 88–99 % of them — the binomial
limits of 95 % over 200 trials (σ = 3 %, so ±2σ ≈ 89–100 %; 0.99 cuts off an interval
that is much too wide). Checked for the position of an axis in A|B|C (covariance of the
least-squares fits of the bore and of the three datum planes) and for a diameter.
The Monte Carlo u of a minimum-zone value (flatness) is checked against the spread of
the value over 12 simulated parts (a factor of 2 either way: both are estimates of a
standard deviation from 12 and 30 samples, and the Monte Carlo adds its noise to points
that already carry it)."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm_plugins.fitting.api import fit
from camcmm_plugins.gdt import features
from camcmm_plugins.gdt.characteristics import evaluate_characteristic
from camcmm_plugins.gdt.datums import datum_frame
from camcmm_plugins.gdt.model import Associated
from camcmm_plugins.gdt.plan import parse_plan

BOTTOM, TOP = np.array([0.02, -0.01]), np.array([0.05, 0.03])
TRUE_POSITION = 2 * float(np.hypot(*TOP))
SIGMA = 0.005

DOC = {
    "features": {
        "A": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, -1], "association": "ls"},
        "B": {"type": "plane", "point": [0, 0, 0], "normal": [0, -1, 0], "association": "ls"},
        "C": {"type": "plane", "point": [0, 0, 0], "normal": [-1, 0, 0], "association": "ls"},
        "H": {"type": "cylinder", "point": [20, 30, 0], "axis": [0, 0, 1], "diameter": 10, "length": 30},
        "P": {"type": "plane", "point": [0, 0, 30], "normal": [0, 0, 1]},
    },
    "datums": {"A": "A", "B": "B", "C": "C"},
    "characteristics": [
        {"id": "pos", "type": "position", "feature": "H", "datums": ["A", "B", "C"], "tolerance": 0.2},
        {"id": "dia", "type": "diameter", "feature": "H", "lower": -0.05, "upper": 0.05},
        {"id": "flat", "type": "flatness", "feature": "P", "tolerance": 0.1},
    ],
}
PLAN = parse_plan(DOC, "plan.yaml")


def _face(rng, origin, u, v, n: int) -> np.ndarray:
    s = rng.random((n, 2))
    return np.asarray(origin, float) + np.outer(s[:, 0], u) + np.outer(s[:, 1], v)


def _part(rng) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """A, B, C faces and the bore (axis from BOTTOM at z = 0 to TOP at z = 30, Ø10,
    4 rings of 12 normal to the axis), noise SIGMA along the normals."""
    faces = {
        "A": (_face(rng, [0, 0, 0], [60, 0, 0], [0, 50, 0], 30), [0, 0, 1]),
        "B": (_face(rng, [0, 0, 1], [60, 0, 0], [0, 0, 28], 20), [0, 1, 0]),
        "C": (_face(rng, [0, 1, 1], [0, 48, 0], [0, 0, 28], 20), [1, 0, 0]),
    }
    b, t = np.array([20 + BOTTOM[0], 30 + BOTTOM[1], 0.0]), np.array([20 + TOP[0], 30 + TOP[1], 30.0])
    a = (t - b) / np.linalg.norm(t - b)
    e1 = np.cross(a, [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    th = 2 * np.pi * (np.arange(12) / 12 + rng.random())
    radial = np.outer(np.cos(th), e1) + np.outer(np.sin(th), e2)
    bore = np.vstack([b + (t - b) * f + 5 * radial for f in (0.05, 0.35, 0.65, 0.95)])
    bore_n = np.vstack([radial] * 4)
    pts, sets, start = [], {}, 0
    for fid, (p, n) in faces.items():
        pts.append(p + rng.normal(0, SIGMA, (len(p), 1)) * np.asarray(n, float))
        sets[fid] = np.arange(start, start + len(p))
        start += len(p)
    pts.append(bore + rng.normal(0, SIGMA, (len(bore), 1)) * bore_n)
    sets["H"] = np.arange(start, start + len(bore))
    return np.vstack(pts), sets


def _cylinder_ls(x: np.ndarray, p0: np.ndarray, a0: np.ndarray, r0: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares cylinder by Gauss-Newton from the nominal (shift and tilt normal to
    the axis, radius): the fitting plugin's own fit is checked in tests/fitting; from a
    known start this keeps 200 parts fast (no start-value search)."""
    p, a, r = p0.astype(float), a0.astype(float), r0
    for _ in range(8):
        b = np.linalg.svd(a[None, :])[2][1:]

        def res(d: np.ndarray, p=p, a=a, r=r, b=b) -> np.ndarray:
            params = {
                "point": p + d[0] * b[0] + d[1] * b[1],
                "axis": a + d[2] * b[0] + d[3] * b[1],
                "diameter": 2 * (r + d[4]),
            }
            return features.surface_distance(x, "cylinder", params)

        h = 1e-7
        jac = np.column_stack([(res(h * e) - res(-h * e)) / (2 * h) for e in np.eye(5)])
        d = -np.linalg.lstsq(jac, res(np.zeros(5)), rcond=None)[0]
        p, a, r = p + d[0] * b[0] + d[1] * b[1], a + d[2] * b[0] + d[3] * b[1], r + d[4]
        a = a / np.linalg.norm(a)
    return p, a, r


def _associate(pts: np.ndarray, sets: dict[str, np.ndarray]) -> dict[str, Associated]:
    """Least-squares elements (what features.associate gives, without the plugin host's
    per-call cost), with features.ls_covariance."""
    out = {}
    for fid, idx in sets.items():
        x = pts[idx]
        spec = PLAN.features[fid]
        if spec.type == "plane":
            r = fit("plane", x)
            n = r.normal if r.normal @ spec.nominal["normal"] > 0 else -r.normal
            params = {"point": r.point, "normal": n}
        else:
            p, a, rad = _cylinder_ls(x, spec.nominal["point"], spec.nominal["axis"], 5.0)
            h = (x - p) @ a
            params = {"point": p + h.min() * a, "axis": a, "diameter": 2 * rad, "length": float(np.ptp(h))}
        cov, names = features.ls_covariance(x, spec.type, params)
        res = features.surface_distance(x, spec.type, params)
        out[fid] = Associated(fid, spec.type, "ls", idx, params, res, {}, cov, names)
    return out


def _evaluate(pts, assoc, cid: str):
    spec = next(c for c in PLAN.characteristics if c.id == cid)
    return evaluate_characteristic(spec, PLAN, pts, assoc, lambda labels: datum_frame(PLAN, assoc, labels))


def test_coverage_of_position_and_diameter_over_200_parts():
    rng = np.random.default_rng(2027)
    hits = {"pos": 0, "dia": 0}
    values: dict[str, list[float]] = {"pos": [], "dia": []}
    us: dict[str, list[float]] = {"pos": [], "dia": []}
    n = 200
    for _ in range(n):
        pts, sets = _part(rng)
        sets.pop("P", None)
        assoc = _associate(pts, sets)
        for cid, truth in (("pos", TRUE_POSITION), ("dia", 10.0)):
            r = _evaluate(pts, assoc, cid)
            assert r.u_method == "covariance of the least-squares fit"
            values[cid].append(r.value)
            us[cid].append(r.u)
            hits[cid] += abs(r.value - truth) <= 2 * r.u
    for cid in hits:
        assert 0.88 * n <= hits[cid] <= 0.99 * n, (cid, hits[cid])
        # and u is the spread the values show (the parts' std, ±25 %)
        ratio = np.std(values[cid], ddof=1) / np.mean(us[cid])
        assert 0.8 < ratio < 1.25, (cid, ratio)


def test_monte_carlo_u_of_flatness_matches_the_spread_over_parts():
    """A plane with 60 points, noise 5 µm: flatness over 12 parts vs its Monte Carlo u."""
    rng = np.random.default_rng(7)
    vals, us = [], []
    for _ in range(12):
        p = _face(rng, [0, 0, 30], [60, 0, 0], [0, 50, 0], 60)
        p[:, 2] += rng.normal(0, SIGMA, len(p))
        assoc = {"P": features.associate(p, np.arange(len(p)), PLAN.features["P"])}
        r = _evaluate(p, assoc, "flat")
        assert r.u_method.startswith("monte-carlo")
        vals.append(r.value)
        us.append(r.u)
    ratio = np.std(vals, ddof=1) / np.mean(us)
    assert 0.5 < ratio < 2.0, ratio
    assert np.mean(vals) == pytest.approx(SIGMA * 4.5, rel=0.3)  # the range of 60 normal samples ≈ 4.6σ


def test_tangent_datum_enters_by_monte_carlo():
    """A|B|C with B the ISO 5459 tangent plane of 300 noisy points (σ = 5 µm; A and C
    exact): the position of a sphere 0.05 mm off in y moves with B's outer extreme (and
    its tilt). Its u is the Monte Carlo of the datum frame, compared with the spread of
    the value over 40 parts whose B carries fresh noise — overstated by ~1.3 for an
    extreme (uncertainty.py), and not the ~20× smaller covariance of a least-squares
    plane."""
    rng = np.random.default_rng(5)
    b_exact = _face(rng, [0, 0, 1], [60, 0, 0], [0, 0, 28], 300)
    faces = {
        "A": _face(rng, [0, 0, 0], [60, 0, 0], [0, 50, 0], 40),
        "B": b_exact + np.outer(rng.normal(0, SIGMA, 300), [0, 1, 0]),
        "C": _face(rng, [0, 1, 1], [0, 48, 0], [0, 0, 28], 40),
    }
    k = np.arange(100) + 0.5
    phi, th = np.arccos(1 - 2 * k / 100), np.pi * (1 + 5**0.5) * k
    u = np.c_[np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)]
    faces["S"] = np.array([30, 20.05, 50]) + 10 * u
    doc = {
        "features": {
            **{f: {k2: v for k2, v in DOC["features"][f].items() if k2 != "association"} for f in "ABC"},
            "S": {"type": "sphere", "centre": [30, 20, 50], "diameter": 20},
        },
        "datums": {"A": "A", "B": "B", "C": "C"},
        "characteristics": [
            {"id": "pos", "type": "position", "feature": "S", "datums": ["A", "B", "C"], "tolerance": 1}
        ],
    }
    plan = parse_plan(doc, "plan.yaml")
    pts = np.vstack(list(faces.values()))
    ends = np.cumsum([0] + [len(v) for v in faces.values()])
    sets = {f: np.arange(ends[i], ends[i + 1]) for i, f in enumerate(faces)}
    assoc = {f: features.associate(pts, sets[f], plan.features[f]) for f in faces}
    assert assoc["B"].association == "tangent"
    spec = plan.characteristics[0]
    r = evaluate_characteristic(spec, plan, pts, assoc, lambda labels: datum_frame(plan, assoc, labels))
    assert "monte-carlo of the datum frame" in r.u_method
    values = []
    for _ in range(40):
        p = pts.copy()
        p[sets["B"]] = b_exact + np.outer(rng.normal(0, SIGMA, 300), [0, 1, 0])
        a2 = {**assoc, "B": features.associate(p, sets["B"], plan.features["B"])}
        t = datum_frame(plan, a2, ("A", "B", "C")).transform  # the value alone: 2·|c − c₀| in A|B|C
        values.append(2 * np.linalg.norm(t[:3, :3] @ assoc["S"].params["centre"] + t[:3, 3] - [30, 20, 50]))
    ratio = r.details["u_parts"]["datums monte-carlo"] / np.std(values, ddof=1)
    assert 0.8 < ratio < 2.0, ratio
