"""The shell in Chromium on ``camcmm demo`` (issue 15's Done-when: "a screenshot test at
1366×768 checks that no toolbar text is clipped"), and its keyboard shortcuts.

For every page at 1366×768 and 1600×1000: every element of the toolbar shows all of its
text (scrollWidth <= clientWidth + 1; only the project name may truncate, with its full
name in a tooltip), the toolbar's parts lie inside the window, a page title is shown
whole or not at all (icon and tooltip stay), and the footer is camcmm's own. The
screenshots go to ``shots("layout")``.
"""

from __future__ import annotations

import time

import pytest

from helpers.browsing import MARKS, choose, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SHOTS = shots("layout")
SIZES = [(1366, 768), (1600, 1000)]

# Everything wrong with the toolbar, as a list of lines (empty: it fits).
TOOLBAR_PROBLEMS = """() => {
  const bar = document.querySelector('[data-testid="toolbar"]') || document.querySelector('.v-app-bar');
  if (!bar) return ['no toolbar'];
  const shown = el => el.checkVisibility({checkOpacity: true, checkVisibilityCSS: true});
  const name = el => (el.getAttribute('data-testid') || el.className || el.tagName).toString().slice(0, 60)
    + ' "' + (el.textContent || '').trim().slice(0, 40) + '"';
  const out = [];
  const project = bar.querySelector('[data-testid="project-name"]');
  for (const el of [bar, ...bar.querySelectorAll('*')]) {
    if (!shown(el) || el.closest('.v-overlay') || el.tagName === 'svg' || el.closest('svg')) continue;
    if (el === project) continue;  // may truncate: its box carries the full name as a tooltip
    if (el.clientWidth > 0 && el.scrollWidth > el.clientWidth + 1)
      out.push('clipped: ' + name(el) + ' ' + el.scrollWidth + ' > ' + el.clientWidth);
  }
  const content = bar.querySelector('.v-toolbar__content') || bar;
  const r0 = bar.getBoundingClientRect();
  const buttons = bar.querySelectorAll('[data-testid="page-switch"] [data-testid^="page-"]');
  for (const el of [...content.children, ...buttons]) {
    if (!shown(el)) continue;
    const r = el.getBoundingClientRect();
    if (r.width === 0) continue;
    if (r.left < -0.5 || r.right > window.innerWidth + 0.5 || r.top < r0.top - 0.5 || r.bottom > r0.bottom + 0.5)
      out.push('outside: ' + name(el) + ' ' + JSON.stringify([r.left, r.right, r.top, r.bottom]));
  }
  for (const t of bar.querySelectorAll('.cmm-page-title')) {
    if (!shown(t)) continue;  // titles hidden as a whole when there is no room
    const s = getComputedStyle(t);
    if (t.scrollWidth > t.clientWidth + 1 || s.textOverflow === 'ellipsis')
      out.push('page title cut: ' + t.textContent.trim());
  }
  for (const b of buttons) {
    const title = b.querySelector('.cmm-page-title');
    if (!title || !shown(title)) {
      // icon only: the icon shows and the tooltip/aria-label names the page
      if (!b.querySelector('.v-icon') || !b.getAttribute('aria-label')) out.push('unnamed icon: ' + name(b));
    }
  }
  const box = project && project.closest('[title]');
  if (!project || !box || !box.getAttribute('title').includes(project.textContent.trim()))
    out.push('project name without its tooltip');
  return out;
}"""


@pytest.fixture(scope="module")
def demo(tmp_path_factory, demo_project):
    """The demo project and its GUI (one for the module: building the demo takes ~20 s)."""
    from camcmm.errors import CamcmmError
    from camcmm.gui.process import GuiProcess

    folder = tmp_path_factory.mktemp("layout") / "demo"
    try:
        demo_project(folder)
    except CamcmmError as exc:
        pytest.skip(f"the demo needs its plugins: {exc}")
    try:
        # a browser per test, a session each (closed 300 s after its tab): more than the default 4
        server = GuiProcess(folder, timeout=120, args=("--max-sessions", "8"))
    except CamcmmError as exc:
        pytest.fail(str(exc))
    yield server
    server.stop()
    # behind the session launcher a browser closing mid-update leaves the proxy's websocket
    # write failing ("closing transport"): the browser went away, not a fault of the shell
    faults = [t for t in server_tracebacks(server.log) if "_websocket" not in t and "closing transport" not in t]
    assert not faults, faults


def _open(browser, url, size):
    page = browser.new_page(viewport={"width": size[0], "height": size[1]})
    page.set_default_timeout(60_000)
    page.goto(url)
    page.wait_for_selector('[data-testid="page-switch"] [data-testid^="page-"]', timeout=120_000)
    page.wait_for_function("document.fonts.status === 'loaded'")
    return page


def _keys(page) -> list[str]:
    return page.eval_on_selector_all(
        '[data-testid="page-switch"] [data-testid^="page-"]', "els => els.map(e => e.dataset.testid.slice(5))"
    )


def _settle(page) -> None:
    page.mouse.move(2, page.viewport_size["height"] // 2)  # no tooltip over the toolbar in the picture
    page.evaluate("window.camcmmShell && window.camcmmShell.fit()")
    time.sleep(0.6)


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_no_toolbar_text_is_clipped_on_any_page(demo, size):
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = _open(browser, demo.url, size)
            keys = _keys(page)
            assert len(keys) >= 6, keys
            for key in keys:
                page.click(f'[data-testid="page-{key}"]')
                page.wait_for_function(
                    f"document.querySelector('[data-testid=\"page-{key}\"]').classList.contains('v-btn--active')"
                )
                _settle(page)
                page.screenshot(path=str(SHOTS / f"layout-{size[0]}x{size[1]}-{key}.png"))
                problems = page.evaluate(TOOLBAR_PROBLEMS)
                assert not problems, (key, size, problems)
                # the Inspect page's plugin panel is its own (it once showed on Acceptance too)
                assert page.locator('[data-testid="plugin-panel"]').is_visible() == (key == "inspect"), key
            # the import box shows its label whole, the footer is camcmm's own
            label = page.locator('[data-testid="import-file"] .v-label').first
            assert label.evaluate("el => el.scrollWidth <= el.clientWidth + 1"), label.inner_text()
            footer = page.locator('[data-testid="footer"]')
            assert "camcmm" in footer.locator('[data-testid="footer-version"]').inner_text()
            assert "connected" in footer.inner_text()
            assert "trame" not in footer.inner_text().lower() and "Kitware" not in footer.inner_text()
        finally:
            browser.close()


def test_the_stage_position_is_in_the_device_panel_unclipped(demo):
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = _open(browser, demo.url, SIZES[0])
            page.click('[data-testid="page-devices"]')
            choose(page, "dev-add-plugin", "Simulated stage (in process)")
            page.click('[data-testid="dev-add"]')
            page.wait_for_selector('[data-testid="dev-home"]')
            page.click('[data-testid="dev-home"]')
            readout = page.locator('[data-testid="dev-position"]')
            readout.wait_for()
            page.wait_for_function(
                "(document.querySelector('[data-testid=\"dev-position\"]') || {}).textContent?.includes('mm')"
            )
            assert readout.evaluate("el => el.scrollWidth <= el.clientWidth + 1"), readout.inner_text()
            box = readout.bounding_box()
            assert box and box["x"] >= 0 and box["x"] + box["width"] <= SIZES[0][0]
            _settle(page)
            page.screenshot(path=str(SHOTS / "layout-devices-stage.png"))
        finally:
            browser.close()


def test_keyboard_shortcuts(demo):
    """Alt+2 switches page; Ctrl+Enter clicks the page's run element; a single key clicks
    its element, except while typing in a text field; ? lists them."""
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = _open(browser, demo.url, SIZES[1])
            keys = _keys(page)
            page.click('[data-testid="page-devices"]')
            page.keyboard.press("Alt+2")
            page.wait_for_function(
                f"document.querySelector('[data-testid=\"page-{keys[1]}\"]').classList.contains('v-btn--active')"
            )
            page.keyboard.press("Alt+1")
            page.wait_for_function(
                f"document.querySelector('[data-testid=\"page-{keys[0]}\"]').classList.contains('v-btn--active')"
            )
            # elements of the contract (pages add such attributes to their own controls)
            page.evaluate(
                """() => {
                  window.hits = {run: 0, q: 0, 7: 0};
                  const add = (attr, value, what) => {
                    const b = document.createElement('button');
                    b.setAttribute(attr, value);
                    b.textContent = what;
                    b.addEventListener('click', () => window.hits[what] += 1);
                    document.querySelector('[data-testid="footer"]').appendChild(b);
                  };
                  add('data-shortcut', 'run', 'run');
                  add('data-shortcut-key', 'q', 'q');
                  add('data-shortcut-key', '7', '7');
                }"""
            )
            page.locator("body").click(position={"x": 700, "y": 500})
            page.keyboard.press("q")
            page.keyboard.press("Control+Enter")
            assert page.evaluate("window.hits") == {"run": 1, "q": 1, "7": 0}
            # typing in a field (Compare's tolerance, a number): the key is the field's, no shortcut
            page.click('[data-testid="page-compare"]')
            field = page.locator('[data-testid="ins-tolerance"] input')
            field.click()
            field.press("7")
            assert field.input_value() == "7"
            assert page.evaluate("window.hits") == {"run": 1, "q": 1, "7": 0}
            page.locator("body").click(position={"x": 700, "y": 500})
            page.keyboard.press("7")  # the same key outside the field is the shortcut
            assert page.evaluate("window.hits['7']") == 1
            page.keyboard.press("Alt+1")  # the page keys still work from a field
            page.wait_for_function(
                f"document.querySelector('[data-testid=\"page-{keys[0]}\"]').classList.contains('v-btn--active')"
            )
            # ? shows the list, Esc closes it
            page.locator("body").click(position={"x": 700, "y": 500})
            page.keyboard.press("?")
            help_ = page.locator('[data-testid="shortcut-help"]')
            help_.wait_for()
            text = help_.inner_text()
            assert "Alt+1" in text and "Ctrl+Enter" in text and "q" in text
            _settle(page)
            page.screenshot(path=str(SHOTS / "layout-shortcuts-help.png"))
            page.keyboard.press("Escape")
            help_.wait_for(state="detached")
            page.click('[data-testid="shortcut-help-open"]')  # the toolbar's keyboard button opens it too
            help_.wait_for()
            page.click('[data-testid="shortcut-help-close"]')
            help_.wait_for(state="detached")
        finally:
            browser.close()


# Boxes on the page that must not intersect: each chart's title and notes (plotly annotations),
# the pick labels' texts in the Compare view. [left, top, right, bottom] in px, with the text.
CHART_BOXES = """(testid) => {
  const chart = document.querySelector(`[data-testid="${testid}"]`);
  const box = el => {
    const r = el.getBoundingClientRect();
    return [r.left, r.top, r.right, r.bottom, el.textContent.trim()];
  };
  return {chart: box(chart), parts: [...chart.querySelectorAll('.annotation-text-g, .gtitle')].map(box)
    .filter(b => b[2] > b[0])};
}"""
LABEL_BOXES = """() => [...document.querySelectorAll('[data-testid="ins-view"] .cmm-cv-label')]
  .filter(l => l.style.display !== 'none')
  .map(l => {
    const r = l.querySelector('.cmm-cv-text').getBoundingClientRect();
    return [r.left, r.top, r.right, r.bottom, l.textContent];
  })"""
# the canvas of each 3-D view shown (browser and server rendering): its pixels and its box
CANVASES = """() => [...document.querySelectorAll('[data-testid="ins-view"] canvas, .cmm-cv-host > canvas')]
  .filter(c => c.getBoundingClientRect().width > 0)
  .map(c => { const r = c.getBoundingClientRect(); return [c.width, c.height, r.width, r.height]; })"""
# where the browser's view draws the scene's points (a sample, via its own projection) and where
# its colour legend lies: [max x of the points, the legend's left edge] in the view's px
FRAMED = """(name) => {
  const v = window.camcmmCloudView.views[name];
  const m = v.mvp(), W = v.W;
  let right = -Infinity;
  for (const l of v.layers) {
    if (l.spec.kind !== 'points') continue;
    const step = Math.max(1, Math.floor(l.n / 5000));
    for (let i = 0; i < l.n; i += step) {
      const x = l.pos[3 * i] + v.origin[0], y = l.pos[3 * i + 1] + v.origin[1], z = l.pos[3 * i + 2] + v.origin[2];
      const cx = m[0] * x + m[4] * y + m[8] * z + m[12], cw = m[3] * x + m[7] * y + m[11] * z + m[15];
      right = Math.max(right, (cx / cw + 1) * W / 2);
    }
  }
  const legend = v.legendBox;
  return [right, legend.style.display === 'none' ? null : legend.offsetLeft, W];
}"""


def _overlaps(boxes: list) -> list:
    """The pairs of boxes [l, t, r, b, text] that intersect."""
    out = []
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            if a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]:
                out.append((a[4], b[4]))
    return out


def _check_compare(page, size) -> None:
    """The Compare page after a run at ``size``: the view's share of the window, the charts'
    annotations apart and inside their charts, the canvases' aspect that of their boxes."""
    w, h = size
    view = page.locator('[data-testid="ins-view"]').bounding_box()
    # 540×300 px at 1366×768 before issue 30 (0.40 × 0.39 of the window)
    assert view["width"] >= 0.44 * w and view["height"] >= 0.6 * h, (size, view)
    for testid in ("ins-histogram", "ins-af"):
        got = page.evaluate(CHART_BOXES, testid)
        assert len(got["parts"]) >= 2, (testid, got)
        assert not _overlaps(got["parts"]), (size, testid, _overlaps(got["parts"]))
        c = got["chart"]
        for p in got["parts"]:  # nothing cut at the chart's edges
            assert p[0] >= c[0] - 1 and p[2] <= c[2] + 1 and p[1] >= c[1] - 1, (size, testid, p, c)
    stats = page.locator('[data-testid="ins-stats"] table')
    assert stats.evaluate("t => t.scrollWidth <= t.parentElement.clientWidth + 1"), size  # values whole
    for cw, ch, bw, bh in page.evaluate(CANVASES):  # the picture is not stretched by its box
        assert abs(cw / ch - bw / bh) <= 0.01 * bw / bh, (size, cw, ch, bw, bh)


def test_compare_page_layout_first_paint_and_labels(demo):
    """Issue 30's layout at 1366×768 and 1600×1000 (the same page, resized): the first 3-D
    paint shows "drawing …" until it is up; the ball bar is framed left of its colour legend;
    on Compare the view gets ≥ 44 % × 60 % of the window, the charts' titles and notes do not
    collide, a section axis click shows at once and cuts, two picks close together get labels
    that do not overlap, and after each resize every canvas has its box's aspect."""
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": SIZES[0][0], "height": SIZES[0][1]})
            page.set_default_timeout(60_000)
            # whether the spinner was on screen while the view had drawn nothing, every frame
            page.add_init_script(
                """window.__busy = {shown: 0, shownWhileDrawn: 0};
                (function poll() {
                  for (const b of document.querySelectorAll('.cmm-cv-busy')) {
                    if (b.style.display === 'none' || !b.parentElement.clientWidth) continue;
                    const v = b.parentElement.__cmmCloudView;
                    if (v && v.painted) window.__busy.shownWhileDrawn += 1; else window.__busy.shown += 1;
                  }
                  requestAnimationFrame(poll);
                })();"""
            )
            page.goto(demo.url)
            page.wait_for_selector('[data-testid="page-switch"] [data-testid^="page-"]', timeout=120_000)
            page.wait_for_function(
                "() => { const v = window.camcmmCloudView && window.camcmmCloudView.views.cv_inspect;"
                " return v && v.painted && v.stats().points_drawn > 0; }"
            )
            busy = page.evaluate("window.__busy")
            assert busy["shown"] > 0 and busy["shownWhileDrawn"] == 0, busy
            assert not page.locator('[data-testid="ins-view"] [data-testid="cloudview-busy"]:visible').count()
            # the ball bar (it opened clipped under its colour legend): its points left of the legend
            rev = page.evaluate("window.camcmmCloudView.views.cv_inspect.spec.rev")
            page.locator('[data-testid="item"]', has_text="ball bar").first.click()
            page.wait_for_function(
                "r => { const v = window.camcmmCloudView.views.cv_inspect; return v.spec.rev !== r"
                " && v.spec.legend && v.pendingRev === null && v.layers.some(l => l.n >= 50000); }",
                arg=rev,
            )
            right, legend, _ = page.evaluate(FRAMED, "cv_inspect")
            assert legend is not None and right < legend, (right, legend)
            _settle(page)
            page.screenshot(path=str(SHOTS / "layout-1366x768-ball-bar.png"))

            # the inputs chosen at 1600×1000 (the nominal select's list is longer than 768 px
            # shows), checked there, then at 1366×768: both resizes of a page that has a result
            page.set_viewport_size({"width": SIZES[1][0], "height": SIZES[1][1]})
            page.click('[data-testid="page-compare"]')
            for testid, option in (
                ("ins-measured", "sphere scan (20 mm ball)"),
                ("ins-nominal", "sphere nominal (CAD)"),
            ):
                page.click(f'[data-testid="{testid}"]')
                page.locator(".v-overlay--active .v-list-item", has_text=option).first.click()
                # shown once the server took it (it draws the inputs first: slow on a busy machine)
                page.locator(f'[data-testid="{testid}"]', has_text=option).first.wait_for(timeout=60_000)
            page.click('[data-testid="ins-run"]')
            page.wait_for_selector('[data-testid="ins-progress"]:has-text("done")', timeout=120_000)
            page.wait_for_selector('[data-testid="ins-af"] .annotation-text-g', state="attached")
            page.wait_for_function(  # the colour map drawn (the inputs come first)
                "() => { const v = window.camcmmCloudView.views.cv_compare;"
                " return v.spec && v.spec.legend && v.pendingRev === null && v.stats().points_drawn > 0; }"
            )
            right, legend, width = page.evaluate(FRAMED, "cv_compare")
            assert legend is not None and right < legend, (right, legend, width)
            _check_compare(page, SIZES[1])
            _settle(page)
            page.screenshot(path=str(SHOTS / "layout-1600x1000-compare.png"))

            page.set_viewport_size({"width": SIZES[0][0], "height": SIZES[0][1]})
            page.wait_for_function(
                "() => { const v = window.camcmmCloudView.views.cv_compare;"
                " return v.W === v.el.clientWidth && v.canvas.width === v.W && v.el.clientWidth < 700; }"
            )
            time.sleep(1.0)  # plotly redraws its charts for their new width
            _check_compare(page, SIZES[0])
            right, legend, width = page.evaluate(FRAMED, "cv_compare")
            assert legend is not None and right < legend, (right, legend, width)

            # a section axis: shown at once (no round trip), then cut
            page.click('[data-testid="ins-section-x"]')
            assert "v-btn--active" in page.locator('[data-testid="ins-section-x"]').get_attribute("class")
            page.wait_for_function(
                "() => (document.querySelector('[data-testid=\"ins-section\"] .gtitle') || {}).textContent"
                "?.startsWith('Section x')",
                timeout=20_000,
            )

            # two picks 10 px apart on the sphere: two labels, apart
            box = page.locator('[data-testid="ins-view"] .cmm-cv-canvas').last.bounding_box()
            cx, cy = box["x"] + 0.4 * box["width"], box["y"] + 0.5 * box["height"]
            for dx in (0, 10):
                n = len(page.evaluate(LABEL_BOXES))
                page.mouse.click(cx + dx, cy)
                page.wait_for_function(f"() => ({LABEL_BOXES})().length > {n}", timeout=15_000)
            labels = page.evaluate(LABEL_BOXES)
            assert len(labels) >= 2 and not _overlaps(labels), labels
            _settle(page)
            page.screenshot(path=str(SHOTS / "layout-1366x768-compare.png"))
        finally:
            browser.close()
