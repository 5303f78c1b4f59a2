"""Bad output paths of ``camcmm gdt evaluate PLAN CLOUD --qif FILE --csv FILE`` (issue 28).
Ids start with ``qifout-``.

The output files are checked before the plan or the cloud is read (one line naming the
path and the option): a folder where a file is expected, a file in a folder that does not
exist (or below a file), an empty path. The plan and cloud are valid (the synthetic block
of helpers/gdt_parts.py, a few hundred points), so a case that got past the check would
evaluate and exit 0 without the refusal the verdict asks for.
"""

from __future__ import annotations

import functools

from helpers import gdt_parts as g
from helpers.badinputs import Case, _xyz_text

PLAN, CLOUD = "plan.yaml", "part.xyz"


@functools.lru_cache(maxsize=1)
def _files() -> tuple[tuple[str, bytes], ...]:
    return ((PLAN, g.plan_yaml().encode()), (CLOUD, _xyz_text(g.block(density=0.02, n_min=25).points)))


def _case(cid: str, opts: tuple[str, ...], names: tuple[str, ...], extra: dict[str, bytes] | None = None) -> Case:
    files = dict(_files()) | (extra or {})
    return Case(f"qifout-{cid}", ("gdt", "evaluate", PLAN, CLOUD, *opts, "--json"), files, names)


def cases() -> list[Case]:
    folder = {"out/keep.txt": b"a folder, not a file\n"}
    return [
        _case("qif-is-folder", ("--qif", "out"), ("out",), folder),
        _case("csv-is-folder", ("--csv", "out"), ("out",), folder),
        _case("qif-no-folder", ("--qif", "missing/r.qif"), ("missing/r.qif",)),
        _case("csv-no-folder", ("--csv", "missing/rows.csv"), ("missing/rows.csv",)),
        _case("qif-below-a-file", ("--qif", f"{PLAN}/r.qif"), (f"{PLAN}/r.qif",)),
        _case("qif-blank", ("--qif", " "), ("--qif",)),
        _case("csv-empty", ("--csv", ""), ("--csv",)),
    ]
