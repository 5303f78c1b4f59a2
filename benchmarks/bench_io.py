"""Benchmark: reading a 10-million-point binary little-endian PLY.

Writes the file to a temporary folder (x, y, z float32 + uchar rgb by default; pass
``--double`` for float64 coordinates, ``--no-color`` for xyz only, ``-n`` for another
size), then times ``camcmm.io.read`` and, on the same file in the same run,
``open3d.io.read_point_cloud`` as the reference, and prints both and their ratio.

    .venv/bin/python benchmarks/bench_io.py [-n 10000000] [--double] [--no-color] [--repeat 3]

Each reader's best of ``--repeat`` runs is reported (the first run also pays for the
page cache warming up, which both readers share as the file was just written).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def make_ply(path: Path, n: int, double: bool, color: bool) -> None:
    ftype, fname = (np.float64, "double") if double else (np.float32, "float")
    dtype = [
        ("x", "<" + np.dtype(ftype).str[1:]),
        ("y", "<" + np.dtype(ftype).str[1:]),
        ("z", "<" + np.dtype(ftype).str[1:]),
    ]
    if color:
        dtype += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    rng = np.random.default_rng(0)
    rec = np.empty(n, dtype)
    for c in "xyz":
        rec[c] = rng.uniform(-500.0, 500.0, n)
    if color:
        for c in ("red", "green", "blue"):
            rec[c] = rng.integers(0, 256, n, dtype=np.uint8)
    header = ["ply", "format binary_little_endian 1.0", "comment unit mm", f"element vertex {n}"]
    header += [f"property {fname} {c}" for c in "xyz"]
    if color:
        header += [f"property uchar {c}" for c in ("red", "green", "blue")]
    header.append("end_header")
    with open(path, "wb") as fh:
        fh.write(("\n".join(header) + "\n").encode("ascii"))
        rec.tofile(fh)


def best_of(fn, repeat: int) -> tuple[float, object]:
    best, result = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=10_000_000, help="number of points (default 10 million)")
    ap.add_argument("--double", action="store_true", help="float64 coordinates instead of float32")
    ap.add_argument("--no-color", action="store_true", help="x, y, z only")
    ap.add_argument("--repeat", type=int, default=3, help="runs per reader; the best is reported")
    args = ap.parse_args()

    import open3d as o3d

    import camcmm.io

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.ply"
        t0 = time.perf_counter()
        make_ply(path, args.n, args.double, not args.no_color)
        size = path.stat().st_size
        print(
            f"file: {args.n:,} points, {'float64' if args.double else 'float32'} xyz"
            f"{'' if args.no_color else ' + uchar rgb'}, {size / 1e6:.0f} MB "
            f"(written in {time.perf_counter() - t0:.1f} s)"
        )

        t_ours, cloud = best_of(lambda: camcmm.io.read(path), args.repeat)
        t_o3d, ref = best_of(lambda: o3d.io.read_point_cloud(str(path)), args.repeat)

        ref_pts = np.asarray(ref.points)
        assert cloud.n_points == len(ref_pts) == args.n, (cloud.n_points, len(ref_pts))
        assert np.array_equal(cloud.points, ref_pts), "camcmm and Open3D read different coordinates"
        if not args.no_color:
            assert np.array_equal(cloud.colors, np.round(np.asarray(ref.colors) * 255).astype(np.uint8))

        print(f"camcmm.io.read:             {t_ours:6.2f} s  ({args.n / t_ours / 1e6:5.1f} M points/s)")
        print(f"open3d.io.read_point_cloud: {t_o3d:6.2f} s  ({args.n / t_o3d / 1e6:5.1f} M points/s)")
        print(f"ratio camcmm / Open3D:      {t_ours / t_o3d:6.2f}")


if __name__ == "__main__":
    main()
