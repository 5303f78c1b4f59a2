"""The command line as the tests drive it: ``python -m camcmm`` in a subprocess (run_camcmm,
cli_json, cli_refused) and in-process (refused, main_run, main_json, main_text, main_refused).

The in-process ones call ``camcmm.cli.main.main`` (what ``python -m camcmm`` runs) with
pytest's ``capfd``: the same exit code, stdout and stderr, without the 1-2 s of interpreter
start and imports a subprocess costs. A test about the process itself (exit on a signal, a
killed run, nothing else on stdout of a fresh interpreter) keeps the subprocess."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

from camcmm.cli.main import main


def run_camcmm(*args, ok=True, timeout=300, **kw):
    """``python -m camcmm ARGS`` in a subprocess; asserts exit 0 when ``ok``; returns the
    CompletedProcess (text)."""
    proc = subprocess.run(
        [sys.executable, "-m", "camcmm", *map(str, args)], capture_output=True, text=True, timeout=timeout, **kw
    )
    if ok:
        assert proc.returncode == 0, proc.stderr
    return proc


def cli_json(*args, **kw):
    """``run_camcmm(*args)`` that must succeed; its stdout parsed as the one JSON document."""
    return json.loads(run_camcmm(*args, **kw).stdout)


def cli_refused(*args, code=None, **kw) -> str:
    """``run_camcmm(*args)`` that must be refused: a non-zero exit (``code`` if given) and one
    stderr line ``camcmm: error: …``, returned."""
    proc = run_camcmm(*args, ok=False, **kw)
    assert proc.returncode != 0 if code is None else proc.returncode == code, (proc.returncode, proc.stderr)
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("camcmm: error:"), proc.stderr
    return proc.stderr


def refused(capsys, argv, needle: str) -> str:
    """Run ``camcmm argv``; the one stderr line, which must contain ``needle``."""
    rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert rc != 0, out
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err and "internal error" not in err, err
    assert needle in lines[0], lines[0]
    return lines[0]


#: What a fresh interpreter does not print (Python's default warning filters); every other
#: warning it would print once per place on stderr, and so does :func:`_main`.
_SILENT = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)


def _main(capture, args) -> tuple[int, str, str]:
    """``camcmm ARGS`` in this process: (exit code, stdout, stderr). ``capture`` is pytest's
    ``capfd`` (file descriptors: also what native libraries write, as a process's output
    holds it) or ``capsys``. Warnings go to stderr as a fresh interpreter prints them, so a
    check of "one line on stderr" still sees them."""
    capture.readouterr()  # what the test printed before is not the command's
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            rc = main([str(a) for a in args])
        except SystemExit as exc:  # argparse's --help / usage exits, as the process would
            rc = exc.code if isinstance(exc.code, int) else 1
    out, err = capture.readouterr()
    seen = set()
    for w in caught:
        where = (w.category, str(w.message), w.filename, w.lineno)
        if not issubclass(w.category, _SILENT) and where not in seen:
            seen.add(where)
            err += warnings.formatwarning(w.message, w.category, w.filename, w.lineno)
    return rc, out, err


def main_run(capture, *args) -> tuple[int, str, str]:
    """:func:`run_camcmm` with ``ok=False`` in this process (see :func:`_main`): (exit code,
    stdout, stderr)."""
    return _main(capture, args)


def main_json(capture, *args):
    """:func:`cli_json` in this process (see :func:`_main`): ``camcmm ARGS`` must exit 0;
    its stdout parsed as the one JSON document."""
    rc, out, err = _main(capture, args)
    assert rc == 0, err
    return json.loads(out)


def main_text(capture, *args) -> str:
    """:func:`run_camcmm` in this process (see :func:`_main`) that must exit 0: its stdout."""
    rc, out, err = _main(capture, args)
    assert rc == 0, err
    return out


def main_refused(capture, *args, code=None) -> str:
    """:func:`cli_refused` in this process (see :func:`_main`): a non-zero exit (``code`` if
    given) and one stderr line ``camcmm: error: …``, returned."""
    rc, _, err = _main(capture, args)
    assert rc != 0 if code is None else rc == code, (rc, err)
    assert err.count("\n") == 1 and err.startswith("camcmm: error:"), err
    return err
