"""Benchmark of the client-side 3-D view (resources/ui/cloudview.js, issue 29) beside today's
remote view, in one run.

Browser: headless /usr/bin/chromium on a page of its own (tests/helpers/cloudview_page.py: a fake
``window.trame``, the buffers served over http from a temp folder), a 900x650 view as the
server's. The cloud: a 2 M-point scanned sphere (R 50 mm) with a deviation colour map (blue-white-
red over +-0.05 mm), points in a random (level-of-detail) order, 2 px splats. Printed:

- from the state being set: buffers fetched and sorted, first paint (a budgeted frame when the cloud
  is bigger than the budget), all points drawn (``camcmmCloudView.ready``);
- ms per interaction frame (``view.frame(delta)``: camera move + CPU draw + putImageData), median and
  95th percentile, for rotation (2 deg azimuth, 0.5 deg elevation per frame) and zoom (dolly x1.03),
  with the budget adaptive and forced to every point; the interval between animation frames when
  each frame draws in a requestAnimationFrame callback (what the screen shows, 60 Hz ticks);
- the full draw at rest; memory: the view's buffers and frame buffers, JS heap, the renderer RSS;
- a 10^7-point cloud the same way (budgeted interaction, everything at rest).

Remote view (today): the same 2 M-point cloud in a pyvista off-screen plotter (EGL) and each
frame through VTK's web application exactly as trame's VtkRemoteView serves it
(``vtkWebApplication.StillRenderToBuffer``: render, read back, JPEG at the interactive quality 60,
waiting out the encoder), after the same camera step. The ratio remote / browser is printed.

    .venv/bin/python benchmarks/bench_browser_view.py [--points 2000000] [--big 10000000] [--no-remote]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

SIZE = (900, 650)
RADIUS = 50.0  # mm
CENTRE = np.array([120.0, -40.0, 300.0])  # mm: world coordinates far from 0, as a measured part's

ANIMATE = """async ([name, delta, count, budget]) => {
  const v = window.camcmmCloudView.views[name];
  v.setBudget(budget);
  const ms = [], drawn = [], gaps = [];
  let last = null, i = 0;
  await new Promise(res => {
    function step(ts) {
      if (last !== null) gaps.push(ts - last);
      last = ts;
      if (i++ >= count) { res(); return; }
      ms.push(v.frame(delta));
      drawn.push(v.stats().points_drawn);
      requestAnimationFrame(step);
    }
    requestAnimationFrame(step);
  });
  v.setBudget(null);
  return {ms, drawn, gaps};
}"""


def scanned_sphere(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` points on a sphere with a form deviation d = 0.05 sin(3 theta) cos(2 phi) mm along
    the normal, coloured blue (-0.05) - white (0) - red (+0.05); random order."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3)).astype(np.float64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    theta = np.arccos(np.clip(v[:, 2], -1, 1))
    phi = np.arctan2(v[:, 1], v[:, 0])
    dev = 0.05 * np.sin(3 * theta) * np.cos(2 * phi)
    xyz = CENTRE + v * (RADIUS + dev)[:, None]
    t = np.clip(dev / 0.05, -1, 1)
    rgb = np.empty((n, 3), np.float64)
    neg = t < 0
    rgb[neg] = np.c_[255 * (1 + t[neg]), 255 * (1 + t[neg]), np.full(neg.sum(), 255.0)]
    rgb[~neg] = np.c_[np.full((~neg).sum(), 255.0), 255 * (1 - t[~neg]), 255 * (1 - t[~neg])]
    return xyz, rgb.round().astype(np.uint8)


def camera() -> dict[str, Any]:
    """The server's iso view of the part (pyvista's default direction), fitted as VTK's ResetCamera."""
    d = RADIUS / np.sin(np.radians(15)) * 1.05
    pos = CENTRE + d * np.array([1.0, 1.0, 1.0]) / np.sqrt(3)
    return {"position": pos.tolist(), "focal_point": CENTRE.tolist(), "view_up": [0.0, 0.0, 1.0], "view_angle": 30.0}


def pct(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values, float), q)) if values else float("nan")


def renderer_rss_mb() -> float:
    """The largest Chromium renderer process's resident memory (MB): the page's."""
    import psutil

    best = 0
    for p in psutil.Process().children(recursive=True):
        try:
            if "--type=renderer" in " ".join(p.cmdline()):
                best = max(best, p.memory_info().rss)
        except psutil.Error:
            pass
    return best / 1e6


def browser_case(page: Any, folder: Path, n: int, rev: int, frames: int, forced: bool) -> dict[str, Any]:
    from helpers.cloudview_page import NAME, READY, SET_STATE, points_layer, scene_state

    xyz, rgb = scanned_sphere(n)
    layer = points_layer(folder, "cloud", xyz, rgb, point_size=2, origin=CENTRE)
    state = scene_state([layer], camera(), rev=rev, origin=CENTRE.tolist(), note=f"{n:,} points")
    del xyz, rgb
    t0 = time.perf_counter()
    page.evaluate(SET_STATE, [NAME, state])
    page.wait_for_function(READY, arg=NAME, timeout=120_000, polling=10)
    first = time.perf_counter() - t0
    ev = f"window.camcmmCloudView.views['{NAME}']"
    out: dict[str, Any] = {"n": n, "ready_s": first, "timing": page.evaluate(f"{ev}.stats().timing")}
    page.evaluate(f"{ev}.frame({{azimuth: 1}}); {ev}.frame({{azimuth: -1}})")  # JIT warm-up
    moves = {"rotate": {"azimuth": 2, "elevation": 0.5}, "zoom in": {"dolly": 1.03}, "zoom out": {"dolly": 1 / 1.03}}
    budgets = {"adaptive": None, "all points": 10**12} if forced else {"adaptive": None}
    for bname, budget in budgets.items():
        for mname, delta in moves.items():
            r = page.evaluate(ANIMATE, [NAME, delta, frames, budget])
            out[(mname, bname)] = r
    full = [page.evaluate(f"{ev}.frame({{full: true}})") for _ in range(5)]
    out["full_ms"] = full
    out["stats"] = page.evaluate(f"{ev}.stats()")
    out["heap_mb"] = page.evaluate("performance.memory ? performance.memory.usedJSHeapSize / 1e6 : NaN")
    out["rss_mb"] = renderer_rss_mb()
    return out


def webgl_frames(browser: Any, url: str, folder: Path, n: int, frames: int = 5) -> dict[str, Any]:
    """The same cloud through cloudview.js's WebGL2 backend, forced (a page of its own)."""
    from helpers.cloudview_page import NAME, READY, SET_STATE, points_layer, scene_state

    page = browser.new_page(viewport={"width": SIZE[0] + 40, "height": SIZE[1] + 40})
    try:
        page.goto(url + "?backend=webgl")
        page.wait_for_selector(".cmm-cv-canvas")
        xyz, rgb = scanned_sphere(n)
        layer = points_layer(folder, "cloud", xyz, rgb, point_size=2, origin=CENTRE)
        page.evaluate(SET_STATE, [NAME, scene_state([layer], camera(), rev=1, origin=CENTRE.tolist())])
        page.wait_for_function(READY, arg=NAME, timeout=120_000, polling=10)
        renderer = page.evaluate(
            """() => { const gl = document.createElement('canvas').getContext('webgl2');
            if (!gl) return 'no WebGL2'; const i = gl.getExtension('WEBGL_debug_renderer_info');
            return String(i ? gl.getParameter(i.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER)); }"""
        )
        ev = f"window.camcmmCloudView.views['{NAME}']"
        backend = page.evaluate(f"{ev}.stats().backend")
        ms = [page.evaluate(f"{ev}.frame({{azimuth: 2, elevation: 0.5}})") for _ in range(frames + 1)][1:]
        return {"renderer": f"{renderer}, backend {backend}", "ms": ms}
    finally:
        page.close()


def report(r: dict[str, Any]) -> dict[str, float]:
    n = r["n"]
    print(f"\n== browser, {n:,} points, {SIZE[0]}x{SIZE[1]}, 2 px splats ==")
    t = r["timing"]
    print(
        f"after the state arrives: buffers fetched and sorted {t['loaded_ms'] / 1e3:.2f} s (of which the "
        f"Morton sort {t['sort_ms'] / 1e3:.2f} s), first paint "
        f"{t['first_paint_ms'] / 1e3:.2f} s, all points drawn {t['all_drawn_ms'] / 1e3:.2f} s "
        f"(ready() seen by the test after {r['ready_s']:.2f} s)"
    )
    head = ["move", "budget", "median ms", "p95 ms", "min ms", "points drawn (median)", "rAF gap med/p95 ms"]
    print(f"{head[0]:9} {head[1]:11} {head[2]:>9} {head[3]:>7} {head[4]:>6} {head[5]:>22} {head[6]:>19}")
    med: dict[str, float] = {}
    for key, v in r.items():
        if not isinstance(key, tuple):
            continue
        m, b = key
        mm, p95 = pct(v["ms"], 50), pct(v["ms"], 95)
        med[f"{m}/{b}"] = mm
        gaps = f"{pct(v['gaps'], 50):.1f} / {pct(v['gaps'], 95):.1f}"
        drawn = int(np.median(v["drawn"]))
        print(f"{m:9} {b:11} {mm:9.1f} {p95:7.1f} {min(v['ms']):6.1f} {drawn:>22,} {gaps:>19}")
    full = r["full_ms"]
    print(f"full draw at rest (all {n:,} points, id-buffer too): median {pct(full, 50):.1f} ms, min {min(full):.1f}")
    s = r["stats"]
    print(
        f"memory: buffers {s['buffer_bytes'] / 1e6:.0f} MB ({s['buffer_bytes'] / n:.0f} B/point) + frame buffers "
        f"= {s['bytes'] / 1e6:.0f} MB; JS heap {r['heap_mb']:.0f} MB; renderer process RSS {r['rss_mb']:.0f} MB"
    )
    return med


def remote_frames(n: int, frames: int) -> list[float]:
    """ms per frame of the remote view: camera step + vtkWebApplication.StillRenderToBuffer
    (render, read back, JPEG quality 60) until the encoder has the frame."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv
    from vtkmodules.vtkWebCore import vtkWebApplication

    pv.OFF_SCREEN = True
    xyz, rgb = scanned_sphere(n)
    pl = pv.Plotter(off_screen=True, window_size=list(SIZE))
    try:
        pl.set_background("#f4f5f7", top="#ffffff")
        pl.add_points(pv.PolyData(xyz), scalars=rgb, rgb=True, point_size=2)
        pl.show_axes()
        cam = camera()
        pl.camera_position = [cam["position"], cam["focal_point"], cam["view_up"]]
        pl.render()
        rw = pl.render_window
        app = vtkWebApplication()
        out = []
        for k in range(frames + 1):
            t0 = time.perf_counter()
            pl.camera.Azimuth(2)
            app.InvalidateCache(rw)
            img = app.StillRenderToBuffer(rw, 0, 60)
            while app.GetHasImagesBeingProcessed(rw):  # the client asks again until it gets this frame
                time.sleep(0.001)
                img = app.StillRenderToBuffer(rw, app.GetLastStillRenderToMTime(), 60)
            if k and img is not None:  # the first frame builds the GPU buffers
                out.append((time.perf_counter() - t0) * 1000)
        return out
    finally:
        pl.close()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=2_000_000)
    ap.add_argument("--big", type=int, default=10_000_000, help="the big case (0: skip)")
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--remote-frames", type=int, default=8)
    ap.add_argument("--no-remote", action="store_true")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright

    from helpers.browsing import launch
    from helpers.cloudview_page import CloudviewPage

    print(f"load average at start: {os.getloadavg()}  ({os.cpu_count()} cores)")
    results = []
    with tempfile.TemporaryDirectory() as tmp, CloudviewPage(Path(tmp), SIZE) as url, sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": SIZE[0] + 40, "height": SIZE[1] + 40})
            page.goto(url)
            page.wait_for_selector(".cmm-cv-canvas")
            results.append(browser_case(page, Path(tmp), args.points, 1, args.frames, forced=True))
            gl_ms = webgl_frames(browser, url, Path(tmp), args.points)
            if args.big:
                for f in Path(tmp).iterdir():  # the 2 M buffers are not needed any more
                    f.unlink()
                results.append(browser_case(page, Path(tmp), args.big, 2, args.frames // 2, forced=False))
        finally:
            browser.close()
    meds = [report(r) for r in results]
    print(
        f"\nWebGL2 backend forced on this machine's GL ({gl_ms['renderer']}; chosen automatically only for a "
        f"hardware GPU): {args.points:,} points, median {pct(gl_ms['ms'], 50):.0f} ms per rotate frame (GPU finished)"
    )
    print(f"\nload average after the browser runs: {os.getloadavg()}")
    if args.no_remote:
        return
    remote = remote_frames(args.points, args.remote_frames)
    rm = pct(remote, 50)
    print(f"\n== remote view today (pyvista EGL + vtkWebApplication JPEG 60), {args.points:,} points ==")
    print(f"ms per frame: median {rm:.0f}, p95 {pct(remote, 95):.0f} (frames: {', '.join(f'{x:.0f}' for x in remote)})")
    b = meds[0]
    print(
        f"ratio remote / browser per rotate frame: adaptive {rm / b['rotate/adaptive']:.0f}x, "
        f"all {args.points:,} points {rm / b['rotate/all points']:.0f}x"
    )
    print(f"load average at the end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
