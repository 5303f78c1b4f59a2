"""The command line as the tests drive it: ``python -m camcmm`` in a subprocess (run_camcmm,
cli_json, cli_refused) and in-process (refused)."""

from __future__ import annotations

import json
import subprocess
import sys

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
