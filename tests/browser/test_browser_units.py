"""Units at import in a real headless Chromium (issue 15: "a metre file asked and converted").

A block of 60 × 40 × 20 mm written in metres in an .xyz file with no unit comment is
imported through the toolbar's file input: the app does not read it as mm (a 0.075 mm
part) but asks, listing the candidate units with the size each gives and the suggestion
(m) preselected; nothing is stored before the answer; "Import in m" stores it and the
item shows its size in mm. Then the upload's unit field (the ruler menu) set to m: the
next metre file is read in m without a question. Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default
``/tmp/units-gui``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from helpers.browsing import MARKS, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SHOTS = shots("units-gui")


def block_in_metres(path: Path) -> Path:
    """Points on the faces of a 60 × 40 × 20 mm block, written in metres, no unit stated."""
    g = np.linspace(0.0, 1.0, 11)
    u, v = (a.ravel() for a in np.meshgrid(g, g))
    faces = []
    for axis in range(3):
        for side in (0.0, 1.0):
            p = np.empty((u.size, 3))
            p[:, axis] = side
            p[:, (axis + 1) % 3], p[:, (axis + 2) % 3] = u, v
            faces.append(p)
    pts = np.unique(np.vstack(faces), axis=0) * np.array([0.060, 0.040, 0.020])
    path.write_text("".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in pts.tolist()))
    return path


def test_a_metre_file_is_asked_and_converted(gui_server, tmp_path):
    url, log = gui_server
    f = block_in_metres(tmp_path / "block_m.xyz")
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.set_default_timeout(30_000)
            page.goto(url)
            page.wait_for_selector('[data-testid="project-name"]', timeout=120_000)
            page.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(f))

            dialog = page.wait_for_selector('[data-testid="unit-dialog"]', state="visible", timeout=60_000)
            reason = page.locator('[data-testid="unit-reason"]').inner_text()
            assert "block_m.xyz has no unit" in reason and "too small" in reason, reason
            assert "in m: 60 × 40 × 20 mm" in reason, reason
            text = dialog.inner_text()
            for label in ("m (→ 60 × 40 × 20 mm)", "cm (→ 0.6 × 0.4 × 0.2 mm)", "µm", "in (→"):
                assert label in text, text
            # the suggestion is preselected; nothing is stored yet
            assert page.locator('[data-testid="unit-choice-m"] input').is_checked()
            assert page.locator('[data-testid="item"]').count() == 0
            page.screenshot(path=str(SHOTS / "unit-dialog.png"))
            # choose m (click it, as a user would) and import
            page.locator('[data-testid="unit-choice-m"] input').click()
            assert "Import in m" in page.locator('[data-testid="unit-accept"]').text_content()
            page.locator('[data-testid="unit-accept"]').click()

            item = page.wait_for_selector('[data-testid="item"]:has-text("block_m.xyz")', timeout=60_000)
            assert "60 × 40 × 20 mm" in item.inner_text(), item.inner_text()
            page.wait_for_selector('[data-testid="unit-dialog"]', state="hidden")
            page.screenshot(path=str(SHOTS / "imported-in-m.png"))

            # the upload's unit field: told "m" first, the next file is not asked about
            page.locator('[data-testid="import-unit"]').click()
            page.locator('.v-overlay--active [data-testid="import-unit-m"]').click()
            g = block_in_metres(tmp_path / "block_told.xyz")
            page.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(g))
            item = page.wait_for_selector('[data-testid="item"]:has-text("block_told.xyz")', timeout=60_000)
            assert "60 × 40 × 20 mm" in item.inner_text(), item.inner_text()
            assert not page.locator('[data-testid="unit-dialog"]').is_visible()
        finally:
            browser.close()
    assert not server_tracebacks(log), server_tracebacks(log)[0]
