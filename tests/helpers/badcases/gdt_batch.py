"""Bad inputs of ``camcmm gdt batch PLAN CLOUD...`` (issue 28). Ids start with ``gdtbatch-``.

What makes the batch impossible is refused before any part, in one line naming it: the
plan (missing, empty, a bad key), an option (``--subgroup``, ``--confidence``,
``--align``, ``--k``), the nominal (missing, junk), an output (``--qif`` or ``--report`` a file, ``--csv``
in a missing folder), a work folder that cannot be made. What concerns one part is that
part's failure, listed, and the batch goes on: exit 0 with the failure in ``warnings`` —
a cloud missing, an image, NaN coordinates, the same file twice, a corrupt record in the
work folder (ignored, said).

The valid part: the block of helpers/gdt_parts.py at a low density (about 400 points)
and the plan of helpers/gdt_batch.py; each case runs in well under a second.
"""

from __future__ import annotations

import functools
import json

from helpers import gdt_batch as gb
from helpers import gdt_parts as g
from helpers.badinputs import Case, _xyz_text, png

PLAN, CLOUD = "plan.yaml", "p1.xyz"


@functools.lru_cache(maxsize=1)
def _cloud() -> bytes:
    return _xyz_text(g.block(density=0.02, n_min=25).points)


@functools.lru_cache(maxsize=1)
def _plan() -> bytes:
    return g.plan_yaml(gb.plan_document()).encode()


def _case(cid: str, names: tuple[str, ...], *argv: str, files: dict[str, bytes] | None = None) -> Case:
    base = {PLAN: _plan(), CLOUD: _cloud()}
    base.update(files or {})
    args = argv or (PLAN, CLOUD)
    return Case(f"gdtbatch-{cid}", ("gdt", "batch", *args, "--align", "none", "--json"), base, names)


def cases() -> list[Case]:
    bad_plan = json.dumps({**gb.plan_document(), "band": -1}).encode()
    return [
        # the plan: refused before any part
        _case("plan-missing", ("none.yaml",), "none.yaml", CLOUD),
        _case("plan-empty", (PLAN,), files={PLAN: b""}),
        _case("plan-bad-band", ("band",), files={PLAN: bad_plan}),
        # the options
        _case("subgroup-zero", ("--subgroup",), PLAN, CLOUD, "--subgroup", "0"),
        _case("subgroup-huge", ("--subgroup",), PLAN, CLOUD, "--subgroup", "1000"),
        _case("confidence-one", ("--confidence",), PLAN, CLOUD, "--confidence", "1"),
        _case("confidence-nan", ("--confidence",), PLAN, CLOUD, "--confidence", "nan"),
        _case("k-zero", ("--k",), PLAN, CLOUD, "--k", "0"),
        _case("nominal-missing", ("n.step",), PLAN, CLOUD, "--nominal", "n.step"),
        _case("nominal-junk", ("n.stl",), PLAN, CLOUD, "--nominal", "n.stl", files={"n.stl": b"solid\x00 junk"}),
        # the outputs and the work folder
        _case("qif-a-file", ("q.txt",), PLAN, CLOUD, "--qif", "q.txt", files={"q.txt": b"x"}),
        _case("qif-below-a-file", ("f.txt",), PLAN, CLOUD, "--qif", "f.txt/q", files={"f.txt": b"x"}),
        _case("report-a-file", ("r.txt",), PLAN, CLOUD, "--report", "r.txt", files={"r.txt": b"x"}),
        _case("csv-folder-missing", ("rows.csv",), PLAN, CLOUD, "--csv", "no/such/rows.csv"),
        _case("folder-in-project", ("w",), PLAN, CLOUD, "--project", "proj", "--folder", "proj/w"),
        _case("folder-below-a-file", ("f.txt",), PLAN, CLOUD, "--folder", "f.txt/work", files={"f.txt": b"x"}),
        # one part's failure: listed, the batch goes on (exit 0, a warning)
        _case("cloud-missing", ("none.xyz",), PLAN, CLOUD, "none.xyz"),
        _case("cloud-an-image", ("p2.ply",), PLAN, CLOUD, "p2.ply", files={"p2.ply": png(4, 4)}),
        _case("cloud-nan", ("p2.xyz",), PLAN, "p2.xyz", files={"p2.xyz": b"1 2 3\nnan 0 0\n4 5 6\n"}),
        _case("cloud-twice", (CLOUD,), PLAN, CLOUD, "copy.xyz", files={"copy.xyz": _cloud()}),
        _case(
            "record-corrupt",
            ("bad.json",),
            PLAN,
            CLOUD,
            "--folder",
            "w",
            files={"w/bad.json": b"{not json", "w/other.json": b'{"kind": "camcmm gdt batch part"}'},
        ),
    ]
