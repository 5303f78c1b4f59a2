"""Height maps as project items (issue 17): stored as X3P (lossless with camcmm's
members), instrument files kept as they came, the GUI's import and its 3D view."""

from __future__ import annotations

import os

import numpy as np
import pytest

from camcmm import api
from camcmm.project import Project

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


def _map():
    rng = np.random.default_rng(3)
    y, x = np.mgrid[0:60, 0:80]
    h = 0.002 * np.sin(x / 7.0) * np.cos(y / 5.0) + 1e-5 * rng.normal(size=x.shape)
    h[10:14, 20:25] = np.nan
    return api.HeightMap(
        h,
        0.0011,
        0.0011,
        intensity=rng.uniform(0, 255, h.shape),
        origin=(1.5, 2.5),
        name="csi.x3p",
        source_unit="m",
        meta={"instrument": {"vendor": "Zygo", "serial": "42"}, "raw_metadata": {"wavelength_in": 5.7e-7}},
    )


def test_a_height_map_stored_in_a_project_comes_back_whole(tmp_path):
    m = _map()
    with Project.create(tmp_path / "p") as project:
        h = project.add_object(m, "csi")
        mid = project.add_measurement("csi", h, kind="heightmap")
        rec = project.measurement(mid)
        assert rec["kind"] == "heightmap" and rec["path"].endswith(".x3p")
        back = project.load_measurement(mid)
    assert isinstance(back, api.HeightMap) and back.name == "csi"
    np.testing.assert_array_equal(back.heights, m.heights)
    np.testing.assert_array_equal(back.intensity, m.intensity)
    assert (back.dx, back.dy, back.origin) == (m.dx, m.dy, m.origin)
    assert back.meta["instrument"] == {"vendor": "Zygo", "serial": "42"}
    assert back.meta["raw_metadata"]["wavelength_in"] == 5.7e-7


@pytest.mark.slow
def test_an_instrument_file_is_kept_as_it_came(tmp_path, shared_data):
    src = shared_data / "csi_height_maps_surfalize" / "test_1.plu"
    if not src.is_file():
        pytest.skip(f"{src} is absent")
    with Project.create(tmp_path / "p") as project:
        h = project.add_file(src)
        mid = project.add_measurement("test_1.plu", h, kind="heightmap", meta={"unit": "um"})
        assert project.measurement(mid)["path"].endswith(".plu")
        back = project.load_measurement(mid)
    ref = api.read(src)
    np.testing.assert_array_equal(back.heights, ref.heights)
    assert (back.dx, back.source_unit) == (ref.dx, "um")


@pytest.mark.slow
def test_gui_import_shows_a_coloured_surface(gui_app, tmp_path):
    pytest.importorskip("trame")
    pytest.importorskip("pyvista")
    path = tmp_path / "csi.x3p"
    api.write(_map(), path)
    server, s = gui_app()
    key = s.import_file(path)
    assert key is not None, server.state.error_message
    item = server.state.items[0]
    assert item["kind"] == "heightmap"
    assert "height map 80 × 60 points, 99.6% valid" in item["subtitle"]
    shown = s.view.shown
    assert shown.kind == "heightmap" and shown.n_total == 80 * 60 - 20
    # heights spanning less than 1 mm read in µm by the number rule (issue 30)
    assert server.state.color_field == "z" and server.state.legend_title == "z [µm]"
    assert server.state.display_note == "showing all 4 780 valid points"
    # no NaN reaches the renderer: the 20 invalid points and the cells around them are left out
    assert not np.isnan(np.asarray(shown.poly.points)).any()
    assert shown.poly.n_cells == 79 * 59 - (4 + 1) * (5 + 1)
    img = s.view.screenshot()
    assert img.std() > 5 and len(np.unique(img.reshape(-1, 3), axis=0)) > 50, "view looks blank"
    (m,) = s.project.measurements()
    assert m["kind"] == "heightmap" and m["path"].endswith(".x3p")


@pytest.mark.slow
def test_the_real_instrument_files_open_in_the_app(gui_app, shared_data):
    """Zygo .dat, Wyko .opd and Sensofar .plu as their instruments wrote them, through the
    GUI's import: a height-map item each, drawn as a surface of its valid points."""
    pytest.importorskip("trame")
    pytest.importorskip("pyvista")
    folder = shared_data / "csi_height_maps_surfalize"
    files = [folder / n for n in ("test_1.dat", "test_1.opd", "test_1.plu")]
    if not all(f.is_file() for f in files):
        pytest.skip(f"{folder} is incomplete")
    server, s = gui_app()
    for f in files:
        assert s.import_file(f) is not None, server.state.error_message
        ref = api.read(f)
        assert server.state.items[-1]["kind"] == "heightmap"
        assert s.view.shown.kind == "heightmap" and s.view.shown.n_total == int(ref.valid.sum())
    assert [m["kind"] for m in s.project.measurements()] == ["heightmap"] * 3
