"""What the moving progress costs: SIFT extraction and matching of templeRing (47 views,
640 x 480, ring matching) handed to pycolmap in pieces (the default, ~2 s each:
camcmm_plugins.photogrammetry.progress.in_chunks) against in one call each, in the same run.

The run stops once matching is done (the mapper is not timed). Prints the wall-clock and the
process's CPU times (CPU time is what the pieces' own cost adds, whatever the load; wall-clock
on a loaded machine varies by more than the effect), their ratios and the load average;
alternating A/B/A/B so that a change of load hits both.

    .venv/bin/python benchmarks/bench_photogrammetry_progress.py [--views 47] [--repeats 2]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

TEMPLE = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "middlebury_mvs_templering"


def timed(images, names, one_call: bool) -> tuple[float, float, float, float]:
    """Seconds of extraction and of matching (from the progress messages), wall-clock and
    CPU of this process; the run cancelled after matching."""
    from camcmm.api import Cancelled
    from camcmm_plugins.photogrammetry import sfm

    saved = sfm.FIRST_IMAGES, sfm.FIRST_PAIRS
    if one_call:
        sfm.FIRST_IMAGES = sfm.FIRST_PAIRS = 10**9
    marks: dict[str, tuple[float, float]] = {}

    def progress(_fraction: float, message: str) -> None:
        for key in ("features: 0 of", "matching: 0 of", "mapping"):
            if message.startswith(key) and key not in marks:
                marks[key] = (time.perf_counter(), time.process_time())

    try:
        sfm.reconstruct_sparse(images, names, progress=progress, cancel=lambda: "mapping" in marks)
    except Cancelled:
        pass
    finally:
        sfm.FIRST_IMAGES, sfm.FIRST_PAIRS = saved
    a, b, c = marks["features: 0 of"], marks["matching: 0 of"], marks["mapping"]
    return b[0] - a[0], c[0] - b[0], b[1] - a[1], c[1] - b[1]


def main() -> None:
    import cv2

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--views", type=int, default=47)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    files = sorted(TEMPLE.glob("templeR00*.png"))[: args.views]
    images = [cv2.imread(str(f))[:, :, ::-1] for f in files]
    names = [f.name for f in files]
    rows: dict[bool, list[tuple[float, float, float, float]]] = {True: [], False: []}
    for _ in range(args.repeats):
        for one in (True, False):
            rows[one].append(timed(images, names, one))
            r = rows[one][-1]
            print(f"{'one call' if one else 'pieces  '}: extract {r[0]:.1f} s (CPU {r[2]:.1f} s), "
                  f"match {r[1]:.1f} s (CPU {r[3]:.1f} s), load {os.getloadavg()[0]:.1f}", flush=True)  # fmt: skip
    for k, what in enumerate(("extract wall", "match wall", "extract CPU", "match CPU")):
        a = sorted(r[k] for r in rows[True])[len(rows[True]) // 2]
        b = sorted(r[k] for r in rows[False])[len(rows[False]) // 2]
        print(f"{what}: pieces / one call = {b / a:.3f} (median of {args.repeats})")


if __name__ == "__main__":
    main()
