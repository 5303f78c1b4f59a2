"""resources/ui/cloudview.js in Chromium on a page of its own (tests/helpers/cloudview_page.py:
a fake ``window.trame``, the buffers from a folder over http), against VTK's perspective
projection computed here (``project``: f = (H/2)/tan(view_angle/2), x = W/2 + f xc/d,
y = H/2 - f yc/d):

- three points of 3 px in three colours land as 3x3 squares of exactly their colours at their
  projected pixels, and nowhere else; 2 and 1 px likewise; an interaction frame (its own loop)
  draws the same picture;
- a triangle facing the camera hides a point behind it and not one in front, in its colour
  (the headlight falls straight on it: Lambert factor 1);
- a click 2 px beside a point triggers ``cv_pick`` with its layer, its index in the server's
  order and its world position;
- with tool "rect" a drag shows the rectangle over the view and then triggers ``cv_select`` with
  it in NDC, and its ``mvp``
  maps each point to the NDC of its projected pixel (so a point is inside exactly when drawn
  inside);
- with a colour legend the scene is centred in the width left of it (lens(): W' = W - the
  legend's strip, f = (min(H, W')/2)/tan(view_angle/2)): two points at ±20 mm, of which the right
  one lay under the legend before (issue 30: the ball bar), are drawn at those pixels, left of it;
- two pick labels of points 0.6 mm apart: their texts do not overlap (the later lifted);
- a view attached over the server's empty placeholder (rev 0) shows "drawing …" until the first
  frame of a scene, and not after; after its element is resized the canvas has the element's
  size (no stretched picture);
- the WebGL2 backend (forced) draws the same colours at the same pixels with the same occlusion.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from helpers.browsing import MARKS, launch
from helpers.cloudview_page import NAME, READY, SET_STATE, CloudviewPage, mesh_layer, points_layer, project, scene_state

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SIZE = (400, 300)
CAMERA = {"position": [0.0, 0.0, 100.0], "focal_point": [0.0, 0.0, 0.0], "view_up": [0.0, 1.0, 0.0], "view_angle": 30.0}
# green, red, blue: not in the renderer's Morton order (red, green, blue), so that a pick must map
# the drawn order back to the server's index
XYZ = np.array([[10.0, 5.0, 0.0], [0.0, 0.0, 0.0], [-8.0, -6.0, 5.0]])
RGB = np.array([[0, 200, 0], [255, 0, 0], [0, 0, 255]], dtype=np.uint8)


def _image(page) -> np.ndarray:
    """The view as shown (RGB): canvas and overlays composited."""
    shot = page.screenshot(clip={"x": 0, "y": 0, "width": SIZE[0], "height": SIZE[1]})
    return cv2.imdecode(np.frombuffer(shot, np.uint8), cv2.IMREAD_COLOR)[:, :, ::-1]


def _triggers(page, name: str, timeout: float = 5000) -> list:
    page.wait_for_function(f"() => window.__triggers.some(t => t[0] === '{name}')", timeout=timeout)
    return [t[1] for t in page.evaluate("window.__triggers") if t[0] == name]


def test_cloudview_draws_picks_and_selects(tmp_path):
    folder = tmp_path / "cv"
    folder.mkdir()
    cloud = points_layer(folder, "cloud", XYZ, RGB, point_size=3)
    px = project(CAMERA, SIZE, XYZ)
    with CloudviewPage(folder, SIZE) as url, sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": SIZE[0] + 50, "height": SIZE[1] + 50})
            page.goto(url)
            page.wait_for_selector(".cmm-cv-canvas")
            page.evaluate(SET_STATE, [NAME, scene_state([cloud], CAMERA, rev=1)])
            page.wait_for_function(READY, arg=NAME, timeout=10_000)
            img = _image(page)
            for (x, y), c in zip(px, RGB, strict=True):
                ix, iy = int(np.floor(x)), int(np.floor(y))  # a 3 px splat spans [i-1, i+2)
                assert (img[iy - 1 : iy + 2, ix - 1 : ix + 2] == c).all(), (x, y, img[iy - 1 : iy + 2, ix - 1 : ix + 2])
                assert (img == c).all(axis=2).sum() == 9, c  # that colour nowhere else
            stats = page.evaluate(f"window.camcmmCloudView.views['{NAME}'].stats()")
            assert stats["points_drawn"] == 3 and stats["points_total"] == 3

            # an interaction frame (its own loop: no id-buffer, no branches) draws the same picture,
            # for 3, 2 and 1 px splats
            view = f"window.camcmmCloudView.views['{NAME}']"
            page.evaluate(f"{view}.frame({{}})")
            assert (_image(page) == img).all()
            for size in (2, 1):
                small = points_layer(folder, "cloud", XYZ, RGB, point_size=size)
                page.evaluate(SET_STATE, [NAME, scene_state([small], CAMERA, rev=10 + size)])
                page.wait_for_function(READY, arg=NAME, timeout=10_000)
                full = _image(page)
                page.evaluate(f"{view}.frame({{}})")
                assert (_image(page) == full).all(), size
                for (x, y), c in zip(px, RGB, strict=True):
                    ix, iy = int(np.floor(x)), int(np.floor(y))  # the splat spans [i, i + size)
                    assert (full[iy : iy + size, ix : ix + size] == c).all(), (size, c)
                    assert (full == c).all(axis=2).sum() == size * size, (size, c)

            # a click 2 px right of the green point: index 0 in the server's order, its world mm
            gx, gy = px[0]
            page.mouse.click(gx + 2, gy)
            (pick,) = _triggers(page, "cv_pick")
            assert pick[:3] == [NAME, "cloud", 0]
            assert np.allclose(pick[3], XYZ[0], atol=1e-5)

            # a rectangle from (40, 30) to (260, 170) px: the red and green points inside, not blue
            page.evaluate(SET_STATE, [NAME, scene_state([cloud], CAMERA, rev=2, tool="rect")])
            page.wait_for_function(READY, arg=NAME, timeout=10_000)
            page.mouse.move(40, 30)
            page.mouse.down()
            page.mouse.move(150, 100, steps=4)
            page.mouse.move(260, 170, steps=4)
            shown = "() => { const s = document.querySelector('.cmm-cv-select'); return [getComputedStyle(s).display,"
            shown += " s.querySelector('polygon').getAttribute('points')]; }"
            # the rectangle is drawn while dragging
            assert page.evaluate(shown) == ["block", "40.0,30.0 260.0,30.0 260.0,170.0 40.0,170.0"]
            page.mouse.up()
            (sel,) = _triggers(page, "cv_select")
            assert sel[0] == NAME and sel[1]["shape"] == "rect"
            w, h = SIZE
            want = [[2 * x / w - 1, 1 - 2 * y / h] for x, y in [(40, 30), (260, 30), (260, 170), (40, 170)]]
            assert np.allclose(sel[1]["polygon"], want, atol=1e-9)
            mvp = np.array(sel[1]["mvp"], dtype=float).reshape(4, 4, order="F")
            clip = mvp @ np.c_[XYZ, np.ones(3)].T
            assert (clip[3] > 0).all()
            ndc = (clip[:2] / clip[3]).T
            assert np.allclose(ndc, np.c_[2 * px[:, 0] / w - 1, 1 - 2 * px[:, 1] / h], atol=1e-9)
            inside = (
                (ndc[:, 0] > want[0][0])
                & (ndc[:, 0] < want[1][0])
                & (ndc[:, 1] < want[0][1])
                & (ndc[:, 1] > want[2][1])
            )
            assert inside.tolist() == [True, True, False]

            # a triangle at z = 1 facing the camera (the headlight's Lambert factor is 1): it hides
            # the red point (z = 0) inside its outline, not the blue one (z = 5) in front of it
            tri = np.array([[0.0, -5.0, 1.0], [30.0, 10.0, 1.0], [-30.0, 10.0, 1.0]])
            mesh = mesh_layer(folder, "part", tri, np.array([[0, 1, 2]]), color=(180, 120, 60))
            page.evaluate(SET_STATE, [NAME, scene_state([cloud, mesh], CAMERA, rev=3)])
            page.wait_for_function(READY, arg=NAME, timeout=10_000)
            img = _image(page)
            (rx, ry), (bx, by) = px[1], px[2]
            assert (img[int(ry), int(rx)] == [180, 120, 60]).all(), img[int(ry), int(rx)]
            assert (img[int(by), int(bx)] == [0, 0, 255]).all()
            assert (img == [255, 0, 0]).all(axis=2).sum() == 0

            _legend_labels_spinner(page, folder)

            # the GPU backend (forced: under SwiftShader the automatic choice is the CPU), the same
            # scene: the same colours at the same pixels, the same occlusion
            gl = browser.new_page(viewport={"width": SIZE[0] + 50, "height": SIZE[1] + 50})
            gl.goto(url + "?backend=webgl")
            gl.wait_for_selector(".cmm-cv-canvas")
            gl.evaluate(SET_STATE, [NAME, scene_state([cloud, mesh], CAMERA, rev=1)])
            gl.wait_for_function(READY, arg=NAME, timeout=10_000)
            assert gl.evaluate(f"window.camcmmCloudView.views['{NAME}'].stats().backend") == "webgl2"
            img = _image(gl)
            assert (img[int(ry), int(rx)] == [180, 120, 60]).all(), img[int(ry), int(rx)]
            assert (img[int(by), int(bx)] == [0, 0, 255]).all()
            assert (img == [0, 0, 255]).all(axis=2).sum() == 9
            assert (img == [255, 0, 0]).all(axis=2).sum() == 0
        finally:
            browser.close()


def _legend_labels_spinner(page, folder) -> None:
    """Issue 30 in cloudview.js: framing beside the legend, labels apart, the spinner, a resize."""
    w, h = SIZE
    legend = {"title": "deviation [µm]", "colors": [[90, 90, 90], [160, 160, 160]], "lo": -1, "hi": 1}
    legend["labels"] = [{"value": v, "text": t} for v, t in ((-1, "−1"), (0, "0"), (1, "1"))]
    ends = np.array([[-20.0, 0.0, 0.0], [20.0, 0.0, 0.0]])
    bar = points_layer(folder, "bar", ends, np.array([[0, 200, 0]] * 2, dtype=np.uint8), point_size=3)
    labels = [
        {"pos": [0.0, 0.0, 0.0], "text": "#1 (0.000, 0.000, 0.000) mm +8.6 µm", "color": [0, 0, 0]},
        {"pos": [0.5, 0.3, 0.0], "text": "#2 (0.500, 0.300, 0.000) mm +3.0 µm", "color": [0, 0, 0]},
    ]
    page.evaluate(SET_STATE, [NAME, scene_state([bar], CAMERA, rev=40, legend=legend, labels=labels)])
    page.wait_for_function(READY, arg=NAME, timeout=10_000)
    left = page.evaluate("document.querySelector('.cmm-cv-legend').offsetLeft")
    assert 0.6 * w < left < w, left
    wv = w - (w - left + 8)  # LEGEND_GAP
    f = min(h, wv) / 2 / math.tan(math.radians(CAMERA["view_angle"]) / 2)
    want = [wv / 2 - f * 20 / 100, wv / 2 + f * 20 / 100]  # the camera 100 mm away
    assert project(CAMERA, SIZE, ends)[1][0] > left  # where it was drawn before: under the legend
    img = _image(page)
    ys, xs = np.nonzero((img == [0, 200, 0]).all(axis=2))
    assert xs.size == 18 and xs.max() < left, (xs, left)
    for x0 in want:
        near = xs[np.abs(xs - x0) <= 2]
        assert near.size == 9 and abs(near.mean() - (np.floor(x0) + 0.5)) <= 0.6, (x0, xs)

    boxes = page.evaluate(
        "() => [...document.querySelectorAll('.cmm-cv-label .cmm-cv-text')].map(t => {"
        " const r = t.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; })"
    )
    assert len(boxes) == 2
    (a, b) = boxes
    assert not (a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]), boxes

    # a second view over the server's placeholder (rev 0, empty): "drawing …" until a scene is up
    busy = "n => getComputedStyle(document.querySelector(`[data-cv='${n}'] .cmm-cv-busy`)).display"
    page.evaluate(SET_STATE, ["cv_more", scene_state([], CAMERA, rev=0)])
    page.evaluate(
        "() => { const d = document.createElement('div'); d.className = 'cmm-cloudview';"
        " d.setAttribute('data-cv', 'cv_more'); d.style.width = '200px'; d.style.height = '150px';"
        " document.body.appendChild(d); }"
    )
    page.wait_for_selector("[data-cv='cv_more'] .cmm-cv-busy", state="attached")
    page.wait_for_timeout(300)
    assert page.evaluate(busy, "cv_more") != "none"
    assert "drawing" in page.inner_text("[data-cv='cv_more'] .cmm-cv-busy")
    page.evaluate(SET_STATE, ["cv_more", scene_state([bar], CAMERA, rev=1)])
    page.wait_for_function(READY, arg="cv_more", timeout=10_000)
    assert page.evaluate(busy, "cv_more") == "none"
    assert page.evaluate(busy, NAME) == "none"

    # resized: after the next frame the canvas has the element's size (the picture not stretched)
    got = page.evaluate(
        """() => new Promise(done => {
          const host = document.querySelector("[data-cv='cv_more']");
          host.style.width = '260px'; host.style.height = '120px';
          requestAnimationFrame(() => requestAnimationFrame(() => {
            const c = host.querySelector('canvas');
            done([c.width, c.height, host.clientWidth, host.clientHeight]);
          }));
        })"""
    )
    assert got == [260, 120, 260, 120], got
