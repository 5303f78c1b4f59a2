"""Decision rules for conformity with a specification (ISO 14253-1).

Two rules, reported side by side:

* **simple acceptance** (the rule VDI/VDE 2634 states): a quality parameter passes when
  its magnitude does not exceed its maximum permissible error (MPE).
* **guarded acceptance** (ISO 14253-1:2017, "conformity proven"): the acceptance zone
  shrinks by the expanded uncertainty U of the test itself: pass when |E| <= MPE - U,
  fail when |E| > MPE + U ("non-conformity proven"), otherwise ``inconclusive``.

A test verdict is ``incomplete`` as soon as one parameter is missing or failed to
evaluate — never ``pass``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

PASS, FAIL, INCOMPLETE, INCONCLUSIVE = "pass", "fail", "incomplete", "inconclusive"
#: A verdict as a person reads it (pages, reports); the keys above stay what is stored.
VERDICT_WORDS = {PASS: "passed", FAIL: "failed", INCONCLUSIVE: "inconclusive", INCOMPLETE: "incomplete"}


def verdict_words(verdict: object) -> str:
    """``"pass"`` -> ``"passed"``; a missing verdict is ``"incomplete"``; another text as it is."""
    key = str(verdict or INCOMPLETE).strip().lower()
    return VERDICT_WORDS.get(key, key)


def simple_verdict(value: float | None, mpe: float) -> str:
    """``pass`` if |value| <= mpe, ``fail`` otherwise, ``incomplete`` if value is missing."""
    if value is None or not math.isfinite(value):
        return INCOMPLETE
    return PASS if abs(value) <= mpe else FAIL


def guarded_verdict(value: float | None, mpe: float, expanded_uncertainty: float) -> str:
    """ISO 14253-1 guarded acceptance with the test's expanded uncertainty U (same unit).

    pass: |value| <= mpe - U; fail: |value| > mpe + U; else inconclusive.
    """
    if value is None or not math.isfinite(value):
        return INCOMPLETE
    if expanded_uncertainty < 0 or not math.isfinite(expanded_uncertainty):
        raise ValueError(f"expanded uncertainty must be finite and >= 0, got {expanded_uncertainty}")
    if abs(value) <= mpe - expanded_uncertainty:
        return PASS
    if abs(value) > mpe + expanded_uncertainty:
        return FAIL
    return INCONCLUSIVE


def combine(verdicts: Iterable[str]) -> str:
    """The verdict of a whole test from its parameters' verdicts.

    incomplete if any is incomplete (or there are none); else fail if any fails; else
    inconclusive if any is; else pass.
    """
    verdicts = list(verdicts)
    if not verdicts or INCOMPLETE in verdicts:
        return INCOMPLETE
    for v in (FAIL, INCONCLUSIVE):
        if v in verdicts:
            return v
    return PASS
