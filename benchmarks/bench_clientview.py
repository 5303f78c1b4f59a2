"""What the server spends on the client-rendered 3-D view (camcmm.gui.clientview), beside
what it spends on one frame of the remote view, for a coloured cloud of N points.

A SceneView shows a cloud of N points (uniform in a 100 × 60 × 10 mm box) coloured by a
signed field; then, in one run:

* ``publish, first``: export the scene (points in LOD order, colours as VTK maps them,
  legend, camera) and write its buffers (hash-named files);
* ``publish, colour change``: after colouring by another field — only the colour buffer
  is new;
* ``publish, nothing new``: the same scene again (every buffer known by its source);
* reference: one off-screen render of the same scene on the server (``plotter.screenshot``):
  what the remote view costs per frame before its JPEG, and per turn of the view.

Prints the times, the bytes written and the ratios to the server render, with the load
average (the machine is shared: compare ratios within one run). Run by hand:

    VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow .venv/bin/python benchmarks/bench_clientview.py [--points 2000000]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from types import SimpleNamespace

import numpy as np

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=2_000_000)
    args = ap.parse_args()

    from camcmm.gui.clientview import BufferStore, ClientView
    from camcmm.gui.view import SceneView
    from camcmm.model import PointCloud

    n = args.points
    P = np.random.default_rng(0).uniform([0, 0, 0], [100, 60, 10], size=(n, 3))
    cloud = PointCloud(P, name="bench", fields={"deviation": (P[:, 0] - 50) / 500}, field_units={"deviation": "mm"})
    print(f"load average {os.getloadavg()[0]:.2f}; {n:,} points")
    view = SceneView(display_limit=max(n, 1))
    t_show, _ = timed(lambda: view.show("c", cloud, "deviation"))
    with tempfile.TemporaryDirectory() as tmp:
        cv = ClientView("cv_bench", view, SimpleNamespace(), BufferStore(tmp), "b/")
        cv.names = lambda: {"cloud": view.actor}
        t_render, _ = timed(lambda: view.screenshot())  # the first render uploads the points

        def turn():  # a turn of the view: the remote view renders it again on the server
            view.plotter.renderer.GetActiveCamera().Azimuth(10.0)
            view.plotter.render_window.Render()

        t_render2, _ = timed(turn)
        t_first, _ = timed(cv.publish)
        b_first = sum(os.path.getsize(os.path.join(tmp, f)) for f in cv.store.take_written())
        view.set_field("z")
        t_colour, _ = timed(cv.publish)
        b_colour = sum(os.path.getsize(os.path.join(tmp, f)) for f in cv.store.take_written())
        t_same, _ = timed(cv.publish)
        b_same = len(cv.store.take_written())
    view.plotter.close()
    print(f"scene drawn on the server (SceneView.show)   {t_show:7.3f} s")
    print(f"server render, first (remote view)           {t_render:7.3f} s")
    print(f"server render, again (each turn, remote)     {t_render2:7.3f} s")
    for what, t, written in (
        ("publish, first        ", t_first, f"{b_first / 1e6:7.1f} MB written"),
        ("publish, colour change", t_colour, f"{b_colour / 1e6:7.1f} MB written"),
        ("publish, nothing new  ", t_same, f"{b_same:7d} files written"),
    ):
        print(f"{what}  {t:7.3f} s  {written}  {t / t_render2:7.2f}x a server render")


if __name__ == "__main__":
    main()
