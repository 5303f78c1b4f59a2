"""The positions of a running test as the operator sees them: counters per test, a
card per position with its repeats, values and verdicts, and the fit in words."""

from __future__ import annotations

from typing import Any

from ...conformity import combine
from ...errors import InputError
from .values import SYMBOLS, _verdict, fmt_mm, fmt_value


class WizardPositions:
    """Counters and cards of :class:`~camcmm.gui.wizard.Wizard`."""

    def progress(self) -> list[dict[str, Any]]:
        """Counters per test: ``{"test", "label", "done", "total", "required", "text",
        "complete"}`` — text like "7 of 10 sphere positions"."""
        out = []
        for r in self.requirements():
            slots = self._slots(r["test"])
            done = sum(1 for p in r["positions"] for mid in slots[p["id"]]
                       if mid is not None and not (self.evaluation(mid) or {}).get("error"))
            total = len(r["positions"]) * r["repeats"]
            required = r["min_count"] * r["repeats"]
            label = r["label"][:1].lower() + r["label"][1:]
            text = f"{done} of {total} {label}"
            if r["repeats"] > 1:
                text = f"{done} of {total} measurements of {label} ({len(r['positions'])} × {r['repeats']} repeats)"
            out.append({"test": r["test"], "label": r["label"], "done": done, "total": total, "required": required,
                        "text": text, "complete": done >= required})
        return out

    @property
    def complete(self) -> bool:
        return self.active and all(p["complete"] for p in self.progress())

    def cards(self) -> list[dict[str, Any]]:
        """Per test its position cards: id, label, hint, status (pending | done |
        error), the values with unit and per-position verdict, the error, the fit."""
        mpe = self.plan.get("mpe") or {}
        errors = (self.state or {}).get("errors") or {}
        blocks = []
        prog = {p["test"]: p for p in self.progress()}
        for r in self.requirements():
            slots = self._slots(r["test"])
            cards = []
            for p in r["positions"]:
                key = f"{r['test']}/{p['id']}"
                reps = []
                for i, mid in enumerate(slots[p["id"]]):
                    ev = self.evaluation(mid)
                    reps.append(self._repeat_view(r["test"], i + 1, mid, ev, mpe))
                done = [x for x in reps if x["status"] == "done"]
                status = "done" if len(done) == len(reps) else ("partial" if done else "pending")
                if status != "done" and errors.get(key):
                    status = "error"
                cards.append({"key": key, "test": r["test"], "id": p["id"], "label": p.get("label") or p["id"],
                              "hint": p.get("hint") or "", "status": status, "error": errors.get(key, ""),
                              "repeats": reps, "n_repeats": r["repeats"],
                              "verdict": combine(x["verdict"] for x in reps) if done else "",
                              "next_repeat": next((x["repeat"] for x in reps if x["status"] != "done"), None)})
            blocks.append({"test": r["test"], "label": r["label"], "progress": prog[r["test"]], "cards": cards})
        return blocks

    def _repeat_view(self, test: str, repeat: int, mid: Any, ev: dict | None, mpe: dict) -> dict[str, Any]:
        if mid is None or ev is None:
            return {"repeat": repeat, "status": "pending", "values": [], "verdict": "", "measurement": None,
                    "file": "", "fit": "", "warnings": []}
        if ev.get("error"):
            return {"repeat": repeat, "status": "error", "values": [], "verdict": "", "measurement": int(mid),
                    "file": ev.get("file") or "", "fit": ev["error"], "warnings": []}
        values = []
        verdicts = []
        for param, v in (ev.get("values") or {}).items():
            verdict = _verdict(v, mpe.get(param))
            verdicts.append(verdict)
            values.append({"param": param, "symbol": SYMBOLS.get(param, param), "text": fmt_value(param, v),
                           "verdict": verdict, "mpe": mpe.get(param)})
        return {"repeat": repeat, "status": "done", "values": values, "verdict": combine(verdicts),
                "measurement": int(mid), "file": ev.get("file") or "", "fit": fit_text(ev),
                "warnings": list(ev.get("warnings") or [])}

    def card(self, test: str, position: str) -> dict[str, Any]:
        for block in self.cards():
            for c in block["cards"]:
                if c["test"] == test and c["id"] == position:
                    return c
        raise InputError(f"no position {position!r} in {test}")


def fit_text(ev: dict[str, Any]) -> str:
    """One line on the fit of an evaluation: what was fitted, points used/removed."""
    parts = []
    if ev.get("diameter") is not None:
        parts.append(f"Ø {ev['diameter']:.4f} mm")
    if ev.get("length") is not None:
        parts.append(f"L {ev['length']:.4f} mm")
    if isinstance(ev.get("lengths"), list):
        parts.append("L " + ", ".join(f"{x:.4f}" for x in ev["lengths"]) + " mm")
    form = ev.get("form") if isinstance(ev.get("form"), dict) else None
    if form and form.get("std") is not None:
        parts.append(f"σ {1000 * form['std']:.1f} µm")
    if ev.get("n_points") is not None:
        used = ev.get("n_used")
        pts = f"{ev['n_points']} pts" if used is None else f"{used} of {ev['n_points']} pts"
        parts.append(pts)
    if ev.get("n_removed"):
        parts.append(f"{ev['n_removed']} removed")
    return " · ".join(parts)


def fit_rows(ev: dict[str, Any]) -> list[dict[str, str]]:
    """Rows ``{name, value}`` describing an evaluation's fit for the detail panel."""
    rows: list[dict[str, str]] = []

    def add(name: str, value: str) -> None:
        rows.append({"name": name, "value": value})

    def xyz(v: Any, digits: int = 3) -> str:
        return "(" + ", ".join(f"{float(x):.{digits}f}" for x in v) + ") mm"

    for param, v in (ev.get("values") or {}).items():
        add(SYMBOLS.get(param, param), fmt_value(param, v))
    if ev.get("center") is not None:
        add("centre", xyz(ev["center"]))
    if ev.get("diameter") is not None:
        cal = ev.get("diameter_calibrated")
        add("Ø", fmt_mm(ev["diameter"]) + (f" (calibrated {float(cal):.4f})" if cal is not None else ""))
    if ev.get("length") is not None:
        cal = ev.get("length_calibrated")
        add("length", fmt_mm(ev["length"]) + (f" (calibrated {float(cal):.4f})" if cal is not None else ""))
    for i, sph in enumerate(ev.get("spheres") or []):
        if isinstance(sph, dict) and sph.get("center") is not None:
            add(f"sphere {i + 1}", xyz(sph["center"]) + (f", Ø {float(sph['diameter']):.4f} mm"
                                                          if sph.get("diameter") is not None else ""))
    if ev.get("normal") is not None:
        add("normal", "(" + ", ".join(f"{float(x):.4f}" for x in ev["normal"]) + ")")
    form = ev.get("form") if isinstance(ev.get("form"), dict) else {}
    if form.get("std") is not None:
        add("form σ", f"{1000 * float(form['std']):.1f} µm")
    n, used, removed = ev.get("n_points"), ev.get("n_used"), ev.get("n_removed")
    if n is not None:
        text = f"{used} of {n} used" if used is not None else f"{n}"
        if removed:
            text += f", {removed} removed"
        if ev.get("outliers"):
            text += f" (rule {ev['outliers']})"
        add("points", text)
    if isinstance(ev.get("scale"), (int, float)) and ev["scale"] != 1:
        add("scale", f"{float(ev['scale']):.6g}")
    return rows
