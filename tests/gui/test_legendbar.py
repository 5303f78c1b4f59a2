"""The 3-D legends by the number rule (camcmm.gui.legendbar): the title in words, round
ticks in µm for a deviation given in mm, a real minus; a two-valued field (fusion's
``source``) as labelled swatches — in the VTK scalar bar and in what the browser draws
(clientview.export), and in the Inspect view's scene (gui/view.py)."""

from __future__ import annotations

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from camcmm.gui import legendbar as lb  # noqa: E402
from camcmm.gui.clientview.export import export_scene  # noqa: E402

M = "\u2212"


def test_a_deviation_in_mm_reads_in_micrometres_on_round_ticks():
    spec = lb.legend("radial_deviation", "mm", -0.01899, 0.009493)
    assert spec.title == "radial deviation [µm]" and spec.unit == "µm" and spec.factor == 1000.0
    assert spec.texts == [f"{M}15", f"{M}10", f"{M}5", "0", "5"]
    assert spec.ticks == pytest.approx([-0.015, -0.01, -0.005, 0.0, 0.005])  # where VTK puts them: mm
    z = lb.legend("z", "mm", 3.2, 48.7)  # a position stays in mm
    assert z.title == "z [mm]" and z.texts == ["10", "20", "30", "40"]
    assert lb.value_text(spec, -0.0123) == f"radial deviation = {M}12.3 µm"
    assert lb.value_text(z, 12.34567) == "z = 12.3457 mm"
    in_um = lb.legend("deviation", "um", -20.0, 20.0)  # a field stored in µm stays µm
    assert in_um.title == "deviation [µm]" and in_um.factor == 1.0
    assert lb.value_text(in_um, 4.2) == "deviation = +4.20 µm"


def test_only_a_few_whole_values_are_categories():
    assert lb.categories("source", [0, 1, 1, 0]) == [(0.0, "photogrammetry"), (1.0, "CSI map 1")]
    assert lb.categories("source", [0, 1, 2]) == [(0.0, "photogrammetry"), (1.0, "CSI map 1"), (2.0, "CSI map 2")]
    assert lb.categories("flag", [0.0, 1.0]) == [(0.0, "flag 0"), (1.0, "flag 1")]
    assert lb.categories("height", [0.0, 0.5, 1.0]) == []  # a ramp
    assert lb.categories("label", [0, 1, 2, 3]) == []  # more than two values of an unknown field


def _scene(name: str, values: np.ndarray, unit: str):
    pts = np.random.default_rng(0).normal(size=(len(values), 3))
    plotter = pv.Plotter(off_screen=True, window_size=[300, 200])
    try:
        cloud = pv.PolyData(pts)
        cloud[name] = values
        lo, hi = float(values.min()), float(values.max())
        actor = plotter.add_mesh(cloud, scalars=name, clim=[lo, hi], scalar_bar_args={"title": name})
        spec = lb.legend(name, unit, lo, hi, values)
        lb.dress(plotter.scalar_bars[name], spec)
        return spec, export_scene(plotter.renderer, {id(actor): "cloud"})
    finally:
        plotter.close()


def test_the_browser_draws_the_same_legend_as_vtk():
    dev = np.linspace(-0.0377, 0.0326, 500)
    spec, scene = _scene("radial_deviation", dev, "mm")
    legend = scene.legend
    assert legend["title"] == "radial deviation [µm]" and scene.entries == []
    assert [t["text"] for t in legend["labels"]] == [f"{M}30", f"{M}20", f"{M}10", "0", "10", "20", "30"]
    assert [t["value"] for t in legend["labels"]] == pytest.approx([-0.03, -0.02, -0.01, 0, 0.01, 0.02, 0.03])
    assert not any("e" in t["text"] or "-" in t["text"] for t in legend["labels"])


def test_a_two_valued_field_is_two_labelled_swatches():
    src = np.repeat([0, 1], 300)
    spec, scene = _scene("source", src, "")
    assert scene.legend is None  # no ramp
    assert [e["text"] for e in scene.entries] == ["photogrammetry", "CSI map 1"]
    swatches = [e["color"] for e in scene.entries]
    assert swatches[0] != swatches[1]
    (layer,) = scene.layers
    colours = {tuple(c) for c in np.asarray(layer.colors)[:, :3].tolist()}
    assert colours == {tuple(c) for c in swatches}  # the points are drawn in the swatches' colours


def test_the_inspect_view_titles_its_legend_in_words_and_micrometres():
    from camcmm.gui.view import SceneView
    from camcmm.model import PointCloud

    pts = np.random.default_rng(1).normal(size=(400, 3))
    dev = pts[:, 0] * 0.01
    cloud = PointCloud(pts, fields={"radial_deviation": dev}, field_units={"radial_deviation": "mm"}, name="c")
    view = SceneView(window_size=(300, 200))
    try:
        view.show("k", cloud, "radial_deviation")
        assert view.scalar_bar_title == "radial deviation [µm]"
        bar = view.plotter.scalar_bars[view.scalar_bar_title]
        notes = lb.lut_annotations(bar.GetLookupTable())
        assert notes and all(text.lstrip(M).replace(".", "").isdigit() for _, text in notes)
        assert not bar.GetDrawTickLabels()
        assert view.value_text(-0.0042) == f"radial deviation = {M}4.20 µm"
        view.set_field("z")
        assert view.scalar_bar_title == "z [mm]"
        from camcmm.gui.view import color_fields

        titles = {f["value"]: f["title"] for f in color_fields(cloud)}
        assert titles["radial_deviation"] == "radial deviation [µm]"  # the select says what the legend says
    finally:
        view.plotter.close()


def test_the_compare_charts_hover_without_an_exponent():
    import json
    import re

    from camcmm.gui.pages.compare import figures
    from camcmm_plugins.inspection.material_ratio import parameters

    heights = np.random.default_rng(2).normal(0.0, 2e-9, 2000)  # nanometre deviations
    mr = parameters(heights, curve_points=101)
    stats = {"p2_5": float(np.percentile(heights, 2.5)), "p97_5": float(np.percentile(heights, 97.5))}
    text = json.dumps(figures.material_ratio_figure(mr, stats, "µm"), ensure_ascii=False)
    hovers = " ".join(re.findall(r'"hovertemplate": "([^"]*)"', text))
    assert "Spk " in hovers and not re.search(r"\d[eE][-+]?\d", hovers), hovers
    assert ":.4g" not in hovers  # plotly's own formats: significant digits (".4r"), never an exponent
