"""Benchmark: a full VDI/VDE 2634 part 2 evaluation at the sizes of the issue.

10 spheres of 200 000 points, 7 ball bars of 2 x 100 000 (plus their bars), 6 flats of
500 000 points — simulated once by the virtual lab (cached in a temp folder) — then
evaluated by the vdi2634-2 standard plugin exactly as ``camcmm verify`` does: read
every file, hash it, segment the ball bars, fit everything with the 3-per-1000 rule,
summarise. Target: at most 2 s (issue 29; 5 s before). The process CPU time per
evaluation is printed too: on this shared 2-core machine the wall time follows the load
of other programs, the CPU time much less.

Reference, in the same run: the bare least-squares fits of the same data with no
outlier rule (fit.sphere / fit.plane through the host; ball bars split by the true
centres, no segmentation), files already in memory — the floor the evaluation cannot
beat. A second reference times scipy.optimize.least_squares on one 200 000-point sphere
(the textbook way) beside the plugin's fit of it.

    .venv/bin/python benchmarks/bench_vdi2634.py [--repeat 3] [--workers N] [--regenerate]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from camcmm.api import RunContext, read
from camcmm.host import default_host

SIZES = {"n_sphere": 200_000, "n_ball_bar": 100_000, "n_flat": 500_000}
CACHE = Path(tempfile.gettempdir()) / "camcmm-bench-vdi2634"


def dataset(regenerate: bool) -> Path:
    plan = CACHE / "plan.yaml"
    if plan.is_file() and not regenerate:
        return plan
    t = time.perf_counter()
    default_host().run(
        "virtuallab.acceptance-set",
        {},
        {"directory": str(CACHE), **SIZES, "noise": 0.02, "scale_error": 2e-4, "amplitude": 0.01},
    )
    print(f"simulated the data set in {time.perf_counter() - t:.1f} s -> {CACHE}")
    return plan


CPU: list[float] = []  # process CPU seconds per evaluation: a figure other processes on the machine disturb less


def evaluate(plan: Path, workers: int | None) -> tuple[float, dict]:
    host = default_host()
    std = host.load("vdi2634-2")
    t, c = time.perf_counter(), time.process_time()
    result = std(RunContext(host, "vdi2634-2"), plan, workers=workers)
    CPU.append(time.process_time() - c)
    return time.perf_counter() - t, result


def bare_fits(plan: Path) -> float:
    """Sum of the plain least-squares fits (no outlier rule, no segmentation, no I/O)."""
    host = default_host()
    truth = json.loads((plan.parent / "truth.json").read_text())
    fs, fp = host.algorithm("fit.sphere"), host.algorithm("fit.plane")
    clouds = {f: read(plan.parent / f) for f in truth}
    t = time.perf_counter()
    for f, tr in truth.items():
        c = clouds[f]
        if tr["test"] == "sphere":
            fs(cloud=c, outliers="none")
        elif tr["test"] == "flat":
            fp(cloud=c, outliers="none")
        else:
            centres = np.array([s["center"] for s in tr["spheres"]])
            r = tr["sphere_diameter"] / 2
            for cc in centres:
                near = np.abs(np.linalg.norm(c.points - cc, axis=1) - r) < 0.2
                fs(cloud=c.subset(near), outliers="none")
    return time.perf_counter() - t


def scipy_sphere(points: np.ndarray) -> float:
    from scipy.optimize import least_squares

    def res(p):
        return np.linalg.norm(points - p[:3], axis=1) - p[3]

    x0 = np.append(points.mean(axis=0), np.linalg.norm(points - points.mean(axis=0), axis=1).mean())
    t = time.perf_counter()
    least_squares(res, x0, method="lm")
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--workers", type=int)
    ap.add_argument("--regenerate", action="store_true")
    args = ap.parse_args()
    plan = dataset(args.regenerate)
    n = sum(read(plan.parent / f).n_points for f in json.loads((plan.parent / "truth.json").read_text()))
    cold, _ = evaluate(plan, args.workers)  # first run in this process: plugin imports (scipy...) included
    times, result = [], None
    for _ in range(args.repeat):
        dt, result = evaluate(plan, args.workers)
        times.append(dt)
    ref = min(bare_fits(plan) for _ in range(args.repeat))
    best = min(times)
    print(f"cpus: {os.cpu_count()}, workers: {args.workers or 'auto'}, points: {n:,}")
    print(
        f"full part-2 evaluation (read + hash + segment + fit with 3/1000 rule + summary): "
        f"best {best:.2f} s, median {statistics.median(times):.2f} s over {args.repeat} runs "
        f"({'within' if best <= 2 else 'OVER'} the 2 s target)"
    )
    print(
        f"CPU time of this process per evaluation (all threads): best {min(CPU[1:]):.2f} s; "
        f"load average while running: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    )
    print(f"first (cold) run in this process, plugin imports included: {cold:.2f} s")
    print(
        f"reference: bare least-squares fits, no outlier rule, data in memory: {ref:.2f} s "
        f"-> ratio evaluation / bare fits = {best / ref:.2f}"
    )
    sphere = read(plan.parent / "sphere_01.ply")
    fs = default_host().algorithm("fit.sphere")
    t = time.perf_counter()
    fs(cloud=sphere, outliers="vdi2634")
    t_plugin = time.perf_counter() - t
    t_scipy = scipy_sphere(sphere.points)
    print(
        f"one 200k sphere: fit.sphere with the 3/1000 rule {t_plugin:.3f} s; scipy least_squares (lm), "
        f"no outlier rule {t_scipy:.3f} s -> ratio {t_plugin / t_scipy:.2f}"
    )
    print("verdict:", result["verdict"], {k: round(v["value"], 4) for k, v in result["parameters"].items()})


if __name__ == "__main__":
    main()
