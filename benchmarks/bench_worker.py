"""Benchmark: what running plugins in the worker process (camcmm.worker) costs the GUI.

In one run, against ``PluginHost.run`` in this process as the reference:

* the worker's start-up (a fresh interpreter reading the manifests), paid once per server
  and again only after a worker died;
* a small plugin run (a GUM budget of three rows): the added round trip per run once
  the worker is warm;
* ``cloud.downsample`` of an N-point cloud (default 1 000 000): the cloud pickled in
  (N x 24 bytes) and the result pickled back, as a ratio to the in-process run.

Each figure is the median of ``--repeat`` warm runs (the first run of each plugin, which
imports it in either process, is left out).

    .venv/bin/python benchmarks/bench_worker.py [--points 1000000] [--repeat 7]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from camcmm import worker
from camcmm.host import PluginHost
from camcmm.model import PointCloud

BUDGET = {
    "quantity": "L",
    "unit": "mm",
    "contributions": [
        {"name": "a", "u": 0.001, "c": 1},
        {"name": "b", "u": 0.002, "c": 1},
        {"name": "c", "u": 0.0005, "c": 2},
    ],
}


def median_time(fn, repeat: int) -> float:
    fn()  # the plugin's imports
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=7)
    a = ap.parse_args()
    host = PluginHost()
    t0 = time.perf_counter()
    worker.warm(host)
    print(f"worker start-up: {time.perf_counter() - t0:.2f} s (paid once; again only after a worker died)")

    here = median_time(lambda: host.run("uncertainty.budget", {"spec": BUDGET}), a.repeat)
    there = median_time(lambda: worker.run(host, "uncertainty.budget", {"spec": BUDGET}), a.repeat)
    print(
        f"small plugin (uncertainty.budget): in process {1e3 * here:.1f} ms, in the worker {1e3 * there:.1f} ms "
        f"(+{1e3 * (there - here):.1f} ms per run)"
    )

    cloud = PointCloud(np.random.default_rng(0).uniform(0, 100, size=(a.points, 3)), name="bench")
    params = {"voxel_size": 0.5}
    here = median_time(lambda: host.run("cloud.downsample", {"cloud": cloud}, params), a.repeat)
    there = median_time(lambda: worker.run(host, "cloud.downsample", {"cloud": cloud}, params), a.repeat)
    print(
        f"cloud.downsample of {a.points} points ({a.points * 24 / 1e6:.0f} MB in): in process {here:.3f} s, "
        f"in the worker {there:.3f} s, ratio {there / here:.2f} (+{1e3 * (there - here):.0f} ms)"
    )
    worker.shutdown()


if __name__ == "__main__":
    main()
