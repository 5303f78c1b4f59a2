"""Generated bad inputs over every reader and every command (issue 13's "Done when").

Each case of tests/badinputs.py is one test: ``camcmm <argv>`` on generated files must
exit non-zero with exactly one line on stderr naming the file or the value (no
traceback, no "internal error"), or exit 0 with an explicit warning; never die of a
signal, hang past its timeout or add more than 1 GB. The cases run in-process in a
few long-lived worker processes (``CAMCMM_BADINPUT_WORKERS``, default 2), all at once
for the selected tests, before the first of them reports.

Cases that still fail in another part of the work are marked xfail(strict=True) with
the area and what happens, so that the day they are fixed the mark has to go.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from helpers import badinputs as bi  # noqa: E402

CASES = bi.all_cases()

#: case id -> "<area>: <what happens>" for a failure that belongs to another piece of work and
#: is not fixed yet (``python tests/badinputs.py [ID ...]`` prints each case's verdict). Strict
#: xfails, so the fix has to remove its line. Empty: every case behaves.
KNOWN: dict[str, str] = {}


def _param(case_id: str):
    if case_id in KNOWN:
        return pytest.param(case_id, marks=pytest.mark.xfail(strict=True, reason=KNOWN[case_id]))
    return case_id


@pytest.fixture(scope="module")
def results(request):
    """Run every selected case once, in parallel workers; case id -> result."""
    here = request.node.fspath if hasattr(request.node, "fspath") else None
    wanted = [
        item.callspec.params["case_id"]
        for item in request.session.items
        if getattr(item, "originalname", None) == "test_bad_input" and item.fspath == here
    ]
    workers = int(os.environ.get("CAMCMM_BADINPUT_WORKERS", "0")) or min(2, os.cpu_count() or 1)
    return bi.run_cases([CASES[i] for i in wanted], workers)


def test_there_are_enough_cases_over_every_reader_and_command():
    firsts = {c.argv[0] for c in CASES.values()}
    assert len(CASES) >= 300
    assert {
        "info",
        "fit",
        "verify",
        "inspect",
        "uncertainty",
        "calibrate",
        "scale",
        "gauge-block",
        "fringe",
        "simulate",
        "run",
        "devices",
    } <= firsts
    exts = {Path(c.argv[1]).suffix for c in CASES.values() if c.argv[0] == "info" and len(c.argv) > 1}
    assert {".ply", ".pcd", ".xyz", ".txt", ".csv", ".stl", ".obj", ".e57", ".png", ".jpg", ".tif", ".bmp"} <= exts
    subs = {
        c.argv[1] for c in CASES.values() if c.argv[0] in ("uncertainty", "calibrate", "fringe") and len(c.argv) > 1
    }
    assert {"budget", "iso15530-3", "montecarlo", "camera", "stereo", "patterns", "reconstruct"} <= subs


def test_the_readers_and_commands_added_since_have_their_own_300_cases():
    """Issue 26: height maps, COLMAP text/binary, Metashape, photogrammetry reconstruct and
    import, speckle stability, the speckle study, the light field and part-3 plans."""
    from helpers import badcases

    new = badcases.cases()
    assert len(new) >= 300, len(new)
    commands = {" ".join(c.argv[:2]) for c in new}
    assert {
        "photogrammetry import",
        "photogrammetry reconstruct",
        "speckle stability",
        "study speckle",
        "lightfield gradient",
        "lightfield study",
        "fuse csi",
        "verify",
    } <= commands | {c.argv[0] for c in new}, sorted(commands)
    exts = {Path(c.argv[1]).suffix for c in new if c.argv[0] == "info" and len(c.argv) > 1}
    assert {".x3p", ".sdf"} <= exts, sorted(exts)


# One xdist work unit: `results` runs every selected case of the session, and a worker's session
# holds them all; without the group both workers would run the whole matrix once each.
@pytest.mark.parametrize("case_id", [_param(i) for i in CASES])
@pytest.mark.slow
@pytest.mark.xdist_group("bad-inputs")
def test_bad_input(case_id, results):
    case = CASES[case_id]
    problem = bi.verdict(case, results.get(case_id, {"rc": "not run: its worker thread stopped"}))
    assert problem is None, f"camcmm {' '.join(case.argv)}: {problem}"


@pytest.mark.parametrize(
    "what,expected",
    [
        ("segv", "crash: the worker died (signal SIGSEGV)"),
        ("hang", "hang: no answer in 3 s"),
        ("alloc", "used 1."),
        ("traceback", "traceback: "),
        ("two-lines", "2 lines on stderr"),
        ("silent", "exit 0 without a warning"),
        ("native-stderr", "2 lines on stderr"),
        ("ok-error", None),
    ],
)
@pytest.mark.slow
def test_the_harness_catches_each_misbehaviour(what, expected):
    """The verdicts above can fail: each kind of misbehaviour, done on purpose in a worker."""
    if what == "ok-error":
        case = bi.Case("selftest-ok", ("info", "x.ply"), {"x.ply": b"junk"}, ("x.ply",), timeout=60)
    else:
        case = bi.Case(f"selftest-{what}", ("__selftest__", what), {}, ("x.ply",), timeout=3 if what == "hang" else 60)
    res = bi.run_cases([case], 1)[case.id]
    problem = bi.verdict(case, res)
    if expected is None:
        assert problem is None, problem
    else:
        assert problem is not None and problem.startswith(expected), problem
