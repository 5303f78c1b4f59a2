"""Artefact rules of VDI/VDE 2634 part 2 (thesis ch. 2.7.1), against the longest
diagonal L0 of the measuring volume (mm).

* sphere: 0.02 L0 <= D <= 0.2 L0 (as the issue states it; the thesis words it for the
  radius), and its form "explicitly less" than the expected probing error;
* ball bar: length >= 0.3 L0, sphere diameter 0.02 L0 .. 0.2 L0, length calibrated to
  an uncertainty "substantially less" than the expected spacing error;
* flat: width >= 50 mm, length >= 0.5 L0, flatness "substantially less" than the
  expected flatness error;
* ball plate (part 3, thesis ch. 4.3): its longest length is held to the ball-bar rule,
  its spheres to the sphere rule; and (ours) its longest length to at most L0, the
  longest that fits in the volume.

"Substantially less" is taken here as at most 1/5 of the MPE (our reading; the
guideline gives no number) — a check that is stated, not a verdict.

A broken rule never stops the evaluation: each check is reported with ``ok`` false and
a sentence for the report and the warnings.
"""

from __future__ import annotations

from typing import Any

from .plan import Plan

#: "substantially less than the MPE": at most this fraction of it (our reading).
SUBSTANTIAL = 0.2


def _check(artefact: str, rule: str, value: float, limit: str, ok: bool, text: str) -> dict[str, Any]:
    return {
        "artefact": artefact,
        "rule": rule,
        "value": value,
        "limit": limit,
        "ok": bool(ok),
        "text": text if not ok else f"{artefact}: {rule} ({value:.4g} mm; {limit}) ok",
    }


def _between(
    artefact: str, what: str, v: float, lo: float, hi: float, l0: float, flo: float, fhi: float
) -> dict[str, Any]:
    ok = lo <= v <= hi
    limit = f"{flo:g} L0 .. {fhi:g} L0 = {lo:.4g} .. {hi:.4g} mm, L0 = {l0:.4g} mm"
    return _check(
        artefact,
        f"{what} between {flo:g} and {fhi:g} of the volume diagonal",
        v,
        limit,
        ok,
        f"{artefact}: {what} {v:.4g} mm is outside {limit}; the evaluation runs, the test deviates from VDI/VDE 2634",
    )


def _at_least(artefact: str, what: str, v: float, lo: float, descr: str) -> dict[str, Any]:
    return _check(
        artefact,
        f"{what} at least {descr}",
        v,
        f">= {lo:.4g} mm",
        v >= lo,
        f"{artefact}: {what} {v:.4g} mm is below {descr} = {lo:.4g} mm; the evaluation runs, the test "
        "deviates from VDI/VDE 2634",
    )


def _small(artefact: str, what: str, v: float, mpe: float | None, param: str) -> dict[str, Any] | None:
    if mpe is None:
        return None
    lim = SUBSTANTIAL * mpe
    return _check(
        artefact,
        f"{what} substantially less than MPE {param}",
        v,
        f"<= {SUBSTANTIAL:g} x MPE = {lim:.4g} mm",
        v <= lim,
        f"{artefact}: {what} {v:.4g} mm is not substantially less than MPE {param} = {mpe:g} mm "
        f"(taken as <= {lim:.4g} mm); the artefact takes a large share of the error",
    )


def check(plan: Plan, tests: list[str]) -> list[dict[str, Any]]:
    """Every rule for the artefacts of ``tests`` that the plan defines."""
    l0 = plan.diagonal
    out: list[dict[str, Any] | None] = []
    if "sphere" in tests and "sphere" in plan.artefacts:
        d = plan.required("sphere", "diameter")
        out.append(_between("sphere", "diameter", d, 0.02 * l0, 0.2 * l0, l0, 0.02, 0.2))
        form = plan.certificate("sphere", "form")
        if form is not None:
            out.append(_small("sphere", "form deviation", form.value, plan.mpe.get("PF"), "PF"))
    if "ball_bar" in tests and "ball_bar" in plan.artefacts:
        length = plan.required("ball_bar", "length")
        out.append(_at_least("ball bar", "length", length, 0.3 * l0, f"0.3 L0 (L0 = {l0:.4g} mm)"))
        ds = plan.required("ball_bar", "sphere_diameter")
        out.append(_between("ball bar", "sphere diameter", ds, 0.02 * l0, 0.2 * l0, l0, 0.02, 0.2))
        u_length = plan.required_certificate("ball_bar", "length").expanded_uncertainty
        out.append(_small("ball bar", "length uncertainty U", u_length, plan.mpe.get("SD"), "SD"))
    if "flat" in tests and "flat" in plan.artefacts:
        out.append(_at_least("flat", "width", plan.required("flat", "width"), 50.0, "50 mm"))
        out.append(_at_least("flat", "length", plan.required("flat", "length"), 0.5 * l0, f"0.5 L0 (L0 = {l0:.4g} mm)"))
        fl = plan.certificate("flat", "flatness")
        if fl is not None:
            out.append(_small("flat", "flatness", fl.value, plan.mpe.get("F"), "F"))
    if "ball_plate" in tests and "ball_plate" in plan.artefacts:
        longest = max(plan.required("ball_plate", f"length_{i}") for i in (1, 2, 3))
        out.append(_at_least("ball plate", "longest length", longest, 0.3 * l0, f"0.3 L0 (L0 = {l0:.4g} mm)"))
        # not the guideline's: a plate longer than the volume's diagonal cannot be measured
        # in it, so its lengths (or the volume) are wrong (a plan 10 x too long, issue 26)
        out.append(
            _check(
                "ball plate",
                "longest length within the volume diagonal L0",
                longest,
                f"<= L0 = {l0:.4g} mm",
                longest <= l0,
                f"ball plate: longest length {longest:.4g} mm is longer than the measuring volume's diagonal "
                f"L0 = {l0:.4g} mm: it cannot be measured in it; check the calibrated lengths and the volume",
            )
        )
        ds = plan.required("ball_plate", "sphere_diameter")
        out.append(_between("ball plate", "sphere diameter", ds, 0.02 * l0, 0.2 * l0, l0, 0.02, 0.2))
    return [c for c in out if c is not None]
