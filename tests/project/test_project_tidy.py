"""The project tidy in the store (camcmm.project.tidy): rename, hide, delete, restore.

Nothing saved is lost by a delete (the row, its file and the results that used it all
stay, and a restore brings the item back); a measurement that a stored result used is
deleted only when the caller confirms, and the refusal names the results. A project
of schema 2 migrates to 3 (the hidden flag) and keeps its items.
"""

from __future__ import annotations

import sqlite3

import pytest

from camcmm.errors import ProjectError
from camcmm.project import DB_NAME, SCHEMA_VERSION, Project
from camcmm.project import schema as project_schema

RUN = {"plugin": "fit.sphere", "version": "0.1.0", "params": {}, "input_hashes": {"cloud": "0" * 64}, "outputs": {}}


@pytest.fixture
def proj(tmp_path):
    with Project.create(tmp_path / "p", name="tidy") as p:
        yield p


@pytest.fixture
def h(proj, tmp_path):
    src = tmp_path / "a.xyz"
    src.write_text("0 0 0\n1 0 0\n0 1 0\n")
    return proj.add_file(src)


def _names(p, **kw):
    return [m["name"] for m in p.measurements(**kw)]


def test_rename_changes_the_name_only(proj, h):
    mid = proj.add_measurement("scan 1", h, meta={"summary": "3 points"})
    rid = proj.add_result(RUN, [mid])
    assert proj.rename_measurement(mid, "  ball   left\n") == "ball left"
    m = proj.measurement(mid)
    assert m["name"] == "ball left" and m["hash"] == h and m["meta"] == {"summary": "3 points"}
    assert proj.result(rid)["measurement_ids"] == [mid]
    for bad in ("", "   ", None, "x" * 201):
        with pytest.raises(ProjectError, match="name"):
            proj.rename_measurement(mid, bad)
    with pytest.raises(ProjectError, match="no measurement with id 77"):
        proj.rename_measurement(77, "x")
    assert proj.measurement(mid)["name"] == "ball left"


def test_hide_and_show_again(proj, h):
    a = proj.add_measurement("a", h)
    b = proj.add_measurement("b", h)
    assert [m["hidden"] for m in proj.measurements()] == [False, False]
    proj.set_measurement_hidden(a)
    assert {m["name"]: m["hidden"] for m in proj.measurements()} == {"a": True, "b": False}
    proj.set_measurement_hidden(a, False)
    assert not proj.measurement(a)["hidden"]
    with pytest.raises(ProjectError, match="no measurement with id 9"):
        proj.set_measurement_hidden(9)
    assert b


def test_delete_loses_nothing_and_undo_restores(proj, h):
    a = proj.add_measurement("a", h)
    b = proj.add_measurement("b", h)
    assert proj.delete_measurement(a) == []
    assert _names(proj) == ["b"]
    gone = proj.measurement(a)  # the row is still there, marked
    assert gone["removed"] is not None and proj.file_path(h).is_file()
    assert _names(proj, include_removed=True) == ["a", "b"]
    proj.delete_measurement(a)  # twice: still one delete, same time
    assert proj.measurement(a)["removed"] == gone["removed"]
    proj.restore_measurement(a)
    assert _names(proj) == ["a", "b"] and proj.measurement(a)["removed"] is None
    assert proj.load_measurement(a).n_points == 3
    with pytest.raises(ProjectError, match="no measurement with id 5"):
        proj.delete_measurement(5)
    assert b


def test_a_stored_results_input_is_refused_unless_confirmed(proj, h):
    used = proj.add_measurement("used", h)
    free = proj.add_measurement("free", h)
    r1 = proj.add_result(RUN, [used])
    r2 = proj.add_result(dict(RUN, plugin="fit.plane"), [used, free])
    assert [r["id"] for r in proj.results_using(used)] == [r1, r2]
    assert [r["plugin"] for r in proj.results_using(used)] == ["fit.sphere", "fit.plane"]
    with pytest.raises(ProjectError) as err:
        proj.delete_measurement(used)
    msg = str(err.value)
    assert f"#{r1} fit.sphere" in msg and f"#{r2} fit.plane" in msg and "confirm" in msg
    assert _names(proj) == ["used", "free"]  # refused: nothing changed
    assert [r["id"] for r in proj.delete_measurement(used, confirm=True)] == [r1, r2]
    assert _names(proj) == ["free"]
    # the results still name their input, and it can come back
    assert proj.result(r1)["measurement_ids"] == [used]
    proj.restore_measurement(used)
    assert _names(proj) == ["used", "free"]


def test_schema_2_project_migrates_to_the_hidden_flag(tmp_path):
    root = tmp_path / "old"
    root.mkdir()
    (root / "data").mkdir()
    c = sqlite3.connect(root / DB_NAME, isolation_level=None)
    for step in range(2):  # a project as camcmm with schema 2 wrote it
        project_schema.apply(c, step)
    c.execute("INSERT INTO meta(key, value) VALUES ('name', 'old'), ('created', '2025-01-01T00:00:00+00:00')")
    c.execute(
        "INSERT INTO files(hash, ext, size, original_name, added) VALUES (?, '.xyz', 1, 'a.xyz', 't')", ("a" * 64,)
    )
    c.execute(
        "INSERT INTO measurements(name, kind, hash, meta, created) VALUES ('kept', 'pointcloud', ?, '{}', 't')",
        ("a" * 64,),
    )
    c.close()
    with Project.open(root) as p:
        assert p.schema_version == SCHEMA_VERSION >= 3
        (m,) = p.measurements()
        assert m["name"] == "kept" and m["hidden"] is False
        p.set_measurement_hidden(m["id"])
        assert p.measurement(m["id"])["hidden"] is True


# -- the tidy on the Inspect page (no browser) ------------------------------------------------
@pytest.mark.slow
def test_the_page_renames_hides_deletes_with_confirmation_and_undoes(gui_app, tmp_path):
    pytest.importorskip("trame")
    import numpy as np

    from camcmm import io as cio
    from camcmm.model import PointCloud

    f = tmp_path / "scan.xyz"
    cio.write(PointCloud(np.random.default_rng(1).normal(size=(200, 3)), name="scan"), f)
    server, s = gui_app()
    page, state = server.pages["inspect"], server.state
    tidy = page.tidy
    a, b = s.import_file(f), s.import_file(f, name="other.xyz")
    names = lambda: [it["name"] for it in state.items]  # noqa: E731

    tidy.ask_rename(a)
    assert state.tidy_rename == {"id": a, "name": "scan.xyz"} and state.tidy_new_name == "scan.xyz"
    assert tidy.rename(a, "left ball") and names() == ["left ball", "other.xyz"]
    assert s.load(a).name == "left ball" and state.tidy_rename is None
    assert not tidy.rename(a, "   ") and "name" in s.page_error("inspect")  # refused, kept
    assert (
        tidy.set_hidden(b) and names() == ["left ball"] and [it["name"] for it in state.hidden_items] == ["other.xyz"]
    )
    assert tidy.undo() and names() == ["left ball", "other.xyz"]
    assert tidy.undo() and names() == ["scan.xyz", "other.xyz"]

    # a stored result's input: the page lists the results and asks; nothing happens until confirmed
    import asyncio

    assert asyncio.run(page.run_plugin("cloud.downsample", {"voxel_size": 0.5}, {"cloud": a})) is not None
    rid = page.last_result_id
    assert not tidy.ask_delete(a)
    assert state.tidy_confirm["id"] == a and state.tidy_confirm["results"][0].startswith(f"#{rid} cloud.downsample")
    assert "scan.xyz" in names()
    tidy.cancel()
    assert state.tidy_confirm is None and "scan.xyz" in names()
    assert not tidy.delete(a, confirm="yes")  # only a real True from the dialog confirms
    assert "scan.xyz" in names()
    assert tidy.delete(a, confirm=True) and "scan.xyz" not in names()
    assert s.project.result(rid)["measurement_ids"] == [int(a)]  # the result keeps its record
    # an item no result used goes at once; both come back with undo
    assert tidy.ask_delete(b) and "other.xyz" not in names()
    assert tidy.undo() and tidy.undo() and names()[:2] == ["scan.xyz", "other.xyz"]
    assert not state.tidy_can_undo
    # hostile ids from the browser: a one-line reason, nothing changes
    before = names()
    for bad in ("999", None, "'; DROP TABLE measurements; --", {"x": 1}):
        assert not tidy.ask_delete(bad) and not tidy.set_hidden(bad) and not tidy.rename(bad, "x")
    assert names() == before
