"""Benchmark: a big cloud out of core — store, first paint, view selection, Dask comparison.

In one run:

1. ``--n`` points (default 10^8) near a sphere of radius 50 mm (0.05 mm noise, random
   order) are written to disk as a binary float32 PLY (12 bytes a point: 1.2 GB for 10^8),
   in pieces, never whole in memory; in a temporary folder (``--tmp``) removed afterwards.
2. ``camcmm.bigcloud.build_store`` indexes it out of core: time, peak memory.
3. First paint: ``LodIndex.open`` + ``uniform(10^6)`` from the store (memory-mapped; the
   page cache is warm from the build, as right after an import); one ``select()`` of a
   zoomed-in view (budget 10^6).
4. ``compare_store`` against a 99 224-triangle mesh of the sphere on a local Dask cluster
   (``--workers`` processes of one thread; ``--scheduler`` for another cluster): time and
   peak memory of this process and its workers together.
5. Cross-check on ``--check`` points (default 2·10^6, the first of the same file): the
   same comparison on Dask and in memory (camcmm.io.read + MeshDistance + the inspection
   plugin's ``deviation_stats``): which statistics agree to the last digit, the largest
   relative difference of the others, and the time ratio Dask / in memory.

Memory is sampled every 0.1 s over this process and its children: ``rss`` (all resident
pages, including the memory-mapped store's file pages, which the kernel may drop at any
time) and ``anon`` (RssAnon: the memory the processes really hold).

    .venv/bin/python benchmarks/bench_bigcloud.py [--n 100000000] [--workers 2] [--chunk 2000000]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import open3d as o3d
import psutil

from camcmm.bigcloud import LodIndex, build_store
from camcmm.bigcloud.compare import compare_store
from camcmm.io import read
from camcmm.meshdistance import MeshDistance
from camcmm_plugins.inspection.stats import deviation_stats

R = 50.0


class Peak:
    """Peak resident memory (rss and RssAnon, bytes) of this process and its children."""

    def __init__(self):
        self.rss = self.anon = 0
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True)

    @staticmethod
    def _anon(pid: int) -> int:
        try:
            for line in open(f"/proc/{pid}/status"):
                if line.startswith("RssAnon:"):
                    return int(line.split()[1]) * 1024
        except OSError:
            pass
        return 0

    def _run(self):
        me = psutil.Process()
        while not self._stop.is_set():
            procs = [me, *me.children(recursive=True)]
            rss = anon = 0
            for p in procs:
                try:
                    rss += p.memory_info().rss
                    anon += self._anon(p.pid)
                except psutil.Error:
                    pass
            self.rss, self.anon = max(self.rss, rss), max(self.anon, anon)
            self._stop.wait(0.1)

    def __enter__(self):
        self._t.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join()


def gb(x: float) -> str:
    return f"{x / 1e9:.2f} GB"


def write_cloud(path: Path, n: int, seed: int = 0, piece: int = 5_000_000) -> None:
    """n points near the sphere, float32 binary PLY, written piece by piece."""
    rng = np.random.default_rng(seed)
    with open(path, "wb") as fh:
        fh.write(
            (
                "ply\nformat binary_little_endian 1.0\ncomment unit mm\n"
                f"element vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
            ).encode()
        )
        for s in range(0, n, piece):
            m = min(piece, n - s)
            u = rng.normal(size=(m, 3))
            u *= ((R + rng.normal(0.0, 0.05, m)) / np.linalg.norm(u, axis=1))[:, None]
            fh.write(u.astype("<f4").tobytes())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=float, default=1e8)
    ap.add_argument("--check", type=float, default=2e6)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--chunk", type=int, default=2_000_000)
    ap.add_argument("--scheduler", default=None)
    ap.add_argument("--tmp", default=None, help="folder for the temporary files (default: the system's)")
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    a = ap.parse_args()
    n, n_check = int(a.n), int(a.check)
    print(f"load average at start: {os.getloadavg()}; {os.cpu_count()} cores")
    fig: dict = {"n": n, "workers": a.workers, "chunk": a.chunk, "load_start": os.getloadavg()}
    sph = o3d.geometry.TriangleMesh.create_sphere(radius=R, resolution=158)
    mesh = (np.asarray(sph.vertices), np.asarray(sph.triangles))
    print(f"nominal: sphere r = {R} mm, {len(mesh[1]):,} triangles")
    tmp = Path(tempfile.mkdtemp(prefix="bench_bigcloud_", dir=a.tmp))
    try:
        t = time.perf_counter()
        write_cloud(tmp / "cloud.ply", n)
        size = (tmp / "cloud.ply").stat().st_size
        print(f"wrote {n:,} points, {gb(size)} float32 PLY in {time.perf_counter() - t:.1f} s")

        with Peak() as pk:
            t = time.perf_counter()
            meta = build_store(tmp / "cloud.ply", tmp / "store", chunk=a.chunk)
            t_build = time.perf_counter() - t
        print(
            f"index build: {t_build:.1f} s ({n / t_build / 1e6:.2f} M points/s), {meta['n_cells']:,} cells, "
            f"level {meta['grid']['level']}; peak rss {gb(pk.rss)}, anon {gb(pk.anon)}"
        )
        fig.update(build_s=t_build, build_rss=pk.rss, build_anon=pk.anon, n_cells=meta["n_cells"])

        t = time.perf_counter()
        idx = LodIndex.open(tmp / "store")
        first = idx.uniform(1_000_000)
        t_first = time.perf_counter() - t
        cam = {
            "position": [30.0, 20.0, 90.0],
            "focal_point": [20.0, 15.0, 45.0],
            "view_up": [0, 1, 0],
            "view_angle": 30,
        }
        t = time.perf_counter()
        pts, rows = idx.select(cam, (1600, 1000), 1_000_000)
        t_sel = time.perf_counter() - t
        t = time.perf_counter()
        idx.select({**cam, "position": [0.0, 0.0, 400.0], "focal_point": [0, 0, 0]}, (1600, 1000), 1_000_000)
        t_sel_all = time.perf_counter() - t
        print(
            f"first paint (open + uniform(1e6)): {t_first:.3f} s ({len(first):,} points); "
            f"select zoomed in: {t_sel:.3f} s ({len(rows):,} points); whole view: {t_sel_all:.3f} s"
        )
        fig.update(first_paint_s=t_first, select_zoom_s=t_sel, select_zoom_points=len(rows), select_all_s=t_sel_all)
        del idx, first, pts, rows

        with Peak() as pk:
            r = compare_store(
                tmp / "store", mesh, scheduler=a.scheduler, workers=None if a.scheduler else a.workers, chunk=a.chunk
            )
        s = r["statistics"]
        print(
            f"Dask comparison of {n:,} points ({r['n_chunks']} chunks on {r['scheduler']}): "
            f"{r['seconds']['total']:.1f} s (cluster start {r['seconds']['cluster_start']:.1f} s, distances "
            f"{r['seconds']['distances']:.1f} s, exact percentile pass {r['seconds']['percentile_pass']:.1f} s), "
            f"{n / r['seconds']['distances'] / 1e6:.2f} M points/s; peak rss {gb(pk.rss)}, anon {gb(pk.anon)}"
        )
        print(f"  mean {s['mean']:.6g} std {s['std']:.6g} min {s['min']:.6g} max {s['max']:.6g} mm; exact {r['exact']}")
        fig.update(compare=r["seconds"], compare_rss=pk.rss, compare_anon=pk.anon, stats=s, exact=r["exact"])
        shutil.rmtree(tmp / "store")

        # -- cross-check on the first n_check points, in memory and on Dask
        n_check = min(n_check, n)
        with open(tmp / "cloud.ply", "rb") as fh:
            head = b""
            while not head.endswith(b"end_header\n"):
                head += fh.readline()
            body = fh.read(12 * n_check)
        (tmp / "small.ply").write_bytes(head.replace(f"vertex {n}".encode(), f"vertex {n_check}".encode()) + body)
        del body
        build_store(tmp / "small.ply", tmp / "small", chunk=a.chunk)
        t = time.perf_counter()
        cloud = read(tmp / "small.ply")
        dev = MeshDistance(mesh).signed_distance(cloud.points)
        ref = deviation_stats(dev)
        t_mem = time.perf_counter() - t
        rc = compare_store(
            tmp / "small", mesh, scheduler=a.scheduler, workers=None if a.scheduler else a.workers, chunk=a.chunk
        )
        sc = rc["statistics"]
        same = [k for k in ref if sc[k] == ref[k]]
        diff = {k: abs(sc[k] - ref[k]) / abs(ref[k]) for k in ref if k not in same and k != "interval95"}
        print(
            f"cross-check on {n_check:,} points: in memory {t_mem:.2f} s, Dask {rc['seconds']['total']:.2f} s "
            f"(ratio {rc['seconds']['total'] / t_mem:.2f}; distances alone {rc['seconds']['distances']:.2f} s)"
        )
        print(f"  equal to the last digit: {', '.join(same)}")
        print(f"  others, relative difference: {json.dumps({k: f'{v:.1e}' for k, v in diff.items()})}")
        fig.update(check_n=n_check, check_mem_s=t_mem, check_dask=rc["seconds"], check_same=same, check_diff=diff)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    fig["load_end"] = os.getloadavg()
    print(f"load average at end: {fig['load_end']}")
    if a.json:
        Path(a.json).write_text(json.dumps(fig, indent=2, default=str))


if __name__ == "__main__":
    main()
