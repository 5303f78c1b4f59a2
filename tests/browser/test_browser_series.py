"""The Series view end to end in a headless Chromium (issue 28's Done-when: "the Series
view runs a batch in the browser").

A fresh project holds four simulated parts as files and their plan (helpers/series_parts.py:
sphere caps whose diameters are constructed to conform, conform, lie on the upper limit —
undecided — and be out of tolerance). On the Series page the plan file and the four files
are entered, Run: the parts × characteristics table shows every cell in its verdict's
colour as constructed; a click on a cell shows that part's labels and the
characteristic's run chart with its tolerance limits, mean and control limits, Cp/Cpk
with their intervals beside it. Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default
``/tmp/series``).
"""

from __future__ import annotations

import time

import pytest

from helpers import series_parts as sp
from helpers.browsing import MARKS, launch, server_tracebacks, shots

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SHOTS = shots("series")
#: the verdict colours of camcmm.tasks.gdt.VERDICT_COLOURS as the browser writes them
RGB = {"conform": "rgb(26, 152, 80)", "undecided": "rgb(249, 168, 37)", "not conform": "rgb(215, 48, 31)"}


@pytest.fixture
def series_server(tmp_path):
    from camcmm.gui.process import GuiProcess
    from camcmm.project import Project

    Project.create(tmp_path / "proj").close()
    sp.write(tmp_path / "proj")  # the plan and the parts inside the project folder (the server's root)
    server = GuiProcess(tmp_path / "proj")
    yield server.url, server.log
    server.stop()


def test_a_series_runs_in_the_browser_with_cells_coloured_by_verdict_and_the_run_chart(series_server):
    url, log = series_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            page.set_default_timeout(20_000)
            page.goto(url)
            page.wait_for_selector('[data-testid="project-name"]', timeout=60_000)
            t0 = time.monotonic()
            page.locator('[data-testid="page-series"]').click()
            page.wait_for_selector('[data-testid="se-empty"]')
            page.locator('[data-testid="se-plan"] input').fill("plan.yaml")
            page.locator('[data-testid="se-files"] textarea').fill("\n".join(f"{n}.xyz" for n in sp.DELTAS))
            page.locator('[data-testid="se-align"]').click()
            page.locator(".v-overlay--active .v-list-item", has_text="None").click()
            page.locator('[data-testid="se-run"]').click()
            try:
                page.wait_for_selector('[data-testid="se-table"]', timeout=60_000)
            except sync_api.TimeoutError:
                page.screenshot(path=str(SHOTS / "timeout.png"))
                err = page.locator('[data-testid="se-error"]')
                raise AssertionError(f"no table: {err.inner_text() if err.count() else 'no error shown'}") from None
            run_s = time.monotonic() - t0

            # every cell in its verdict's colour, as constructed
            for part, verdict in sp.EXPECTED.items():
                cell = page.locator(f'[data-testid="se-cell-{part}-dia-S1"]')
                assert cell.get_attribute("data-verdict") == verdict, part
                assert cell.evaluate("e => getComputedStyle(e).backgroundColor") == RGB[verdict], part
                prof = page.locator(f'[data-testid="se-cell-{part}-prof-S1"]')
                assert prof.get_attribute("data-verdict") == "conform"
            cell = page.locator('[data-testid="se-cell-part4-dia-S1"]').inner_text()
            assert cell.endswith(" mm"), cell  # a size in mm (a zone in µm), as on the Compare page
            value = float(cell.split()[0])
            assert abs(value - 2 * (sp.RADIUS + sp.DELTAS["part4"])) < 1e-3, value

            # a click on part 3's diameter: its labels, the diameter's run chart and capability
            page.locator('[data-testid="se-cell-part3-dia-S1"]').click()
            page.wait_for_function(
                "() => document.querySelector('[data-testid=\"se-part-title\"]').textContent.startsWith('part3')"
            )
            assert "undecided" in page.locator('[data-testid="se-label-dia-S1"]').inner_text()
            chart = page.locator('[data-testid="se-chart"]')
            chart.locator(".main-svg").first.wait_for()
            names = chart.evaluate("e => Array.from(e.querySelectorAll('.legendtext')).map(t => t.textContent)")
            for name in ("value", "upper tolerance limit", "lower tolerance limit", "mean", "upper control limit"):
                assert name in names, names
            assert len(chart.locator(".scatterlayer .trace").first.locator(".point").all()) == 4
            cpk = page.locator('[data-testid="se-cap-cpk"]').inner_text()
            assert "[" in cpk and "]" in cpk, cpk  # Cpk with its interval
            assert page.locator('[data-testid="se-cap-out"]').inner_text().find("part4") >= 0
            assert page.locator('[data-testid="se-cap-undecided"]').inner_text() == "part3"
            labels = page.locator('[data-testid="se-labels"]')
            labels.locator(".main-svg").first.wait_for()
            traces = labels.evaluate("e => e.querySelector('.js-plotly-plot').data.map(t => t.name)")
            assert "the part, aligned" in traces, traces  # the part's cloud under its flags
            assert any("dia-S1: 20.01" in t and "undecided" in t for t in traces), traces
            page.screenshot(path=str(SHOTS / "series.png"))
            elapsed = time.monotonic() - t0
        finally:
            browser.close()
    assert not server_tracebacks(log), server_tracebacks(log)
    assert not [line for line in log if "camcmm GUI error" in line]
    print(f"series in the browser: {elapsed:.1f} s, of which the run {run_s:.1f} s")
