"""The toolbar's server-path import dialog and the unit question: every button and field
has a tooltip, and a field's covers its label and value, not only the bare <input>
Vuetify puts a field's ``title`` on (issue 15)."""

from __future__ import annotations

import os
import re

import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
pytest.importorskip("trame")

CONTROLS = re.compile(r"<(VBtn|VTextField|VSelect|VRadio)\b[^>]*>")


def _part(html: str, start: str, end: str) -> str:
    i = html.index(start)
    return html[i : html.index(end, i)]


@pytest.mark.slow
def test_dialog_controls_have_titles(gui_app):
    server, _ = gui_app()
    html = server.state.trame__template_main
    parts = {
        "path": _part(html, 'data-testid="path-dialog"', "</VDialog>"),
        "unit": _part(html, 'data-testid="unit-dialog"', "</VDialog>"),
    }
    for name, part in parts.items():
        controls = list(CONTROLS.finditer(part))
        assert len(controls) >= 2, name
        for m in controls:
            assert re.search(r"\s:?title=", m.group(0)), (name, m.group(0))
            if m.group(1) != "VBtn":  # the wrapping element's title covers label and value
                opened = part[: m.start()].rstrip().rsplit("<div", 1)[-1]
                assert re.match(r"[^>]*\s:?title=", opened), (name, m.group(0))
    opener = re.search(r'<VBtn[^>]*data-testid="open-path-dialog"[^>]*>', html)
    assert opener and " title=" in opener.group(0)
