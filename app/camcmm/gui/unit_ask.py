"""Imports held until the user gives their unit (the question camcmm.units asks).

:func:`camcmm.units.decide_unit` says when a file's size is implausible in the unit it
would be read in (no unit stated); the session then holds the read object here and
shows the question (state ``unit_ask``, ``unit_choice``, ``unit_ask_visible``; the
shell's dialog). The answer converts the object (:func:`camcmm.io.with_unit`) and
stores the original file with the chosen unit recorded on the item. Several held
imports are asked about one after the other. Loop thread only.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

from ..errors import one_line
from ..numbers import significant
from ..units import CANDIDATE_UNITS


class UnitAsks:
    """The queue of held imports of one session."""

    def __init__(self, session: Any):
        self.session = session
        self.waiting: list[dict[str, Any]] = []

    def hold(self, path: Path, obj: Any, label: str, check: Any, source: Any) -> None:
        if isinstance(source, (bytes, bytearray, memoryview)):  # an upload: keep it past drop_upload
            folder = Path(tempfile.mkdtemp(prefix="pending-", dir=self.session._tmp))
            path = Path(shutil.move(str(path), folder / path.name))
        self.waiting.append({"path": path, "obj": obj, "label": label, "check": check})
        self.show()

    def show(self) -> None:
        state = self.session.state
        head = self.waiting[0] if self.waiting else None
        if head is None:
            state.unit_ask = None
            state.unit_ask_visible = False
            return
        check = head["check"]
        state.unit_ask = {
            "file": head["label"],
            "reason": check.reason,
            "span": " × ".join(significant(x, 3) for x in check.span),
            "waiting": len(self.waiting),
            "choices": [
                {"value": c["unit"], "title": c["label"], "plausible": bool(c["plausible"])} for c in check.candidates
            ],
        }
        state.unit_choice = check.suggested or "mm"
        state.unit_ask_visible = True

    def answer(self, unit: Any) -> str | None:
        from .. import io as cio

        s = self.session
        if not self.waiting:
            s.error("no import is waiting for its unit")
            return None
        choice = str(unit or "").strip().replace("µ", "u")
        if choice not in CANDIDATE_UNITS:  # browser input: only what was offered
            label = self.waiting[0]["label"]
            s.error(f"{label}: unit {str(unit)[:20]!r} is not one of {', '.join(CANDIDATE_UNITS)}")
            return None
        head = self.waiting.pop(0)
        try:
            return s._register(head["path"], cio.with_unit(head["obj"], choice), head["label"])
        except Exception as exc:
            s.error(one_line(exc, head["label"]))
            return None
        finally:
            self._drop(head["path"])
            self.show()

    def cancel(self) -> None:
        if self.waiting:
            head = self.waiting.pop(0)
            self._drop(head["path"])
            self.session.info(f"{head['label']}: not imported (no unit chosen)")
        self.show()

    def _drop(self, path: Path) -> None:
        if path.parent.name.startswith("pending-") and path.parent.parent == self.session._tmp:
            shutil.rmtree(path.parent, ignore_errors=True)
