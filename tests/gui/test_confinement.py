"""The web server's guard on paths and outbound connections, headless (issue 26).

* a parameter says what it is in its manifest (``type: path`` with ``access``, ``type:
  address``), and every built-in one that names a file or folder says so;
* every job a page runs is confined (paths to the project folder and the data roots,
  addresses to ``--scheduler``) in its own thread, and nothing leaks to the caller;
* a refused path says only that it was refused: the same text for /etc/passwd and a
  file that does not exist (the Inspect page's run of ``studies.speckle``, the
  projector's Load);
* a scheduler address from the browser that is not configured is refused before any
  connection: the same text for a listening and a closed port, and nothing connects to
  the listening one.
"""

from __future__ import annotations

import asyncio
import re
import socket
import time

import pytest

from camcmm import confine, reach
from camcmm.errors import InputError, ParameterError
from camcmm.params import Param, add_cli_options, form_schema, validate

pytest.importorskip("trame")

#: a str parameter whose help names a file or a folder and is not a path, with the reason
NOT_PATHS = {
    # "spheres:R1,R2", "bar:L" or "lengths:FILE": the file is read through api.document_path
    # (confined in a server run) and the photogrammetry page checks it with the roots
    ("photogrammetry.reconstruct", "scale"),
    ("photogrammetry.scale", "scale"),
    # a device index, a stream URL or a video file: the camera checks a file with
    # api.checked_path when it opens it (test_an_opencv_camera_opens_only_a_file_inside_the_roots)
    ("devices.camera.opencv", "source"),
}
_FILEISH = re.compile(r"\b(file|files|folder|folders|dir|directory|path)\b|FILE|DIR")


def _host():
    from camcmm.host import PluginHost

    return PluginHost()


def _same(a: str, b: str, *paths: str) -> bool:
    """Messages equal once the paths they name are taken out."""
    for p in paths:
        a, b = a.replace(p, "PATH"), b.replace(p, "PATH")
    return a == b


# -- the declaration -------------------------------------------------------------------------
def test_path_and_address_types_give_form_cli_and_validation():
    out = Param.from_dict({"name": "out", "type": "path", "access": "write", "help": "Folder to write."})
    study = Param.from_dict({"name": "study", "type": "path", "required": True})
    sched = Param.from_dict({"name": "scheduler", "type": "address"})
    assert (out.access, study.access, sched.access) == ("write", "read", "")
    assert out.to_dict()["access"] == "write" and Param.from_dict(out.to_dict()) == out
    assert [f["widget"] for f in form_schema([out, sched])] == ["text", "text"]
    import argparse

    ap = argparse.ArgumentParser()
    add_cli_options(ap, [out, sched])
    assert "--out PATH" in ap.format_help() and "--scheduler ADDRESS" in ap.format_help()
    got = validate([out, study, sched], {"out": " res ", "study": "s.yaml", "scheduler": "tcp://h:1"})
    assert got == {"out": "res", "study": "s.yaml", "scheduler": "tcp://h:1"}
    assert validate([out], {"out": ""}) == {"out": None}  # empty: not given
    for bad, text in (
        ({"name": "x", "type": "str", "access": "read"}, "'access' is for type path"),
        ({"name": "x", "type": "path", "access": "execute"}, "access 'execute'"),
    ):
        with pytest.raises(ParameterError, match=text):
            Param.from_dict(bad)
    with pytest.raises(ParameterError, match="'study'"):
        study.coerce("a\x00b")
    with pytest.raises(ParameterError, match="'scheduler'"):
        sched.coerce("tcp://a:1 tcp://b:2")
    # the declared type decides; a lab's older str manifest is still recognised by its name
    assert reach.is_path_param(study) and not reach.is_path_param(sched)
    assert reach.is_path_param(Param("save", "str")) and not reach.is_path_param(Param("board", "str"))
    assert reach.is_address_param(sched) and reach.is_address_param(Param("scheduler", "str"))


def test_every_built_in_parameter_naming_a_file_or_folder_is_a_path():
    host = _host()
    left = []
    for spec in host.all():
        for p in spec.parameters:
            if p.type == "str" and _FILEISH.search(p.help) and (spec.id, p.name) not in NOT_PATHS:
                left.append(f"{spec.id} {p.name}: {p.help[:60]}")
    assert not left, left
    declared = {(s.id, p.name): p for s in host.all() for p in s.parameters}
    assert declared[("studies.speckle", "study")].type == "path"  # the Inspect page ran it outside the roots
    assert declared[("studies.speckle", "study")].access == "read"
    assert declared[("virtuallab.turntable-series", "out")].access == "write"
    assert declared[("uncertainty.montecarlo", "scheduler")].type == "address"
    assert declared[("photogrammetry.reconstruct", "scheduler")].type == "address"
    for key in NOT_PATHS:  # each exception still exists (a stale one would hide nothing)
        assert declared[key].type == "str"


# -- the jobs are confined, in their own thread --------------------------------------------------
def test_every_job_is_confined_in_its_thread_and_nothing_leaks(gui_app, tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    server, session = gui_app(data_roots=[data], schedulers=["tcp://10.0.0.5:8786"])
    assert confine.current() is None and reach.addresses() is None  # building an app confines nothing here
    job = server.pages["inspect"].job

    def inside():
        return confine.current(), reach.addresses()

    folders, addresses = asyncio.run(job.call(inside))
    assert folders == session.roots.folders == ((tmp_path / "proj").resolve(), data.resolve())
    assert addresses == ("tcp://10.0.0.5:8786",)
    assert confine.current() is None and reach.addresses() is None  # nor after a run
    # a page's other jobs (devices, imports, the other pages) are confined the same way
    for job in (server.pages["devices"].io, server.pages["uncertainty"].job, session._reader):
        assert asyncio.run(job.call(inside))[0] == session.roots.folders


def test_a_refused_path_says_nothing_of_the_file(gui_app, tmp_path):
    """studies.speckle's ``study`` from the Inspect page's form: /etc/passwd exists, the
    other does not; both are refused before anything is read, in the same words."""
    server, session = gui_app()
    page = server.pages["inspect"]
    lines = []
    for path in ("/etc/passwd", "/nonexistent/x"):
        assert asyncio.run(page.run_form("studies.speckle", {"study": path}, {})) is None
        lines.append(page.state.run_reason)
    assert "parameter 'study': /etc/passwd: outside the folders" in lines[0]
    assert _same(*lines, "/etc/passwd", "/nonexistent/x"), lines
    assert "no such" not in lines[0] + lines[1] and "root:x:" not in lines[0]
    # inside a job the readers' checked_path gives the same words, whatever the file
    got = []
    for path in ("/etc/passwd", "/nonexistent/x"):
        with pytest.raises(InputError) as e:
            asyncio.run(page.job.call(confine.check, path, "study"))
        got.append(str(e.value))
    assert _same(*got, "/etc/passwd", "/nonexistent/x") and confine.OUTSIDE in got[0]


def test_a_measuring_system_of_the_acceptance_page_is_held_to_the_roots(gui_app, tmp_path):
    """The browser names the system and its settings: a plugin that renders a series into
    a folder (virtuallab.turntable-series out=...) wrote images outside the project."""
    outside = tmp_path / "outside"
    server, session = gui_app()
    acq = server.pages["acceptance"].acquisition
    acq.state.wz_source_params = {"out": str(outside), "n_images": 3}
    with pytest.raises(InputError, match="not a plugin that acquires a point cloud"):
        acq.source_params("virtuallab.turntable-series")
    assert not outside.exists()
    host = session.host
    system = next(s for s in host.all() if getattr(s, "acquires", "") == "pointcloud" and s.kind == "algorithm")
    acq.state.wz_source_params = {}
    assert isinstance(acq.source_params(system.id), dict)  # a measuring system still runs


def test_the_projector_loads_only_a_sequence_inside_the_roots(gui_app, tmp_path):
    server, session = gui_app()
    page = server.pages["devices"]
    key = page.add("devices.projector.simulated", {})
    assert key is not None and asyncio.run(page.act(key, "connect")), page.state.dev_error
    lines = []
    for path in ("/etc/passwd", "/nonexistent/x.yaml"):
        assert asyncio.run(page.act(key, "load", path)) is None
        lines.append(page.state.dev_error)
    assert "sequence file: /etc/passwd: outside the folders" in lines[0]
    assert _same(*lines, "/etc/passwd", "/nonexistent/x.yaml"), lines
    assert asyncio.run(page.act(key, "load", "")) > 0  # the shipped sequence, confined or not
    own = tmp_path / "proj" / "seq.yaml"
    own.write_text("projector: {width: 64, height: 32}\nframes: [white, black]\n")
    assert asyncio.run(page.act(key, "load", "seq.yaml")) == 2, page.state.dev_error
    # the device itself refuses a file outside in a confined run (api.checked_path), before reading
    dev = page.devices[key]
    with pytest.raises(InputError, match="sequence file: /etc/passwd: outside the folders"):
        asyncio.run(page.io.call(dev.load_sequence, "/etc/passwd"))


def test_an_opencv_camera_opens_only_a_file_inside_the_roots(gui_app, tmp_path):
    """A camera's ``source`` is an index, a URL or a video/image file: a file outside the
    roots would show any image of the machine as a frame."""
    pytest.importorskip("cv2")
    server, session = gui_app()
    page = server.pages["devices"]
    lines = []
    for path in ("/etc/passwd", "/nonexistent/x.avi"):
        key = page.add("devices.camera.opencv", {"source": path})
        assert key is not None, page.state.dev_error
        assert asyncio.run(page.act(key, "connect")) is None
        lines.append(page.state.dev_error)
    assert "source: /etc/passwd: outside the folders" in lines[0]
    assert _same(*lines, "/etc/passwd", "/nonexistent/x.avi"), lines


# -- outbound connections --------------------------------------------------------------------
@pytest.fixture
def ports():
    """``(listening, closed, accepted)``: a listening socket's port, a closed port, and a
    function returning how many connections reached the listening one."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    srv.setblocking(False)
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    closed = probe.getsockname()[1]
    probe.close()

    def accepted() -> int:
        n = 0
        time.sleep(0.2)
        while True:
            try:
                conn, _ = srv.accept()
            except BlockingIOError:
                return n
            conn.close()
            n += 1

    yield srv.getsockname()[1], closed, accepted
    srv.close()


def test_a_scheduler_not_configured_is_refused_before_any_connection(gui_app, ports):
    listening, closed, accepted = ports
    server, session = gui_app(schedulers=["tcp://10.0.0.5:8786"])
    open_addr, closed_addr = f"tcp://127.0.0.1:{listening}", f"tcp://127.0.0.1:{closed}"
    # the Uncertainty page's field
    unc = server.pages["uncertainty"]
    lines = []
    for addr in (open_addr, closed_addr):
        assert asyncio.run(unc.run_montecarlo_async({"iterations": 100, "scheduler": addr})) is None
        lines.append(unc.state.unc_error)
    assert "'scheduler'" in lines[0] and reach.NOT_CONFIGURED in lines[0]
    assert _same(*lines, open_addr, closed_addr), lines
    # the generic form of the Inspect page, for both plugins that take a scheduler
    for pid in ("uncertainty.montecarlo", "photogrammetry.reconstruct"):
        got = []
        for addr in (open_addr, closed_addr):
            assert asyncio.run(server.pages["inspect"].run_form(pid, {"scheduler": addr}, {})) is None
            got.append(server.pages["inspect"].state.run_reason)
        assert reach.NOT_CONFIGURED in got[0] and _same(*got, open_addr, closed_addr), got
    # and any run a page's job starts (camcmm.worker.run), whatever page forgot to check
    from camcmm import worker

    for addr in (open_addr, closed_addr):
        with pytest.raises(InputError, match=re.escape(reach.NOT_CONFIGURED)):
            asyncio.run(unc.job.call(worker.run, session.host, "uncertainty.montecarlo", {}, {"scheduler": addr}))
    assert accepted() == 0  # nothing ever connected to the listening socket
    # the configured one passes the check (the run then connects to it)
    spec = session.host.get("uncertainty.montecarlo")
    assert session.roots.check_params(spec.parameters, {"scheduler": " tcp://10.0.0.5:8786/ "}) == {
        "scheduler": "tcp://10.0.0.5:8786"
    }
    # outside a server run (the CLI) nothing is checked
    assert reach.check_addresses(spec.parameters, {"scheduler": open_addr}) == {"scheduler": open_addr}


def test_serve_takes_scheduler_addresses():
    import argparse

    from camcmm.errors import CamcmmError
    from camcmm.gui.app import add_serve_arguments, scheduler_list

    ap = argparse.ArgumentParser()
    add_serve_arguments(ap)
    args = ap.parse_args(["--scheduler", "tcp://a:8786", "--scheduler", "tcp://b:8786"])
    assert scheduler_list(args.scheduler) == ["tcp://a:8786", "tcp://b:8786"]
    assert ap.parse_args([]).scheduler == []
    for bad in ("", "tcp://a:1 tcp://b:2"):
        with pytest.raises(CamcmmError, match="--scheduler"):
            scheduler_list([bad])
