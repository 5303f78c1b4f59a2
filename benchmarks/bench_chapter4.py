"""Benchmark: chapter 4's whole acceptance test (thesis ch. 4.4-4.5) through the simulated
DSLR + turntable + laser speckle photogrammetry system, to the report's tables 4.1/4.2.

Every position VDI/VDE 2634-3 lays out as the thesis modified it — the 10 mm sphere from
five camera positions A-E and the ball plate in seven orientations (fig. 4.4, the tilted
one for the vertical), each ``--repeats`` times with a new speckle pattern — is measured
by ``virtuallab.photogrammetry-system`` (render the series, ``photogrammetry.reconstruct``,
export and scale the spheres), written as a PLY and listed in a plan; the ``vdi2634-3``
standard evaluates the plan exactly as the wizard's imports do (5 % outlier removal, LS
fit, scaling by the 5 mm spheres' radii and eqs. 4.10-4.12, ISO 15530-3 with
u_b = u_w = 0) and writes the report.

Printed: per acquisition the time and the errors against the virtual lab's truth; then
the tables' figures (mean radius, spread, U size and form; each length's mean deviation,
spread and U) beside the thesis's (8 µm, 17 µm, 25/25/20 µm) as ratios, the whole time.
The reference in the same run is the thesis's own figure; the virtual DSLR is down-scaled
(``--downscale``), so its U grows about in proportion (pixels ``downscale`` times larger).

    .venv/bin/python benchmarks/bench_chapter4.py [--repeats 3] [--n-images 30] [--downscale 8]
        [--spheres 5] [--plates 7] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import yaml

from camcmm.api import write
from camcmm.host import default_host

ARTEFACTS = {  # thesis ch. 4.3: carbide balls u(r) = 0.2 µm; lengths on a Zeiss F25 (MPE 0.25 µm + L/666)
    "sphere": {"diameter": 10.0, "uncertainty": 0.0008, "k": 2},
    "ball_plate": {
        "sphere_diameter": 5.0,
        "sphere_diameter_uncertainty": 0.0008,
        "lengths": [5.942, 7.956, 9.957],
        "uncertainty": 0.0005,
        "k": 2,
    },
}
THESIS = {"U_size": 0.008, "U_form": 0.017, "U_L": [0.025, 0.025, 0.020]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--n-images", type=int, default=30)
    ap.add_argument("--downscale", type=float, default=8.0)
    ap.add_argument("--spheres", type=int, default=5, help="camera positions measured (of 5)")
    ap.add_argument("--plates", type=int, default=7, help="plate orientations measured (of 7)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="")
    a = ap.parse_args()
    host = default_host()
    std = host.load("vdi2634-3")
    out = Path(a.out or tempfile.mkdtemp(prefix="camcmm-bench-ch4-"))
    out.mkdir(parents=True, exist_ok=True)
    reqs = {r["test"]: r["positions"] for r in std.requirements()}
    todo = [("sphere", p) for p in reqs["sphere"][: a.spheres]] + [
        ("ball_plate", p) for p in reqs["ball_plate"][: a.plates]
    ]
    params = {"n_images": a.n_images, "downscale": a.downscale, "seed": a.seed}
    meas: dict[str, list] = {"sphere": [], "ball_plate": []}
    log = []
    t0 = time.perf_counter()
    for test, pos in todo:
        group = []
        for r in range(1, a.repeats + 1):
            placement = {"test": test, "position": pos, "repeat": r, "artefacts": ARTEFACTS}
            t = time.perf_counter()
            res = host.run("virtuallab.photogrammetry-system", {"placement": placement}, params)
            o = res.outputs
            name = f"{pos['id']}_r{r}.ply"
            write(o["cloud"], out / name)
            group.append({"file": name, "position": pos["id"], "repeat": r})
            row = {
                "file": name,
                "s": round(time.perf_counter() - t, 1),
                "registered": f"{o['n_registered']}/{o['n_images']}",
                "points": o["n_points"],
                "scale_u_rel": o["scale"]["relative_u"],
                "timings": {k: round(v, 1) for k, v in o["timings"].items()},
            }
            log.append(row)
            print(json.dumps(row), flush=True)
        if group:
            meas[test].append(group)
    plan = {
        "standard": "vdi2634-3",
        "system": {"name": "Virtual DSLR + turntable + laser speckle", "measuring_volume": [30, 30, 30]},
        "mpe": {"PF": 0.3, "PS": 0.15, "SD": 0.15},
        "artefacts": ARTEFACTS,
        "measurements": {k: v for k, v in meas.items() if v},
        "outliers": {"sphere": "percent:5", "ball_plate": "percent:5"},
        "scaling": {"sphere": "radii", "ball_plate": "lengths"},
        "repeats": a.repeats,
    }
    (out / "plan.yaml").write_text(yaml.safe_dump(plan, sort_keys=False), encoding="utf-8")
    t_acq = time.perf_counter() - t0
    res = host.run("vdi2634-3", {"plan": str(out / "plan.yaml")}, {})
    from camcmm_plugins.vdi2634 import report, tables_ch4

    result = res.outputs
    paths = report.write(result, out / "report")
    t1 = tables_ch4.table_4_1(result)
    t2 = tables_ch4.table_4_2(result)
    print(
        f"\nacquisitions: {len(log)} in {t_acq:.0f} s ({t_acq / max(1, len(log)):.0f} s each); report {paths['html']}"
    )
    if t1:
        s = t1["summary"]
        print(
            f"table 4.1: mean r {s['mean_radius']:.4f} mm (true 5.0000, error {1e3 * (s['mean_radius'] - 5):+.1f} µm), "
            f"spread {1e3 * s['std_radius']:.1f} µm, mean std(Δr) {1e3 * s['mean_form_std']:.1f} µm; "
            f"U size {1e3 * s['U_size']:.1f} µm ({s['U_size'] / THESIS['U_size']:.1f} x thesis 8 µm), "
            f"U form {1e3 * s['U_form']:.1f} µm ({s['U_form'] / THESIS['U_form']:.1f} x thesis 17 µm)"
        )
    if t2:
        for p, ref in zip(t2["lengths"], THESIS["U_L"], strict=True):
            print(
                f"table 4.2 {p['name']}: mean {p['mean']:.4f} mm, L_m - L_c {1e3 * p['deviation']:+.1f} µm, "
                f"spread {1e3 * p['std']:.1f} µm, U {1e3 * p['U']:.1f} µm "
                f"({p['U'] / ref:.1f} x thesis {1e3 * ref:.0f} µm)"
            )
    print(f"verdict {result['verdict']}; total {time.perf_counter() - t0:.0f} s")
    (out / "bench.json").write_text(json.dumps({"acquisitions": log}, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
