"""What the command-line tests assert of a refusal (shared by the validation tests)."""

from __future__ import annotations

from camcmm.cli.main import main


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
