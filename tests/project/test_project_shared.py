"""One project store shared by several sessions (one process per browser session):
a session notices another's commits by a cheap token (``Project.change_token``) and
lists its items and results again, without a page reload (issue 15)."""

from __future__ import annotations

import asyncio
import os

import numpy as np
import pytest

from camcmm.project import Project

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

RUN = {
    "plugin": "fit.sphere",
    "version": "1.2.0",
    "params": {},
    "input_hashes": {},
    "outputs": {"radius": 10.0},
    "started": "2024-01-01T00:00:00.000+00:00",
    "finished": "2024-01-01T00:00:01.000+00:00",
}


def test_another_connections_commit_changes_the_token(tmp_path):
    with Project.create(tmp_path / "p") as a, Project.open(tmp_path / "p") as b:
        before = b.change_token()
        assert before is not None and a.change_token() is not None
        a.add_result(RUN)
        after = b.change_token()
        assert after != before  # B sees A's commit
        assert b.change_token() == after  # and nothing more until the next one
        a.set_state("gui.x", 1)
        assert b.change_token() != after


def test_token_of_a_closed_or_busy_store_is_none(tmp_path):
    import threading

    p = Project.create(tmp_path / "p")
    held, done = threading.Event(), threading.Event()

    def hold():  # another thread in the store: the check skips rather than wait
        with p._read("holding"):
            held.set()
            done.wait(5)

    t = threading.Thread(target=hold)
    t.start()
    held.wait(5)
    try:
        assert p.change_token() is None
    finally:
        done.set()
        t.join()
    assert p.change_token() is not None
    p.close()
    assert p.change_token() is None


@pytest.mark.slow
def test_an_import_in_one_session_shows_in_the_other(gui_app, tmp_path):
    from camcmm.io import write
    from camcmm.model import PointCloud

    cloud = tmp_path / "extra.ply"
    write(PointCloud(np.random.default_rng(0).normal(size=(200, 3)) * 10, name="extra"), cloud)
    _, a = gui_app(tmp_path / "proj")
    _, b = gui_app(tmp_path / "proj")  # its own Project object: another connection, as another process has
    assert a.project is not b.project
    assert b.check_project() is False  # nothing changed: nothing listed again
    key = a.import_file(cloud)
    assert key is not None and key in {i["id"] for i in a.state.items}
    assert key not in {i["id"] for i in b.state.items}
    assert b.check_project() is True
    assert key in {i["id"] for i in b.state.items}
    assert a.check_project() is False  # its own import does not make A list again

    a.project.add_result(RUN, [int(key)])
    assert b.check_project() is True
    assert [r["plugin"] for r in b.state.results] == ["fit.sphere"]


@pytest.mark.slow
def test_the_check_runs_on_the_loop_and_stops_on_close(gui_app, tmp_path, monkeypatch):
    from camcmm.gui import session as session_mod

    monkeypatch.setattr(session_mod, "WATCH_PERIOD_S", 0.01)
    _, a = gui_app(tmp_path / "proj")
    _, b = gui_app(tmp_path / "proj")
    calls = []
    real = b.check_project
    b.check_project = lambda: calls.append(1) or real()

    async def main():
        b.bind_loop()
        a.project.add_result(RUN)
        for _ in range(500):  # until the timer ran (bounded; no timing asserted)
            await asyncio.sleep(0.01)
            if b.state.results:
                break
        assert [r["plugin"] for r in b.state.results] == ["fit.sphere"]
        fails = []

        def failing():
            fails.append(1)
            raise RuntimeError("database is locked")

        b.check_project = failing  # a failing check never throws into the loop, and runs again
        for _ in range(500):
            await asyncio.sleep(0.01)
            if len(fails) >= 2:
                break
        b.close()
        n = len(fails)
        await asyncio.sleep(0.1)  # ten periods: a timer left running would call it again
        return n, len(fails)

    before, after = asyncio.run(main())
    assert calls and before >= 2 and after == before
