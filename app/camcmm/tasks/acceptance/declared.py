"""The running standard's declaration (:class:`camcmm.standard.StandardDeclaration`):
the one place the task (and the page) learns parameter symbols, signs, units, artefact fields and
positions. A standard that predates ``declare()`` gets one read off its
``requirements()``: plain symbols, no artefact fields."""

from __future__ import annotations

from typing import Any

from camcmm.errors import InputError
from camcmm.standard import PositionSpec, QualityParameter, StandardDeclaration, TestDeclaration


def declaration_of(std: Any, sid: str) -> StandardDeclaration:
    """``std.declare()``, checked; or the declaration its requirements imply."""
    declare = getattr(std, "declare", None)
    if callable(declare):
        decl = declare()
        if not isinstance(decl, StandardDeclaration):
            raise InputError(
                f"standard plugin {sid!r}: declare() returned {type(decl).__name__}, "
                "not a StandardDeclaration (camcmm.api)"
            )
        return decl
    reqs = std.requirements(None)
    keys = list(dict.fromkeys(p for r in reqs for p in r.get("parameters") or []))
    tests = tuple(
        TestDeclaration(
            r["test"],
            r.get("label") or r["test"],
            r["test"],
            tuple(r.get("parameters") or ()),
            int(r.get("min_count") or 0),
            int(r.get("repeats") or 1),
            bool(r.get("required", True)),
        )
        for r in reqs
    )
    positions = tuple(
        PositionSpec(r["test"], p["id"], p.get("label") or p["id"], r["test"], p.get("hint") or "")
        for r in reqs
        for p in r.get("positions") or []
    )
    return StandardDeclaration(sid, sid, tuple(QualityParameter(k, k, k) for k in keys), (), tests, positions)


def artefact_kind(decl: StandardDeclaration, test: str) -> str:
    """The artefact kind a test measures (the test's own name when undeclared)."""
    t = decl.test(test)
    return t.artefact if t is not None else test


def artefact_fields(decl: StandardDeclaration, test: str) -> list[Any]:
    """The declared fields of the artefact a test measures ([] when undeclared)."""
    kind = decl.artefact(artefact_kind(decl, test))
    return list(kind.fields) if kind is not None else []


def parameter(decl: StandardDeclaration | None, key: str) -> QualityParameter:
    return decl.parameter(key) if decl is not None else QualityParameter(key, key, key)
