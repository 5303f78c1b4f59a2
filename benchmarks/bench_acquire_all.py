"""Benchmark: the acceptance wizard's "Acquire all" at full size — a whole VDI/VDE 2634-2 test
(10 sphere, 7 ball-bar and 6 flat positions) measured by the simulated stereo fringe system
(``virtuallab.fringe-system``: rendered, decoded, triangulated by camera-camera phase
matching, thesis ch. 5.2.4) and evaluated as imported files are, to the verdict.

This is the size the browser test ran before issue 25 (tests/browser/test_browser_acquire.py
now acquires two positions and stops). It drives the Acceptance page's own handlers in this
process (no browser: what the browser adds is drawing, measured by the browser tests), and
as the reference in the same run it measures the system's bare acquisition (``host.run``
of the fringe system for the same positions, no wizard): the ratio is what the wizard
adds per position (evaluation, storing the cloud and the result, the state).

    .venv/bin/python benchmarks/bench_acquire_all.py [--preset stereo_fringe|camera_projector] [--reference 3]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

MPE = {"PF": 0.186, "PS": 0.143, "SD": 0.096, "F": 0.243}  # thesis ch. 5 system


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--preset",
        default="stereo_fringe",
        choices=["stereo_fringe", "camera_projector"],
        help="the system's preset: stereo_fringe (two cameras, the browser's default) or camera_projector",
    )
    ap.add_argument("--reference", type=int, default=3, help="positions acquired bare for the reference")
    a = ap.parse_args()

    from camcmm.gui.app import build, close
    from camcmm.host import default_host

    host = default_host()
    with tempfile.TemporaryDirectory(prefix="camcmm-bench-acquire-") as tmp:
        server, _session = build("bench-acquire", Path(tmp) / "proj")
        server.state.ready()
        try:
            page, state = server.pages["acceptance"], server.state
            page.choose_standard("vdi2634-2", state.wz_form)
            form = json.loads(json.dumps(state.wz_form))
            form["system_name"] = "Virtual stereo fringe system"
            form["mpe"] = {k: str(v) for k, v in MPE.items()}
            form["measuring_volume"] = [100, 100, 100]
            assert page.start(form), state.wz_setup_error
            params = {} if a.preset == "stereo_fringe" else {"method": "projector", "preset": a.preset}
            page.set_source("virtuallab.fringe-system", params)
            t0 = time.perf_counter()
            first = asyncio.run(page.acquire_async("sphere", "sphere-01"))
            assert first is not None and first["status"] == "done", state.error_message
            n = 1 + asyncio.run(page.acquire_all_async())
            t_wizard = time.perf_counter() - t0
            print(
                f"wizard: {n} positions acquired in {t_wizard:.1f} s ({t_wizard / n:.1f} s each); "
                f"verdict {state.wz_verdict}, complete {state.wz_complete}"
            )
            for p in state.wz_parameters:
                print(f"  {p['key']}: {p['value']} (MPE {p['mpe']}) {p['verdict']}")
            # the reference: the system's acquisition alone for the first positions' placements
            reqs = host.load("vdi2634-2").requirements(page.wizard.plan)
            ids = [(r["test"], pos["id"]) for r in reqs for pos in r["positions"]][: a.reference]
            placements = [page.wizard.placement(test, pid) for test, pid in ids]
            t0 = time.perf_counter()
            for placement in placements:
                host.run("virtuallab.fringe-system", {"placement": placement}, params)
            t_bare = (time.perf_counter() - t0) / max(len(placements), 1)
            print(f"reference: the bare acquisition {t_bare:.1f} s per position ({len(placements)} positions)")
            print(f"ratio wizard / bare per position: {t_wizard / n / t_bare:.2f}")
        finally:
            close(server)


if __name__ == "__main__":
    main()
