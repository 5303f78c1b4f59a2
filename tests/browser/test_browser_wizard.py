"""The acceptance-test wizard end to end in headless Chromium, driven by Playwright.

A full VDI/VDE 2634 part-2 test: setup (system, MPEs, artefacts from the catalogue),
then every required position imported through its card's file input, counters and
verdict chips checked; halfway (after 5 sphere positions) the server is KILLED
(SIGKILL), started again on the same project, the page reloaded: the wizard resumes
with the positions already done. The remaining positions, the final verdict, the
Report button and the report's links. Screenshots go to ``$CAMCMM_SCREENSHOTS``
(default ``/tmp/wizard``).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from camcmm.errors import CamcmmError
from camcmm.gui.process import GuiProcess
from helpers.browsing import ARGS, CHROMIUM, MARKS, card, counter, import_file, launch, open_wizard, shots  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
cio = pytest.importorskip("camcmm.io")

from camcmm.host import default_host  # noqa: E402
from helpers.acceptance_data import MPE, write_measurements  # noqa: E402

SHOTS = shots("wizard")
STANDARD = "vdi2634-2"


def _standard():
    try:
        host = default_host()
        if STANDARD not in host.plugins:
            return None
        return host.load(STANDARD)
    except Exception:
        return None


class Server(GuiProcess):
    """The GUI in a subprocess; a failed start fails the test."""

    def __init__(self, project: Path):
        try:
            super().__init__(project)
        except CamcmmError as exc:
            pytest.fail(str(exc))


def test_wizard_full_part2_test_with_a_killed_server(tmp_path):
    std = _standard()
    if std is None:
        pytest.skip(f"the {STANDARD} standard plugin is not installed (yet)")
    files = write_measurements(tmp_path / "meas", std.requirements(None), n=2500)
    bad = tmp_path / "broken.xyz"
    bad.write_text("1 2 3\n4 nan 6\n")
    project = tmp_path / "proj"
    t0 = time.monotonic()
    server = Server(project)
    try:
        with sync_api.sync_playwright() as p:
            ctx = p.chromium.launch_persistent_context(
                str(tmp_path / "chromium-profile"),
                executable_path=CHROMIUM,
                headless=True,
                args=ARGS,
                viewport={"width": 1400, "height": 900},
                accept_downloads=True,
            )
            try:
                page = ctx.new_page()
                page.set_default_timeout(30_000)
                open_wizard(page, server.url)

                # -- 1 setup: standard preselected, catalogue artefacts preselected --------------------
                page.wait_for_selector('[data-testid="wz-artefact-sphere"]')
                # the standard by its name; its plugin id (vdi2634-2) is not shown (issue 30)
                assert "VDI/VDE 2634 part 2" in page.locator('[data-testid="wz-standard"]').inner_text()
                page.locator('[data-testid="wz-system-name"] input').fill("Stereo fringe projection, lab 3")
                for key, value in MPE.items():
                    page.locator(f'[data-testid="wz-mpe-{key}"] input').fill(str(value))
                diameter = page.locator('[data-testid="wz-field-sphere-diameter"] input').input_value()
                assert float(diameter) == pytest.approx(20.001)
                page.locator('[data-testid="wz-field-sphere-uncertainty"] input').fill("0.0012")  # own value
                # every field still shows what was typed (a field falling back to its old value on blur
                # would be sent as typed but shown empty)
                assert page.locator('[data-testid="wz-system-name"] input').input_value().startswith("Stereo")
                assert page.locator('[data-testid="wz-mpe-PF"] input').input_value() == str(MPE["PF"])
                page.screenshot(path=str(SHOTS / "wizard-1-setup.png"))
                page.locator('[data-testid="wz-start"]').click()

                # -- 2 positions -------------------------------------------------------------------
                page.wait_for_selector('[data-testid="wz-positions"]')
                assert counter(page, "sphere") == "0 of 10 sphere positions"
                assert page.locator('[data-testid^="card-sphere-"]').count() == 10
                assert page.locator('[data-testid^="card-ball-bar-"]').count() == 7
                assert page.locator('[data-testid^="card-flat-"]').count() == 6
                assert card(page, "sphere-01").locator("svg").count() == 1  # the pictogram
                page.screenshot(path=str(SHOTS / "wizard-2-positions.png"))

                for i, (pos, path) in enumerate(files["sphere"][:5]):
                    import_file(page, "sphere", pos, path)
                    page.wait_for_selector(f'[data-testid="wz-counter-sphere"]:has-text("{i + 1} of 10")')
                    chip = card(page, pos).locator('[data-testid="card-verdict"]')
                    assert chip.inner_text().strip().lower() == "pass"
                page.wait_for_selector('[data-testid="legend-title"]:has-text("deviation")')  # unit: the number rule
                assert "P_F" in card(page, "sphere-01").inner_text()
                # a bad file: that card says why, the others stay
                import_file(page, "sphere", "sphere-06", bad, expect="error")
                assert "broken.xyz" in card(page, "sphere-06").locator('[data-testid="card-error"]').inner_text()
                assert counter(page, "sphere") == "5 of 10 sphere positions"
                time.sleep(0.5)
                page.screenshot(path=str(SHOTS / "wizard-3-five-spheres.png"))
            finally:
                ctx.close()

        # -- the crash: kill the server halfway, start it again on the same project -------------------
        server.kill()
        from camcmm.project import Project

        with Project.open(project) as proj:  # the edited sphere was kept as the lab's own artefact
            own = {a.id: a for a in proj.artefacts()}
            assert own["sphere-20-own"].certificates["diameter"].expanded_uncertainty == pytest.approx(0.0012)
            assert "ballbar-50" in own
        server = Server(project)
        with sync_api.sync_playwright() as p:
            ctx = p.chromium.launch_persistent_context(
                str(tmp_path / "chromium-profile"),
                executable_path=CHROMIUM,
                headless=True,
                args=ARGS,
                viewport={"width": 1400, "height": 900},
                accept_downloads=True,
            )
            try:
                page = ctx.new_page()
                page.set_default_timeout(30_000)
                open_wizard(page, server.url)
                page.wait_for_selector('[data-testid="wz-positions"]')  # resumed on the positions
                assert counter(page, "sphere") == "5 of 10 sphere positions"
                assert counter(page, "ball_bar") == "0 of 7 ball bar orientations"
                done = [
                    page.locator(f'[data-testid="card-sphere-{i:02d}"]').get_attribute("data-status")
                    for i in range(1, 11)
                ]
                assert done == ["done"] * 5 + ["error"] + ["pending"] * 4
                assert "broken.xyz" in card(page, "sphere-06").inner_text()  # the reason survived too
                page.screenshot(path=str(SHOTS / "wizard-4-resumed.png"))

                for pos, path in files["sphere"][5:]:
                    import_file(page, "sphere", pos, path)
                page.wait_for_selector('[data-testid="wz-counter-sphere"]:has-text("10 of 10")')
                # redo a position: Redo offers the file input again, the new file replaces the old
                card(page, "sphere-02").locator('[data-testid="card-redo"]').click()
                redo_file = tmp_path / "sphere-02-again.ply"
                redo_file.write_bytes(files["sphere"][1][1].read_bytes())
                page.locator(
                    '[data-testid="card-sphere-02"] [data-testid="card-file"] input[type="file"]'
                ).set_input_files(str(redo_file))
                page.wait_for_selector('[data-testid="wz-detail"]:has-text("sphere-02-again.ply")')
                assert card(page, "sphere-02").get_attribute("data-status") == "done"
                assert counter(page, "sphere") == "10 of 10 sphere positions"
                for test in ("ball_bar", "flat"):
                    for pos, path in files[test]:
                        import_file(page, test, pos, path)
                assert counter(page, "ball_bar") == "7 of 7 ball bar orientations"
                assert counter(page, "flat") == "6 of 6 flat orientations"
                page.locator('[data-testid="wz-block-ball_bar"]').scroll_into_view_if_needed()
                time.sleep(0.5)
                page.screenshot(path=str(SHOTS / "wizard-5-ball-bars.png"))
                page.locator('[data-testid="wz-block-flat"]').scroll_into_view_if_needed()
                time.sleep(0.3)
                page.screenshot(path=str(SHOTS / "wizard-6-flats.png"))

                # -- 3 result and the report -------------------------------------------------------------
                page.locator('[data-testid="wz-goto-result"]').click()
                verdict = page.locator('[data-testid="wz-verdict"]')
                verdict.wait_for()
                assert verdict.inner_text().strip() == "PASS"
                assert page.locator('[data-testid^="wz-param-"]').count() == 4
                page.locator('[data-testid="wz-report"]').click()
                link = page.locator('[data-testid="wz-report-html"]')
                link.wait_for(timeout=60_000)
                href = link.get_attribute("href")
                resp = page.request.get(server.base + href.lstrip("/"))
                assert resp.ok and "VDI/VDE 2634" in resp.text()
                with page.expect_download() as dl:
                    page.locator('[data-testid="wz-report-pdf"]').click()
                pdf = Path(dl.value.path())
                assert dl.value.suggested_filename.endswith(".pdf") and pdf.read_bytes()[:5] == b"%PDF-"
                with page.expect_popup() as popup:
                    link.click()
                popup.value.wait_for_load_state()
                assert "VDI/VDE 2634" in popup.value.content()
                popup.value.screenshot(path=str(SHOTS / "wizard-8-report.png"))
                page.screenshot(path=str(SHOTS / "wizard-7-result.png"))
            finally:
                ctx.close()
    finally:
        server.stop()
    assert time.monotonic() - t0 < 180  # about 40 s on an idle machine; generous for a loaded CI


@pytest.fixture(scope="module")
def served_demo(tmp_path_factory, demo_project):
    """(server, summary) of a copy of the demo project (its finished part-2 test) served
    once for the tests below, which run in this order: the demo's result, then a new test
    over it (which changes the project)."""
    host = default_host()
    if _standard() is None or "virtuallab.acceptance-set" not in host.plugins:
        pytest.skip("the demo's acceptance test needs the vdi2634-2 and virtual-lab plugins")
    from camcmm.demo import create_demo

    folder = tmp_path_factory.mktemp("served-demo") / "demo"
    demo_project(folder)  # a copy of the demo built once; create_demo re-opens it
    summary = create_demo(folder)
    server = Server(folder)
    try:
        yield server, summary
    finally:
        server.stop()


def test_demo_project_opens_with_a_finished_test(served_demo):
    server, summary = served_demo
    verdict = summary["acceptance"]["verdict"]
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.set_default_timeout(30_000)
            open_wizard(page, server.url)
            chip = page.locator('[data-testid="wz-verdict"]')  # opens on the result
            chip.wait_for()
            assert chip.inner_text().strip() == verdict.upper()
            assert page.locator('[data-testid="wz-report-html"]').count() == 1
            page.screenshot(path=str(SHOTS / "wizard-demo-result.png"))
            page.locator('[data-testid="wz-tab-positions"]').click()
            page.wait_for_selector('[data-testid="wz-counter-sphere"]:has-text("10 of 10 sphere positions")')
            assert counter(page, "ball_bar") == "7 of 7 ball bar orientations"
            assert counter(page, "flat") == "6 of 6 flat orientations"
            assert page.locator('[data-status="done"]').count() == 23
            card(page, "flat-03").locator('[data-testid="card-show"]').click()
            page.wait_for_selector('[data-testid="wz-detail"]:has-text("flat-03")')
            page.wait_for_selector('[data-testid="legend-title"]:has-text("deviation")')  # unit: the number rule
            time.sleep(1.0)
            page.screenshot(path=str(SHOTS / "wizard-demo-positions.png"))
        finally:
            browser.close()


def test_a_new_test_over_the_finished_one_asks_and_both_tabs_follow(served_demo):
    """Issue 30: "Set up a new test" over the demo's finished test asks first, naming it and
    its verdict and where it stays; after Start in tab A, tab B (its own session) names
    the same current test, without a reload; the results list names the old report."""
    server, summary = served_demo
    verdict = summary["acceptance"]["verdict"]
    words = {"pass": "passed", "fail": "failed"}.get(verdict, verdict)
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            tabs = []
            for _ in range(2):
                tab = browser.new_page(viewport={"width": 1366, "height": 768})
                tab.set_default_timeout(30_000)
                open_wizard(tab, server.url)
                tab.locator('[data-testid="wz-tab-setup"]').click()
                tabs.append(tab)
            a, b = tabs
            old = a.locator('[data-testid="wz-test-name"]').inner_text().strip()
            assert old.startswith("Current test: VDI/VDE 2634 part 2 — ") and ", started " in old
            assert b.locator('[data-testid="wz-test-name"]').inner_text().strip() == old
            a.locator('[data-testid="wz-unlock"]').click()
            dialog = a.locator('[data-testid="wz-supersede"]')
            dialog.wait_for()
            text = dialog.inner_text()
            assert old.removeprefix("Current test: ") in text and f"finished: {words}" in text
            assert "result #" in text and "results list" in text  # where the old one stays findable
            a.screenshot(path=str(SHOTS / "wizard-supersede-1366.png"))
            a.locator('[data-testid="wz-supersede-confirm"]').click()
            dialog.wait_for(state="detached")
            field = a.locator('[data-testid="wz-system-name"] input')
            field.fill("Second scanner")
            field.press("Tab")
            a.locator('[data-testid="wz-start"]').click()
            a.wait_for_selector('[data-testid="wz-counter-sphere"]:has-text("0 of 10 sphere positions")')
            # tab B follows the project (no reload): the same current test, the old one listed as earlier
            b.wait_for_selector('[data-testid="wz-test-name"]:has-text("Second scanner")', timeout=15_000)
            a.locator('[data-testid="wz-tab-setup"]').click()
            name_a = a.locator('[data-testid="wz-test-name"]').inner_text().strip()
            assert b.locator('[data-testid="wz-test-name"]').inner_text().strip() == name_a
            assert b.locator('[data-testid="wz-test-status"]').inner_text().startswith("running")
            assert a.locator('[data-testid="wz-test-status"]').inner_text().startswith("running")
            assert b.locator('[data-testid="wz-earlier"]').count() == 1
            b.screenshot(path=str(SHOTS / "wizard-second-tab-1366.png"))
        finally:
            browser.close()
