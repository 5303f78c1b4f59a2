"""Benchmark: the stereo Monte Carlo, 10 000 iterations x 1 000 points (10^7 triangulations).

In one run, on the thesis's stereo system (tests/data/uncertainty/montecarlo_thesis.yaml,
all influence factors perturbed together):

* camcmm's vectorised Monte Carlo (``run_factors``: chunks of trials, each chunk one
  batched pass of sampling, correction and closed-form linear triangulation);
* as the reference, the straightforward loop a user would write: one iteration at a
  time (vectorised over the points only), same model, same random offsets — timed on
  ``--ref-iterations`` iterations and reported per triangulation;

with triangulations per second, their ratio, and the agreement of the two (same
offsets, so the per-iteration errors must be equal to rounding).

    .venv/bin/python benchmarks/bench_montecarlo.py [--iterations 10000] [--ref-iterations 500]

Target: 10^7 triangulations in <= 5 s on the 2-core development machine.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import yaml

from camcmm_plugins.uncertainty import montecarlo as mc

DOC = Path(__file__).resolve().parents[1] / "tests" / "data" / "uncertainty" / "montecarlo_thesis.yaml"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iterations", type=int, default=10_000)
    ap.add_argument("--ref-iterations", type=int, default=500)
    ap.add_argument("--chunk", type=int, default=100)
    args = ap.parse_args()
    doc = yaml.safe_load(DOC.read_text())
    doc["chunk"] = args.chunk
    setup = mc.setup_from_dict(doc)
    P = len(setup.points)
    mc.run_factors(setup, {"joint": setup.factors}, 200, 0)  # warm-up

    t0 = time.perf_counter()
    res = mc.run_factors(setup, {"joint": setup.factors}, args.iterations, 0)["joint"]
    t_vec = time.perf_counter() - t0
    n_vec = args.iterations * P

    # reference: the per-iteration loop, on the same offsets as one vectorised batch
    n_ref = args.ref_iterations
    off = mc.sample_offsets(setup, setup.factors, n_ref, np.random.default_rng(1))
    t0 = time.perf_counter()
    E_loop = np.empty((n_ref, P, 3))
    for i in range(n_ref):
        X = mc.measure(setup, {f: o[i : i + 1] for f, o in off.items()}, 1)
        E_loop[i] = mc.errors(setup, X)[0]
    t_ref = time.perf_counter() - t0
    E_vec = mc.errors(setup, mc.measure(setup, off, n_ref))
    agree = float(np.max(np.abs(E_loop - E_vec))) * 1e3

    rate_vec, rate_ref = n_vec / t_vec, n_ref * P / t_ref
    print(f"grid {P} points, {len(setup.factors)} factors perturbed together ({', '.join(setup.factors)})")
    print(
        f"vectorised: {args.iterations} iterations x {P} points = {n_vec:.2e} triangulations "
        f"in {t_vec:.2f} s -> {rate_vec:.3e} triangulations/s   (target <= 5 s for 1e7)"
    )
    print(f"loop      : {n_ref} iterations x {P} points in {t_ref:.2f} s -> {rate_ref:.3e} triangulations/s")
    print(f"ratio vectorised / loop: {rate_vec / rate_ref:.1f}x; same offsets agree to {agree:.2e} um")
    print(f"combined (x, y, z) = {np.round(res['u'], 3).tolist()} um")


if __name__ == "__main__":
    main()
