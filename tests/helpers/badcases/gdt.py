"""Bad inputs of ``camcmm gdt evaluate PLAN CLOUD`` (issue 27). Ids start with ``gdt-``.

The plan is refused before the cloud is read, each problem one line naming the plan's
file and the key path (``features.A.type``, ``characteristics[0].feature``,
``alignment.sideways``, ``rps.R1.fixes``); a cloud that is not one (an image, a mesh, an
empty PLY, NaN coordinates, a missing file) is refused naming its file; a cloud far from
the plan with the coarse start switched off is refused naming the plan (no feature has
points within its band), as is a datum or 3-2-1 alignment whose feature finds no points
(naming the plan and ``features.C``); options are refused naming the option. A plan whose features
find no points (three points, or a CAD face without a STEP nominal) is evaluated: exit 0,
those features and their characteristics "not evaluated", each in ``warnings``.

The valid blocks: the synthetic block of helpers/gdt_parts.py at a low density (about
400 points) and its plan; each case runs in well under a second.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from helpers import gdt_parts as g
from helpers.badinputs import ALIAS_BOMB, BAD_UTF8, Case, _xyz_text, ply_binary, png, stl_binary

PLAN, CLOUD = "plan.yaml", "part.xyz"


@functools.lru_cache(maxsize=1)
def _cloud() -> bytes:
    return _xyz_text(g.block(density=0.02, n_min=25).points)


def _plan(edit: Callable[[dict[str, Any]], Any] | None = None) -> bytes:
    doc = copy.deepcopy(g.plan_document())
    if edit is not None:
        edit(doc)
    return g.plan_yaml(doc).encode()


def _case(cid: str, plan: bytes | None, names: tuple[str, ...], *opts: str, cloud: bytes | None = None) -> Case:
    files = {CLOUD: _cloud() if cloud is None else cloud}
    if plan is not None:
        files[PLAN] = plan
    return Case(f"gdt-{cid}", ("gdt", "evaluate", PLAN, CLOUD, *opts, "--json"), files, names)


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    """An edit setting ``doc[a][b]...`` (dotted path; list indices as numbers)."""

    def edit(doc: dict[str, Any]) -> None:
        keys = [int(k) if k.isdigit() else k for k in path.split(".")]
        node: Any = doc
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = value

    return edit


def cases() -> list[Case]:
    plan_bad = [
        ("plan-empty", b"", (PLAN,)),
        ("plan-not-yaml", b"features: {A: [1, 2\n", (PLAN,)),
        ("plan-an-image", png(4, 4), (PLAN,)),
        ("plan-bad-utf8", BAD_UTF8, (PLAN,)),
        ("plan-alias-bomb", ALIAS_BOMB, (PLAN,)),
        ("plan-a-list", b"- 1\n- 2\n", (PLAN,)),
        ("plan-no-features", b"unit: mm\nband: 0.5\n", ("features",)),
        ("plan-unknown-type", _plan(_set("features.A.type", "hexagon")), ("features.A.type",)),
        ("plan-nan-point", _plan(_set("features.A.point", [float("nan"), 0, 0])), ("features.A.point",)),
        ("plan-normal-zero", _plan(_set("features.B.normal", [0, 0, 0])), ("features.B.normal",)),
        ("plan-diameter-text", _plan(_set("features.H1.diameter", "ten")), ("features.H1.diameter",)),
        ("plan-band-negative", _plan(_set("band", -0.5)), ("band",)),
        ("plan-unit-unknown", _plan(_set("unit", "furlong")), ("unit",)),
        ("plan-misspelt-key", _plan(_set("features.H1.diamter", 10)), ("features.H1.diamter",)),
        ("plan-char-feature-unknown", _plan(_set("characteristics.0.feature", "Z9")), ("Z9",)),
        ("plan-char-type-unknown", _plan(_set("characteristics.0.type", "wobble")), ("characteristics[0].type",)),
        ("plan-datum-unknown", _plan(_set("characteristics.1.datums", ["A", "Q"])), ("Q",)),
        ("plan-tolerance-text", _plan(_set("characteristics.0.tolerance", "small")), ("characteristics[0].tolerance",)),
        ("plan-limits-crossed", _plan(_set("characteristics.4.lower", 0.5)), ("characteristics[4].lower",)),
        ("plan-alignment-key", _plan(_set("alignment", {"sideways": 1})), ("alignment.sideways",)),
        ("plan-alignment-boxes", _plan(_set("alignment", {"boxes": [[1, 2, 3]]})), ("alignment.boxes",)),
    ]
    out = [_case(cid, data, names, "--align", "none") for cid, data, names in plan_bad]
    out += [
        _case("plan-missing", None, (PLAN,)),
        Case("gdt-plan-a-folder", ("gdt", "evaluate", "d", CLOUD), {"d/": b"", CLOUD: _cloud()}, ("d",)),
        _case("rps-missing", _plan(), ("rps",), "--align", "rps"),
        _case(
            "rps-bad-fixes",
            _plan(_set("rps", {"R1": {"feature": "H1", "fixes": ["w"]}})),
            ("rps.R1.fixes",),
            "--align",
            "rps",
        ),
        _case(
            "3-2-1-cylinder-primary",
            _plan(_set("alignment", {"features": ["H1", "A", "B"]})),
            ("H1",),
            "--align",
            "3-2-1",
        ),
        _case(
            "datum-feature-without-points",
            _plan(_set("features.C.box", [[100, 100, 100], [101, 101, 101]])),
            ("features.C",),
            "--align",
            "datums",
        ),
        # the cloud
        Case("gdt-cloud-missing", ("gdt", "evaluate", PLAN, "none.xyz"), {PLAN: _plan()}, ("none.xyz",)),
        Case(
            "gdt-cloud-an-image",
            ("gdt", "evaluate", PLAN, "part.ply"),
            {PLAN: _plan(), "part.ply": png(4, 4)},
            ("part.ply",),
        ),
        Case(
            "gdt-cloud-a-mesh",
            ("gdt", "evaluate", PLAN, "part.stl"),
            {PLAN: _plan(), "part.stl": stl_binary(np.eye(3)[None] * 10.0)},
            ("part.stl",),
        ),
        Case(
            "gdt-cloud-empty-ply",
            ("gdt", "evaluate", PLAN, "part.ply"),
            {PLAN: _plan(), "part.ply": ply_binary(np.zeros((0, 3)))},
            ("part.ply",),
        ),
        _case("cloud-nan", _plan(), (CLOUD,), cloud=b"1 2 3\nnan 0 0\n4 5 6\n"),
        _case("cloud-far-no-start", _plan(), (PLAN,), "--start", "none", cloud=_xyz_text(np.full((50, 3), 1e6))),
        _case("cloud-three-points", _plan(), ("H1",), "--align", "none", cloud=b"0 0 0\n1 0 0\n0 1 0\n"),
        _case(
            "face-without-cad",
            _plan(_set("features.F1", {"type": "face", "cad": 3})),
            ("F1",),
            "--align",
            "none",
        ),
        # the options
        _case("k-zero", _plan(), ("--k",), "--k", "0"),
        _case("align-unknown", _plan(), ("--align",), "--align", "sideways"),
        _case("iterations-zero", _plan(), ("--max-iterations",), "--max-iterations", "0"),
        Case(
            "gdt-nominal-junk",
            ("gdt", "evaluate", PLAN, CLOUD, "--nominal", "n.stl"),
            {PLAN: _plan(), CLOUD: _cloud(), "n.stl": b"solid\x00\x01 not really"},
            ("n.stl",),
        ),
    ]
    return out
