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
        server = GuiProcess(folder, timeout=120)
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
