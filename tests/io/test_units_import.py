"""Units at import (issue 15): one rule, camcmm.units.decide_unit, for every import.

Clouds exact by construction at several scales; files that state their unit (PLY's
``comment unit``, E57) are never asked about; the GUI session holds an import of NIST's
SPH101.xyz (metres, no unit in the file) and asks, and answered "m" stores a cloud whose
sphere extraction gives r ≈ 50 mm (tests/data/nist_spheres/SOURCE: nominal radius 50 mm;
NIST's own segmentation fitted 50.08 mm for SPH101); `camcmm info` warns in its JSON.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from camcmm import io as cio
from camcmm.errors import ParameterError
from camcmm.model import PointCloud
from camcmm.units import (
    CANDIDATE_UNITS,
    EXPECTED_RATIO,
    PLAUSIBLE_SPAN_MM,
    decide_unit,
    suggest_unit,
)
from helpers.cli import main_json, main_run, main_text

NIST = Path(__file__).parents[1] / "data" / "nist_spheres"


def _box(sides) -> PointCloud:
    """The 8 corners of a box with these sides: its span is exactly ``sides``."""
    c = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    return PointCloud(c * np.asarray(sides, float), name="box.xyz")


def _diag(d: float) -> tuple[float, float, float]:
    s = d / np.sqrt(3.0)
    return (s, s, s)


# -- the rule ----------------------------------------------------------------------------------
@pytest.mark.parametrize("d", [0.5, 1.0, 20.0, 150.0, 2000.0, 5000.0])
def test_plausible_mm_is_not_asked(d):
    check = decide_unit(_diag(d))
    assert check.status == "plausible" and check.unit == "mm" and not check.asks, check.reason


@pytest.mark.parametrize("d", [0.499, 0.2, 1e-3, 5001.0, 1e5])
def test_implausible_mm_asks(d):
    check = decide_unit(_diag(d), name="scan.xyz")
    assert check.asks, check.reason
    assert check.reason.startswith("scan.xyz has no unit") and "give its unit" in check.reason
    assert [c["unit"] for c in check.candidates] == list(CANDIDATE_UNITS)


def test_bounds_are_the_documented_ones():
    assert PLAUSIBLE_SPAN_MM == (0.5, 5000.0) and EXPECTED_RATIO == 50.0
    doc = (Path(__file__).parents[2] / "docs" / "units.md").read_text("utf-8")
    assert "0.5" in doc and "5000" in doc and "E / 50" in doc


def test_metres_scan_suggests_metres_with_conversions():
    # a 138 x 107 x 99 mm scene written in metres (NIST's SPH101 size)
    check = decide_unit((0.138, 0.107, 0.099), name="s.xyz")
    assert check.asks and check.suggested == "m"
    m = next(c for c in check.candidates if c["unit"] == "m")
    assert m["label"] == "m (→ 138 × 107 × 99 mm)" and m["plausible"]
    assert np.allclose(m["span_mm"], (138.0, 107.0, 99.0), rtol=1e-12)
    um = next(c for c in check.candidates if c["unit"] == "um")
    assert um["label"].startswith("µm") and not um["plausible"]


def test_micrometre_file_suggests_micrometres():
    check = decide_unit((12000.0, 8000.0, 300.0))  # a 12 x 8 mm CSI height map in µm
    assert check.asks and check.suggested == "um" and "too large" in check.reason


def test_stated_unit_is_trusted_without_expected_size():
    for unit, span in (("m", (0.138, 0.107, 0.099)), ("mm", (0.01, 0.01, 0.01)), ("um", (1e6, 1e6, 1e6))):
        check = decide_unit(span, unit, unit=unit)
        assert check.status == "known" and not check.asks, check.reason


def test_expected_size_asks_even_a_stated_unit():
    # a file claiming mm with a 20 mm ball in metres (the wizard's case): its diagonal 0.035
    ball = (0.02, 0.02, 0.02)
    check = decide_unit(ball, "mm", expected=20.0, what="sphere")
    assert check.asks and check.suggested == "m" and "sphere of 20 mm" in check.reason
    # a plausible mm size that does not fit a 100 mm sphere still asks (0.2 "mm" is also implausible)
    assert decide_unit((0.138, 0.107, 0.099), expected=100.0).suggested == "m"
    # the bounds E/50 .. 50 E: inside is fine, a factor 1000 outside asks
    assert not decide_unit(_diag(20.0 / 50 * 1.001), expected=20.0).asks
    assert not decide_unit(_diag(20.0 * 50 * 0.999), expected=20.0).asks
    # cm, inch and m would all fit a 20 mm artefact here; the suggestion is the usual slip, m
    assert decide_unit(_diag(20.0 / 50 * 0.999), expected=20.0).suggested == "m"
    assert decide_unit(_diag(20.0 / 50 * 0.999), expected=20.0, units=("cm", "in", "mm")).suggested == "cm"
    assert decide_unit(_diag(20.0 / 50 * 0.999), expected=20.0, units=("m", "mm", "um")).suggested == "m"
    assert decide_unit(_diag(20.0 * 1000), expected=20.0).suggested == "um"
    # mm read as metres: 20 000 mm for a 20 mm artefact -> mm
    assert decide_unit(_diag(20_000.0), "m", unit="m", expected=20.0).suggested == "mm"


def test_expected_size_no_unit_explains_it_is_not_a_unit_question():
    # 1e5 times too large: no candidate brings it within 0.05..20 E (µm gives 100 E): the wrong file
    check = decide_unit(_diag(1e5), "mm", expected=1.0)
    assert not check.asks and check.status == "known"


def test_suggest_unit():
    assert suggest_unit(0.028, 20.0) == "m"
    assert suggest_unit(28_000.0, 20.0, "m") == "mm"
    assert suggest_unit(20.0, 20.0) is None or suggest_unit(20.0, 20.0) != "mm"
    assert suggest_unit(0.0, 20.0) is None


def test_zero_extent_and_bad_input():
    assert not decide_unit((0.0, 0.0, 0.0)).asks
    with pytest.raises(ParameterError):
        decide_unit((1.0, 2.0))
    with pytest.raises(ParameterError):
        decide_unit((1.0, 1.0, 1.0), "furlong")


# -- files: stated units are never asked about ------------------------------------------------
@pytest.mark.parametrize("ext", [".ply", ".xyz", ".pcd"])
def test_file_stating_metres_is_never_asked(tmp_path, ext):
    cloud = _box((138.0, 107.0, 99.0))
    f = tmp_path / f"scan{ext}"
    cio.write(cloud, f, unit="m")  # writes its unit: 0.138 m
    obj, stated = cio.read_stated(f)
    assert stated == "m" and obj.source_unit == "m"
    check = cio.unit_decision(obj, stated)
    assert not check.asks and check.status == "known"
    # PCD keeps float32 coordinates (7 digits)
    assert np.allclose(np.ptp(obj.points, axis=0), (138.0, 107.0, 99.0), rtol=1e-6 if ext == ".pcd" else 1e-12)


def test_e57_is_metres_by_definition(tmp_path):
    pytest.importorskip("pye57")
    f = tmp_path / "scan.e57"
    cio.write(_box((0.3, 0.2, 0.1)), f)  # 0.3 mm written as 0.0003 m: E57 states metres
    obj, stated = cio.read_stated(f)
    assert stated == "m" and not cio.unit_decision(obj, stated).asks


def test_unitless_file_is_asked_and_with_unit_converts(tmp_path):
    f = tmp_path / "scan.xyz"
    f.write_text("".join(f"{x} {y} {z}\n" for x, y, z in _box((0.138, 0.107, 0.099)).points))
    obj, stated = cio.read_stated(f)
    assert stated is None and obj.source_unit == "mm"
    check = cio.unit_decision(obj, stated)
    assert check.asks and check.suggested == "m"
    m = cio.with_unit(obj, "m")
    assert m.source_unit == "m"
    assert np.allclose(np.ptp(m.points, axis=0), (138.0, 107.0, 99.0), rtol=1e-12)
    assert np.allclose(cio.read(f, unit="m").points, m.points, rtol=1e-15)


@pytest.mark.slow
def test_cli_info_warns_only_without_a_unit(capfd):
    # in-process (main_json/main_text: the CLI's main with capfd): only the output counts
    doc = main_json(capfd, "info", NIST / "SPH101.xyz", "--json")
    assert doc["unit_check"]["status"] == "ask" and doc["unit_check"]["suggested"] == "m"
    assert len(doc["warnings"]) == 1 and "SPH101.xyz has no unit" in doc["warnings"][0]
    told = main_json(capfd, "info", NIST / "SPH101.xyz", "--unit", "m", "--json")
    assert told["warnings"] == [] and told["source_unit"] == "m"
    text = main_text(capfd, "info", NIST / "SPH101.xyz")
    assert "warning: SPH101.xyz has no unit" in text


def test_host_run_warns_on_a_unitless_implausible_file(tmp_path):
    from camcmm.host import read

    notes: list[str] = []
    read(NIST / "SPH101.xyz", notes)
    assert len(notes) == 1 and "give its unit (in m: 138 × 106 × 99.3 mm)" in notes[0]
    f = tmp_path / "ok.ply"
    cio.write(_box((20.0, 20.0, 20.0)), f)
    notes = []
    read(f, notes)
    assert notes == []


# -- the GUI session (no browser) --------------------------------------------------------------
@pytest.mark.slow
def test_session_asks_for_sph101_and_m_gives_a_50_mm_sphere(gui_app):
    server, session = gui_app()
    assert session.import_file(NIST / "SPH101.xyz") is None  # held: asked, not guessed
    ask = server.state.unit_ask
    assert server.state.unit_ask_visible and ask["file"] == "SPH101.xyz"
    assert "no unit" in ask["reason"] and server.state.unit_choice == "m"
    assert [c["value"] for c in ask["choices"]] == list(CANDIDATE_UNITS)
    assert server.state.items == []  # nothing stored before the answer
    assert session.answer_unit("furlong") is None and "not one of" in session.errors[-1]
    key = session.answer_unit("m")
    assert key is not None and not server.state.unit_ask_visible
    cloud = session.load(key)
    assert cloud.source_unit == "m"
    assert np.allclose(np.ptp(cloud.points, axis=0), [137.89, 106.48, 99.33], atol=1e-6)
    assert session.measurement(key)["meta"]["unit"] == "m"
    # reloaded from the project (a new session on the same folder reads it in metres again)
    assert session.project.load_measurement(int(key)).source_unit == "m"
    fit = session.host.run("segment.sphere", {"cloud": cloud}, {"nominal_radius": 50.0})
    assert abs(fit.outputs["radius"] - 50.0) < 0.3, fit.outputs["radius"]  # 49.9936 mm (nominal 50)
    # the project opened again: the item is read in metres and shows its size in mm
    server2, session2 = gui_app(project_dir=Path(session.project.path))
    session2.select_item(key)
    assert session2.load(key).source_unit == "m"
    item = next(it for it in server2.state.items if it["id"] == key)
    assert "138 × 106 × 99.3 mm" in item["subtitle"], item


@pytest.mark.slow
def test_session_plausible_and_stated_files_import_at_once(gui_app, tmp_path):
    server, session = gui_app()
    f = tmp_path / "ball.xyz"
    f.write_text("".join(f"{x} {y} {z}\n" for x, y, z in _box((20.0, 20.0, 20.0)).points))
    assert session.import_file(f) is not None and not server.state.unit_ask_visible
    g = tmp_path / "ball_m.ply"
    cio.write(_box((20.0, 20.0, 20.0)), g, unit="m")
    key = session.import_file(g)
    assert key is not None and session.load(key).source_unit == "m"
    # an explicit unit on the import is used as given
    key = session.import_file(NIST / "SPH101.xyz", unit="m")
    assert key is not None and not server.state.unit_ask_visible


@pytest.mark.slow
def test_session_cancel_and_uploads_kept_while_asking(gui_app):
    server, session = gui_app()
    data = (NIST / "SPH101.xyz").read_bytes()
    assert session.import_file(data, "a.xyz") is None
    assert session.import_file(data, "b.xyz") is None  # a second upload: its temp copy survives the first
    assert server.state.unit_ask["waiting"] == 2
    session.cancel_unit()
    assert server.state.unit_ask["file"] == "b.xyz"
    key = session.answer_unit("m")
    assert key is not None and [it["name"] for it in server.state.items] == ["b.xyz"]
    assert not list(session._tmp.glob("pending-*"))


# -- the acceptance wizard uses the same rule ------------------------------------------------------
def test_wizard_extent_check_is_the_shared_rule():
    from camcmm.api import GeometryError, InputError
    from camcmm_plugins.vdi2634.measure import _size_check, check_extent

    corners = _box(_diag(20.0)).points  # a 20 mm artefact's cloud, diagonal exactly 20 mm
    ball = PointCloud(np.vstack([corners, corners.mean(axis=0) + 0 * corners]), name="ok.ply")  # 16 points
    check_extent(ball, 20.0, "ok.ply", "sphere")  # fits: no error
    metres = PointCloud(ball.points / 1000, name="m.ply")  # numbers in metres, read as mm
    with pytest.raises(InputError, match=r"spans 0\.02 mm .* looks like metres; convert it or give its unit"):
        check_extent(metres, 20.0, "m.ply", "sphere")
    mm_as_m = PointCloud(ball.points * 1000, name="x.ply", source_unit="m")  # a plan saying m on mm files
    with pytest.raises(InputError, match="a file in mm read as metres"):
        check_extent(mm_as_m, 20.0, "x.ply", "sphere")
    micro = PointCloud(ball.points * 1000, name="u.ply")  # µm numbers, no unit
    with pytest.raises(InputError, match=r"looks like µm; convert it or give its unit \(unit: um in the plan\)"):
        check_extent(micro, 20.0, "u.ply", "sphere")
    # the fitted diameter: 1/1000 -> metres; 3 x -> not a unit, the wrong artefact
    with pytest.raises(InputError, match="about 1/1000 of 20 mm; it looks like metres"):
        _size_check(0.02, 20.0, "m.ply", "sphere")
    with pytest.raises(GeometryError, match="is this the right file"):
        _size_check(60.0, 20.0, "big.ply", "sphere")


@pytest.mark.slow
def test_compare_inputs_say_when_the_cloud_is_in_another_unit_than_the_nominal(gui_app):
    server, session = gui_app()
    page = server.pages["compare"]
    nominal = _box((60.0, 40.0, 20.0))
    same = _box((59.0, 40.0, 20.0))
    assert page.unit_note(same, nominal) == ""
    metres = _box((0.059, 0.040, 0.020))  # numbers in metres read as mm
    note = page.unit_note(metres, nominal)
    assert "but a nominal of 74.8 mm was expected; in m it would fit" in note, note
    assert "import it again with its unit" in note
    assert page.unit_note(None, nominal) == "" and page.unit_note(metres, None) == ""


@pytest.mark.slow
def test_gauge_block_cli_uses_the_rule_with_the_nominal(tmp_path, capfd):
    rng = np.random.default_rng(0)
    xy = rng.uniform(-20, 20, (3000, 2))
    top = (np.abs(xy[:, 0]) < 4.5) & (np.abs(xy[:, 1]) < 15)
    pts = np.column_stack([xy, np.where(top, 5.0006, 0.0)]) / 1000  # metres, no unit in the file
    f = tmp_path / "block.xyz"
    f.write_text("".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in pts.tolist()))
    told = main_json(capfd, "gauge-block", f, "--nominal", "5.0006", "--unit", "m", "--json")
    assert abs(told["error"]) < 1e-9 and not any("unit" in w for w in told.get("warnings", []))
    _, stdout, stderr = main_run(capfd, "gauge-block", f, "--nominal", "5.0006", "--json")
    out = stdout + stderr
    assert "block.xyz spans" in out and "in m it would fit" in out, out


@pytest.mark.slow
def test_fit_cli_warns_without_a_unit_and_not_with_one(capfd):
    doc = main_json(capfd, "fit", "sphere", NIST / "SPH101.xyz", "--json")
    assert doc["warnings"][0].startswith("SPH101.xyz has no unit and spans 0.138 × 0.106 × 0.0993")
    told = main_json(capfd, "fit", "sphere", NIST / "SPH101.xyz", "--unit", "m", "--json")
    assert not any("no unit" in w for w in told["warnings"])


@pytest.mark.slow
def test_server_path_import_with_its_unit_field(gui_app):
    import asyncio

    server, session = gui_app(data_roots=(NIST,))
    path = str(NIST / "SPH101.xyz")
    asyncio.run(session.ctrl.import_server_path(path, "furlong"))  # hostile input: refused, nothing read
    assert "not one of" in session.errors[-1] and server.state.items == []
    asyncio.run(session.ctrl.import_server_path(path, "m"))  # told: not asked
    assert not server.state.unit_ask_visible and len(server.state.items) == 1
    item = server.state.items[0]
    assert "138 × 106 × 99.3 mm" in item["subtitle"], item
    assert session.load(item["id"]).source_unit == "m"
    asyncio.run(session.ctrl.import_server_path(path, ""))  # the file's own: none, so asked
    assert server.state.unit_ask_visible and len(server.state.items) == 1


@pytest.mark.slow
def test_wizard_import_in_metres_refused_then_read_in_the_plan_unit(tmp_path):
    from helpers.acceptance_data import ARTEFACTS, MPE, VOLUME, make_cloud, real_vdi2634_available

    if not real_vdi2634_available():
        pytest.skip("needs the vdi2634-2 plugin")
    from camcmm.host import default_host
    from camcmm.project import Project
    from camcmm.tasks.acceptance import Wizard

    with Project.create(tmp_path / "proj") as project:
        w = Wizard(project, default_host())
        artefacts = {t: dict(a) for t, a in ARTEFACTS.items()}
        w.setup("vdi2634-2", "Test scanner", VOLUME, MPE, artefacts)
        req = next(r for r in w.requirements() if r["test"] == "sphere")
        pos = req["positions"][0]
        f = tmp_path / "sphere_m.xyz"  # the sphere's numbers in metres, no unit in the file
        pts = make_cloud("sphere", pos, n=2000).points / 1000
        f.write_text("".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in pts.tolist()))
        card = w.import_measurement("sphere", pos["id"], f)
        assert card["status"] == "error" and "looks like metres; convert it or give its unit" in card["error"]
        w.setup("vdi2634-2", "Test scanner", VOLUME, MPE, artefacts, options="unit: m")
        card = w.import_measurement("sphere", pos["id"], f)
        assert card["status"] == "done", card
        m = project.measurements()[-1]
        assert m["meta"]["unit"] == "m"  # recorded: it loads in metres again
        back = project.load_measurement(m["id"])
        assert back.source_unit == "m" and np.allclose(back.points, pts * 1000, rtol=1e-12)
