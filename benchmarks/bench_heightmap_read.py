"""Benchmark: reading a 4 M-point height map (issue 17's budget: <= 1 s).

A 2048 x 2048 map (a CSI-like relief in mm with 1 % invalid points) is written as X3P,
binary SDF (camcmm's own writers) and Gwyddion GWY (SurfaceTopography's writer: a
vendor format camcmm reads through SurfaceTopography). Each file is read with
``camcmm.api.read`` and with SurfaceTopography's ``read_topography(...).heights()`` in
the same process (SurfaceTopography imported before any timing), best of ``--repeat``;
printed: seconds, points per second, the ratio camcmm / SurfaceTopography, whether the
heights agree (max |difference| in mm) and whether camcmm is within the 1 s budget.

    .venv/bin/python benchmarks/bench_heightmap_read.py [--side 2048] [--repeat 3]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from camcmm import api


def _best(fn, repeat: int) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def _st_mm(path: Path) -> np.ndarray:
    from SurfaceTopography import read_topography

    t = read_topography(str(path))
    return np.ma.filled(t.heights(), np.nan).T * api.to_mm_factor(t.unit)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--side", type=int, default=2048, help="points per side (2048: 4.2 M points)")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    import SurfaceTopography  # noqa: F401  (its import, ~1-8 s, is not part of a read)
    from SurfaceTopography import Topography

    n = args.side
    rng = np.random.default_rng(0)
    y, x = np.mgrid[0:n, 0:n] * 0.5e-3  # 0.5 um steps, mm
    h = 2e-3 * np.sin(x * 9) * np.cos(y * 7) + 1e-5 * rng.normal(size=x.shape)
    h[rng.random(h.shape) < 0.01] = np.nan
    m = api.HeightMap(h, 0.5e-3, 0.5e-3, name="bench")
    print(f"height map {n} x {n} = {n * n / 1e6:.2f} M points, {np.isnan(h).mean():.1%} invalid")
    with tempfile.TemporaryDirectory() as tmp:
        files = {}
        for ext in (".x3p", ".sdf"):
            files[ext] = Path(tmp) / f"bench{ext}"
            t = time.perf_counter()
            api.write(m, files[ext])
            print(f"  wrote {ext} in {time.perf_counter() - t:.2f} s ({files[ext].stat().st_size / 1e6:.1f} MB)")
        files[".gwy"] = Path(tmp) / "bench.gwy"
        Topography(np.ma.masked_invalid(h.T), (n * 0.5e-3, n * 0.5e-3), unit="mm").to_gwy(str(files[".gwy"]))
        print(f"{'file':6} {'camcmm s':>9} {'M pts/s':>8} {'ST s':>7} {'ratio':>6} {'max |d| mm':>11}  budget")
        for ext, path in files.items():
            t_ours, ours = _best(lambda p=path: api.read(p), args.repeat)
            t_st, ref = _best(lambda p=path: _st_mm(p), args.repeat)
            d = float(np.nanmax(np.abs(ours.heights - ref))) if np.array_equal(np.isnan(ref), ~ours.valid) else np.inf
            ok = "ok" if t_ours <= 1.0 else "OVER 1 s"
            print(f"{ext:6} {t_ours:9.3f} {n * n / t_ours / 1e6:8.1f} {t_st:7.3f} {t_ours / t_st:6.2f} {d:11.2e}  {ok}")


if __name__ == "__main__":
    main()
