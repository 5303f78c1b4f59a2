"""The argparse parser every camcmm command uses (the top level, subcommands and
``camcmm run PLUGIN``), kept apart so that ``main`` and ``core`` both import it."""

from __future__ import annotations

import argparse
import sys


class Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as one line on stderr (exit 2)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        print(f"{self.prog}: {message}", file=sys.stderr)  # prog is "camcmm" or "camcmm SUBCOMMAND"
        raise SystemExit(2)
