"""Benchmark: the speckle on/off study of thesis ch. 6.2 in the virtual lab (issue 18's
speed target: 4 artefacts x 3 materials x 2 conditions at reduced image size in <= 30 min
on 2 cores).

Runs ``studies.speckle`` through the host on a study file written here (the defaults of
``studies/studyfile.py``: 30 images through 270 deg at 45 deg elevation, 600 x 400 px,
F/11) into a fresh work folder, then prints per case each stage's time (capture =
rendering, reconstruct = SfM + dense, align, deviations), the sum per stage, the total
against the 30-min target, the load average before and after (the machine may be shared:
a load above the core count slows every stage), and the tables' figures.

    .venv/bin/python benchmarks/bench_study_speckle.py [--artefacts am_pyramid,...]
        [--materials nylon12,...] [--n-images 30] [--downscale 10] [--work DIR] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from camcmm.api import default_host

TARGET_S = 30 * 60


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--artefacts", default="am_pyramid,am_recess,am_sphere,am_pillars")
    ap.add_argument("--materials", default="nylon12,abs,ti6al4v")
    ap.add_argument("--n-images", type=int, default=30)
    ap.add_argument("--downscale", type=float, default=10.0)
    ap.add_argument("--work", default=None, help="work folder (default: a temporary one, removed)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-study-") as tmp:
        work = Path(a.work or tmp)
        work.mkdir(parents=True, exist_ok=True)
        f = work / "STUDY.yaml"
        f.write_text(
            "name: benchmark\n"
            f"work: {work / 'cases'}\n"
            f"artefacts: [{a.artefacts}]\nmaterials: [{a.materials}]\n"
            f"capture:\n  simulated: {{n_images: {a.n_images}, downscale: {a.downscale}}}\n"
            f"reconstruct: {{max_image_size: {int(round(6000 / a.downscale))}}}\n",
            encoding="utf-8",
        )
        load0 = os.getloadavg()
        t0 = time.perf_counter()
        res = default_host().run("studies.speckle", {}, {"study": str(f), "fresh": True})
        total = time.perf_counter() - t0
        load1 = os.getloadavg()
    o = res.outputs
    stages = ("capture_s", "reconstruct_s", "align_s", "deviations_s")
    sums = dict.fromkeys(stages, 0.0)
    print(f"{'case':32s} " + " ".join(f"{s[:-2]:>12s}" for s in stages) + "   std_um  n_points  coverage")
    for c in o["cases"]:
        if "error" in c:
            print(f"{c['id']:32s} FAILED: {c['error']}")
            continue
        t = c["timings"]
        for s in stages:
            sums[s] += t[s]
        print(
            f"{c['id']:32s} "
            + " ".join(f"{t[s]:12.1f}" for s in stages)
            + f"   {c['std_um']:6.0f}  {c['n_points']:8d}  {100 * c['coverage_area_fraction']:6.1f} %"
        )
    print(f"{'sum per stage (s)':32s} " + " ".join(f"{sums[s]:12.1f}" for s in stages))
    print(f"total {total:.0f} s for {len(o['cases'])} cases = {total / TARGET_S:.2f} x the 30-min target")
    print(f"load average (1, 5, 15 min) before {load0}, after {load1}; {os.cpu_count()} CPUs — shared machine?")
    for m, s in o["summary"].items():
        if s.get("n_artefacts"):
            print(
                f"{m}: speckle changes std by {s['std_um_change']:+.0f} µm "
                f"({100 * s['std_um_relative_change']:+.0f} %), points by {s['n_points_change']:+.0f}, "
                f"area coverage by {100 * s['coverage_area_fraction_change']:+.1f} %"
            )
    for w in res.warnings:
        if "saturate" not in w:
            print("warning:", w)
    if a.json:
        Path(a.json).write_text(
            json.dumps({"total_s": total, "stages_s": sums, "cases": o["cases"], "summary": o["summary"]}, indent=1),
            encoding="utf-8",
        )


if __name__ == "__main__":
    main()
