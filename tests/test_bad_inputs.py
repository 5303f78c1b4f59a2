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
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import badinputs as bi  # noqa: E402

CASES = bi.all_cases()

#: case id -> "<area>: <what happens>" for failures that belong to another part of issue 13
#: (regenerated from a run of ``python tests/badinputs.py``; strict, so a fix removes its line).
KNOWN: dict[str, str] = {
    "fit-line-two-points":
        "fitting (H7): exit 0 without a warning (fit line two.xyz)",
    "fit-line-identical-points":
        "fitting (H7): names none of ['same.xyz']: line fit: all 50 points coincide",
    "fit-line-empty-ply":
        "fitting (H7): names none of ['empty.ply']: line fit needs at least 2 points, got 0",
    "fit-plane-identical-points":
        "fitting (H7): names none of ['same.xyz']: plane fit: all 50 points coincide",
    "fit-plane-empty-ply":
        "fitting (H7): names none of ['empty.ply']: plane fit needs at least 3 points, got 0",
    "fit-circle-identical-points":
        "fitting (H7): names none of ['same.xyz']: circle fit: all 50 points coincide",
    "fit-circle-empty-ply":
        "fitting (H7): names none of ['empty.ply']: circle fit needs at least 3 points, got 0",
    "fit-sphere-identical-points":
        "fitting (H7): names none of ['same.xyz']: sphere fit: all 50 points coincide",
    "fit-sphere-empty-ply":
        "fitting (H7): names none of ['empty.ply']: sphere fit needs at least 4 points, got 0",
    "fit-cylinder-identical-points":
        "fitting (H7): names none of ['same.xyz']: cylinder fit: all 50 points coincide",
    "fit-cylinder-empty-ply":
        "fitting (H7): names none of ['empty.ply']: cylinder fit needs at least 5 points, got 0",
    "fit-plane-collinear":
        "fitting (H7): names none of ['line.xyz']: plane fit: the points are collinear; a plane needs points off ",
    "fit-circle-collinear":
        "fitting (H7): names none of ['line.xyz']: circle fit: the points are collinear; a circle needs points of",
    "fit-sphere-collinear":
        "fitting (H7): names none of ['line.xyz']: sphere fit: the points lie on a plane (coplanar); a sphere nee",
    "fit-cylinder-collinear":
        "fitting (H7): names none of ['line.xyz']: cylinder fit: the points are collinear; a cylinder needs point",
    "inspect-tolerance-0":
        "parameter limits (H3): exit 0 without a warning (inspect c.xyz --nominal n.stl --tolerance 0)",
    "inspect-pairs-nan":
        "inspection: names none of ['p.json', 'nan', 'NaN']: point pairs: coordinates must be finite",
    "budget-all-zero":
        "uncertainty (H4): exit 0 without a warning (uncertainty budget b.yaml)",
    "montecarlo-out-is-file":
        "uncertainty (H4): internal FileExistsError: [Errno 17] File exists: 'o.txt'",
    "calibrate-subpix-window-0":
        "calibration (H2/H7): internal error: OpenCV(5.0.0) /io/opencv/modules/imgproc/src/cornersubpix.cpp:64: e",
    "calibrate-subpix-window--1":
        "calibration (H2/H7): internal error: OpenCV(5.0.0) /io/opencv/modules/imgproc/src/cornersubpix.cpp:64: e",
    "calibrate-subpix-window-100000":
        "calibration (H2/H7): internal error: OpenCV(5.0.0) /io/opencv/modules/imgproc/src/cornersubpix.cpp:65: e",
    "fringe-reconstruct-saturation-0":
        "fringe / parameter limits (H3/H4): names none of ['saturation', 'saturation', '0']: images: no pixel dec",
    "simulate-sensor-bits-bad":
        "virtual lab (H4): exit 0 without a warning (simulate scene.yaml --out out)",
    "scale-one-row":
        "calibration.scale (H4): names none of ['i.csv']: run '1' has 1 positions; a regression needs at least 3",
    "scale-huge-row":
        "calibration.scale (H4): names none of ['i.csv']: run '1' has 2 positions; a regression needs at least 3",
    "scale-accuracy--1":
        "calibration.scale (H4): exit 0 without a warning (scale --interferometer i.csv --accuracy -1)",
    "scale-accuracy-nan":
        "calibration.scale (H4): exit 0 without a warning (scale --interferometer i.csv --accuracy nan)",
    "scale-accuracy-2":
        "calibration.scale (H4): exit 0 without a warning (scale --interferometer i.csv --accuracy 2)",
    "scale-length-0":
        "calibration.scale (H4): exit 0 without a warning (scale --interferometer i.csv --length 0)",
    "scale-length--5":
        "calibration.scale (H4): exit 0 without a warning (scale --interferometer i.csv --length -5)",
    "scale-length-nan":
        "calibration.scale (H4): exit 0 without a warning (scale --interferometer i.csv --length nan)",
    "gauge-ransac-0":
        "calibration.gauge-block (H4): exit 0 without a warning (gauge-block g.xyz --nominal 25 --ransac-threshol",
    "gauge-ransac--1":
        "calibration.gauge-block (H4): 3 lines on stderr: /work/main/plugins/camcmm_plugins/calibration/gauge.py:",
    "gauge-ransac-nan":
        "calibration.gauge-block (H4): 3 lines on stderr: /work/main/plugins/camcmm_plugins/calibration/gauge.py:",
    "gauge-up-zero":
        "calibration.gauge-block (H4): exit 0 without a warning (gauge-block g.xyz --nominal 25 --up 0 0 0)",
    "gauge-up-nan":
        "calibration.gauge-block (H4): exit 0 without a warning (gauge-block g.xyz --nominal 25 --up nan 0 1)",
    "run-input-missing-file":
        "host / cli core: internal FileNotFoundError: [Errno 2] No such file or directory: 'gone.ply'",
    "run-fit-sphere-mesh":
        "host/fitting: names none of ['m.stl']: plugin 'fit.sphere' failed: TypeError: float() argument must be a",
    "run-fringe-patterns-huge":
        "cli core: camcmm run: internal ArgumentError: argument --out: conflicting option string: --out",
    "devices-simulate-stage-axes-0":
        "devices simulate-stage (H4): hang: no answer in 6 s",
    "devices-simulate-stage-resolution-0":
        "devices simulate-stage (H4): internal ZeroDivisionError: float division by zero",
    "devices-simulate-stage-resolution-nan":
        "devices simulate-stage (H4): internal ValueError: cannot convert float NaN to integer",
    "devices-simulate-stage-speed--200":
        "devices simulate-stage (H4): hang: no answer in 6 s",
    "devices-simulate-stage-travel--5":
        "devices simulate-stage (H4): hang: no answer in 6 s",
    "devices-simulate-stage-address-1000":
        "devices simulate-stage (H4): hang: no answer in 6 s",
    "devices-simulate-stage-tcp-not-an-address":
        "devices simulate-stage (H4): internal ValueError: invalid literal for int() with base 10: 'not-an-addres",
    "devices-simulate-stage-tcp-127.0.0.1:99999":
        "devices simulate-stage (H4): internal OverflowError: bind(): port must be 0-65535.",
    "devices-simulate-stage-seed--1":
        "devices simulate-stage (H4): hang: no answer in 6 s",
}


def _param(case_id: str):
    if case_id in KNOWN:
        return pytest.param(case_id, marks=pytest.mark.xfail(strict=True, reason=KNOWN[case_id]))
    return case_id


@pytest.fixture(scope="module")
def results(request):
    """Run every selected case once, in parallel workers; case id -> result."""
    here = request.node.fspath if hasattr(request.node, "fspath") else None
    wanted = [item.callspec.params["case_id"] for item in request.session.items
              if getattr(item, "originalname", None) == "test_bad_input" and item.fspath == here]
    workers = int(os.environ.get("CAMCMM_BADINPUT_WORKERS", "0")) or min(2, os.cpu_count() or 1)
    return bi.run_cases([CASES[i] for i in wanted], workers)


def test_there_are_enough_cases_over_every_reader_and_command():
    firsts = {c.argv[0] for c in CASES.values()}
    assert len(CASES) >= 300
    assert {"info", "fit", "verify", "inspect", "uncertainty", "calibrate", "scale", "gauge-block", "fringe",
            "simulate", "run", "devices"} <= firsts
    exts = {Path(c.argv[1]).suffix for c in CASES.values() if c.argv[0] == "info" and len(c.argv) > 1}
    assert {".ply", ".pcd", ".xyz", ".txt", ".csv", ".stl", ".obj", ".e57", ".png", ".jpg", ".tif", ".bmp"} <= exts
    subs = {c.argv[1] for c in CASES.values()
            if c.argv[0] in ("uncertainty", "calibrate", "fringe") and len(c.argv) > 1}
    assert {"budget", "iso15530-3", "montecarlo", "camera", "stereo", "patterns", "reconstruct"} <= subs


@pytest.mark.parametrize("case_id", [_param(i) for i in CASES])
def test_bad_input(case_id, results):
    case = CASES[case_id]
    problem = bi.verdict(case, results.get(case_id, {"rc": "not run: its worker thread stopped"}))
    assert problem is None, f"camcmm {' '.join(case.argv)}: {problem}"


@pytest.mark.parametrize("what,expected", [
    ("segv", "crash: the worker died (signal SIGSEGV)"),
    ("hang", "hang: no answer in 3 s"),
    ("alloc", "used 1."),
    ("traceback", "traceback: "),
    ("two-lines", "2 lines on stderr"),
    ("silent", "exit 0 without a warning"),
    ("native-stderr", "2 lines on stderr"),
    ("ok-error", None),
])
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
