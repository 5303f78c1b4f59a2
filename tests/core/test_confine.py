"""camcmm.confine: the folders a confined run may touch (issue 26)."""

from __future__ import annotations

import threading

import pytest

from camcmm import confine
from camcmm.api import PathRefused, checked_path, document_path


def test_unconfined_paths_only_resolve(tmp_path):
    assert confine.current() is None
    assert checked_path("/etc/passwd") == confine.Path("/etc/passwd")
    assert document_path("runs/a.ply", tmp_path / "study.yaml", "runs[0].cloud") == tmp_path / "runs/a.ply"


def test_confined_refuses_outside_and_says_nothing_more(tmp_path):
    inside = tmp_path / "project"
    inside.mkdir()
    (inside / "study.yaml").write_text("x")
    with confine.confined([inside]):
        assert document_path("work", inside / "study.yaml", "work") == inside / "work"
        for bad in ("/etc/shadow", "/nonexistent/x", "../outside", "~/x"):
            with pytest.raises(PathRefused) as exc:
                document_path(bad, inside / "study.yaml", "work")
            msg = str(exc.value)
            assert msg.startswith(f"study.yaml: work: {bad}: outside the folders")
            assert msg.endswith(confine.OUTSIDE) and "\n" not in msg  # nothing about the file itself
        # a symlink inside that points outside is outside
        (inside / "link").symlink_to("/etc")
        with pytest.raises(PathRefused):
            checked_path(inside / "link" / "passwd", "plan")
        # relative paths of a confined run start at the project folder
        assert checked_path("a/b.ply") == inside / "a/b.ply"
    assert confine.current() is None


def test_confinement_belongs_to_its_context(tmp_path):
    seen = []
    with confine.confined([tmp_path]):
        t = threading.Thread(target=lambda: seen.append(confine.current()))
        t.start()
        t.join()
        assert confine.current() == (tmp_path.resolve(),)
    assert seen == [None]  # another thread (another session's job) is not confined by this one


def test_a_worker_run_is_confined_like_its_caller(tmp_path, monkeypatch):
    """The worker process gets the caller's folders with the run (camcmm.worker)."""
    from camcmm import worker
    from camcmm.host import default_host

    host = default_host()
    if not worker.isolatable(host):
        pytest.skip("no worker processes on this system")
    escape = tmp_path.parent / f"{tmp_path.name}-escape"
    study = tmp_path / "study.yaml"
    # image folders that do not exist: whatever happens, no real study runs in this test
    study.write_text(
        f"name: s\nwork: {escape}\nartefacts: [am_pyramid]\nmaterials: [nylon12]\nconditions: [off]\n"
        "capture:\n  images:\n    - {artefact: am_pyramid, material: nylon12, condition: off, folder: img}\n"
    )
    with confine.confined([tmp_path]), pytest.raises(PathRefused, match="outside the folders"):
        worker.run_isolated(host, "studies.speckle", {}, {"study": str(study)})
    assert not escape.exists()
