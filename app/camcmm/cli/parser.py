"""The argparse parser every camcmm command uses (the top level, subcommands and
``camcmm run PLUGIN``), kept apart so that ``main`` and ``core`` both import it."""

from __future__ import annotations

import argparse
import re
import sys
from typing import Any

#: What argparse takes for a negative number, not an option: also a vector value such as
#: ``--min -1,-2.5,3e-3`` (argparse's own pattern knows only ``-1`` and ``-.5``, so a
#: coordinate vector starting with a minus was refused as "expected one argument").
NEGATIVE_NUMBERS = re.compile(r"^-\.?\d[\d.,eE+\-\s]*$")


class Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as one line on stderr (exit 2)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBERS

    def error(self, message: str) -> None:  # type: ignore[override]
        print(f"{self.prog}: {message}", file=sys.stderr)  # prog is "camcmm" or "camcmm SUBCOMMAND"
        raise SystemExit(2)
