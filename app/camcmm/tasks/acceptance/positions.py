"""The positions of a running test as the operator sees them: counters per test, a
card per position with its repeats, values and verdicts, and the fit as the standard
words it (an evaluation's ``fit_text`` and ``fit`` rows)."""

from __future__ import annotations

from typing import Any

from camcmm.conformity import combine
from camcmm.errors import InputError
from camcmm.standard import StandardDeclaration

from .declared import parameter
from .state import TestState
from .values import _verdict, fmt_value


class Positions:
    """The positions of the running test (:class:`TestState`) as counters and cards."""

    def __init__(self, saved: TestState):
        self.saved = saved

    def progress(self) -> list[dict[str, Any]]:
        """Counters per test: ``{"test", "label", "done", "total", "required", "text",
        "complete"}`` — text like "7 of 10 <test label>"."""
        out = []
        for r in self.saved.requirements():
            slots = self.saved.slots(r["test"])
            done = sum(
                1
                for p in r["positions"]
                for mid in slots[p["id"]]
                if mid is not None and not (self.saved.evaluation(mid) or {}).get("error")
            )
            total = len(r["positions"]) * r["repeats"]
            required = r["min_count"] * r["repeats"]
            label = r["label"][:1].lower() + r["label"][1:]
            text = f"{done} of {total} {label}"
            if r["repeats"] > 1:
                text = f"{done} of {total} measurements of {label} ({len(r['positions'])} × {r['repeats']} repeats)"
            out.append(
                {
                    "test": r["test"],
                    "label": r["label"],
                    "done": done,
                    "total": total,
                    "required": required,
                    "text": text,
                    "complete": done >= required,
                }
            )
        return out

    @property
    def complete(self) -> bool:
        return self.saved.active and all(p["complete"] for p in self.progress())

    def cards(self) -> list[dict[str, Any]]:
        """Per test its position cards: id, label, hint, status (pending | done |
        error), the values with unit and per-position verdict, the error, the fit."""
        mpe = self.saved.plan.get("mpe") or {}
        decl = self.saved.declaration()
        errors = (self.saved.state or {}).get("errors") or {}
        blocks = []
        prog = {p["test"]: p for p in self.progress()}
        for r in self.saved.requirements():
            slots = self.saved.slots(r["test"])
            cards = []
            for p in r["positions"]:
                key = f"{r['test']}/{p['id']}"
                reps = []
                for i, mid in enumerate(slots[p["id"]]):
                    ev = self.saved.evaluation(mid)
                    reps.append(self._repeat_view(decl, i + 1, mid, ev, mpe))
                done = [x for x in reps if x["status"] == "done"]
                status = "done" if len(done) == len(reps) else ("partial" if done else "pending")
                if status != "done" and errors.get(key):
                    status = "error"
                cards.append(
                    {
                        "key": key,
                        "test": r["test"],
                        "id": p["id"],
                        "label": p.get("label") or p["id"],
                        "hint": p.get("hint") or "",
                        "status": status,
                        "error": errors.get(key, ""),
                        "repeats": reps,
                        "n_repeats": r["repeats"],
                        "verdict": combine(x["verdict"] for x in reps) if done else "",
                        "next_repeat": next((x["repeat"] for x in reps if x["status"] != "done"), None),
                    }
                )
            blocks.append({"test": r["test"], "label": r["label"], "progress": prog[r["test"]], "cards": cards})
        return blocks

    def _repeat_view(
        self, decl: StandardDeclaration, repeat: int, mid: Any, ev: dict | None, mpe: dict
    ) -> dict[str, Any]:
        if mid is None or ev is None:
            return {
                "repeat": repeat,
                "status": "pending",
                "values": [],
                "verdict": "",
                "measurement": None,
                "file": "",
                "fit": "",
                "warnings": [],
            }
        if ev.get("error"):
            return {
                "repeat": repeat,
                "status": "error",
                "values": [],
                "verdict": "",
                "measurement": int(mid),
                "file": ev.get("file") or "",
                "fit": ev["error"],
                "warnings": [],
            }
        values = []
        verdicts = []
        for param, v in (ev.get("values") or {}).items():
            verdict = _verdict(v, mpe.get(param))
            verdicts.append(verdict)
            q = parameter(decl, param)
            values.append(
                {
                    "param": param,
                    "symbol": q.symbol,
                    "text": fmt_value(v, q.signed, q.unit),
                    "verdict": verdict,
                    "mpe": mpe.get(param),
                }
            )
        return {
            "repeat": repeat,
            "status": "done",
            "values": values,
            "verdict": combine(verdicts),
            "measurement": int(mid),
            "file": ev.get("file") or "",
            "fit": str(ev.get("fit_text") or ""),
            "warnings": list(ev.get("warnings") or []),
        }

    def card(self, test: str, position: str) -> dict[str, Any]:
        for block in self.cards():
            for c in block["cards"]:
                if c["test"] == test and c["id"] == position:
                    return c
        raise InputError(f"no position {position!r} in {test}")


def fit_rows(ev: dict[str, Any], decl: StandardDeclaration | None = None) -> list[dict[str, str]]:
    """Rows ``{name, value}`` for the detail panel: each value with its symbol, then the
    rows the standard wrote about its fit (``fit``)."""
    rows = []
    for key, v in (ev.get("values") or {}).items():
        q = parameter(decl, key)
        rows.append({"name": q.symbol, "value": fmt_value(v, q.signed, q.unit)})
    for row in ev.get("fit") or []:
        if isinstance(row, dict) and row.get("name"):
            rows.append({"name": str(row["name"]), "value": str(row.get("value", ""))})
    return rows
