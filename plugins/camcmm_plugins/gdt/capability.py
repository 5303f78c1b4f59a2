"""Trend and capability of each characteristic over the parts of a batch
(:mod:`.batch`): mean, standard deviation, Cp/Cpk with confidence intervals, control
limits, and the parts out of tolerance or undecided, named.

:func:`summarise` takes the batch's JSON (:meth:`.batch.Batch.to_json`, or any mapping
with ``parts`` [{``part``, ``status``, ``evaluation``}], ``evaluation`` the JSON of
``camcmm gdt evaluate``) and returns one entry per characteristic, in the plan's order.
Only parts with status ``evaluated`` enter the figures (a failed part — its cloud did
not read, its alignment did not settle, a feature or characteristic was not evaluated —
is named in the batch, not counted here); the parts are taken in the batch's order
(the order of production, for the control chart).

Figures (values in the characteristic's unit, mm unless it says otherwise):

* ``mean`` x̄ and ``s`` the sample standard deviation (n − 1) of the n values. s is the
  overall spread of the batch: when the process has not been shown to be in control these
  are, in ISO 22514-2:2017's words, performance indices (Pp, Ppk) rather than capability
  indices of a stable process; the formulas are the same.
* Limits: a **zone** characteristic (form, orientation, location, runout: a tolerance t)
  has only the upper limit USL = t and the natural lower bound 0 — it is one-sided, so
  ``cp`` is not defined (None, said in ``notes``) and ``cpk`` = (USL − x̄)/(3s) (ISO
  22514-2 Cpk,U). A **size** (lower/upper deviations from its nominal N) has LSL = N +
  lower, USL = N + upper: ``cp`` = (USL − LSL)/(6s), ``cpk`` = min(USL − x̄, x̄ − LSL)/(3s);
  a size with one limit only is one-sided like a zone.
* Confidence intervals (two-sided, ``confidence``, default 95 %), s from n normal values
  with ν = n − 1 degrees of freedom:
  ``cp_ci`` = [Cp·√(χ²(α/2; ν)/ν), Cp·√(χ²(1 − α/2; ν)/ν)] (exact under normality:
  (n − 1)s²/σ² is χ²(ν); D. C. Montgomery, Introduction to Statistical Quality Control,
  8.3.5); ``cpk_ci`` = Ĉpk ∓ z(1 − α/2)·√(1/(9n) + Ĉpk²/(2(n − 1))) (A. F. Bissell, "How
  reliable is your capability index?", Applied Statistics 39 (1990) 331–340: the normal
  approximation of Ĉpk's sampling distribution).
* Control limits (Shewhart, ISO 7870-2): parts one at a time (``subgroup`` None or 1) →
  **individuals / moving range**: centre x̄, MR̄ the mean of |x_i − x_(i−1)|, UCL/LCL = x̄ ±
  2.66·MR̄ (2.66 = 3/d₂, d₂ = 1.128 for ranges of two), the moving-range chart's UCL
  3.267·MR̄ (D₄); parts in consecutive subgroups of ``subgroup`` = m ≥ 2 → **X̄/s**: centre
  x̿ the mean of the subgroup means, s̄ the mean of the subgroup standard deviations,
  UCL/LCL = x̿ ± A₃·s̄ with A₃ = 3/(c₄√m), the s chart's limits B₃·s̄ and B₄·s̄ (B₃,₄ = 1 ∓
  3√(1 − c₄²)/c₄, B₃ ≥ 0), c₄ = √(2/(m − 1))·Γ(m/2)/Γ((m − 1)/2); the parts of an
  incomplete last subgroup are left out of the chart (noted). A lower control limit
  below a zone's natural bound 0 is none (None). ``beyond`` names the parts (or
  subgroups) outside the control limits.
* ``out``: the parts whose simple verdict is "not conform" (value outside the limits);
  ``undecided``: those whose ISO 14253-1 verdict with the guard band U is "undecided".

Nothing here reads a file: it is the arithmetic of the batch's JSON.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from scipy import stats

#: Default two-sided confidence of the intervals.
CONFIDENCE = 0.95
#: 3/d₂ and D₄ of ranges of two (individuals / moving range chart).
E2 = 2.66
D4 = 3.267
#: Largest subgroup for the X̄/s chart (c₄ from the Γ function stays exact well beyond).
MAX_SUBGROUP = 25


def c4(m: int) -> float:
    """The bias factor of s for subgroups of m normal values: E[s] = c₄·σ."""
    return math.sqrt(2.0 / (m - 1)) * math.exp(math.lgamma(m / 2) - math.lgamma((m - 1) / 2))


def cp_interval(cp: float, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The chi-square interval of Cp from n values (module docstring)."""
    nu = n - 1
    a = 1.0 - confidence
    return (
        cp * math.sqrt(float(stats.chi2.ppf(a / 2, nu)) / nu),
        cp * math.sqrt(float(stats.chi2.ppf(1 - a / 2, nu)) / nu),
    )


def cpk_interval(cpk: float, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Bissell's (1990) normal-approximation interval of Cpk from n values."""
    z = float(stats.norm.ppf(1 - (1.0 - confidence) / 2))
    half = z * math.sqrt(1.0 / (9 * n) + cpk**2 / (2 * (n - 1)))
    return cpk - half, cpk + half


def limits(c: Mapping[str, Any]) -> dict[str, Any]:
    """The specification limits of one characteristic's JSON: ``kind`` "zone" (USL the
    tolerance, natural lower bound 0), "size" (LSL/USL = nominal + lower/upper; None where
    not given) or "none" (no tolerance: no capability)."""
    if c.get("tolerance") is not None:
        return {"kind": "zone", "lsl": None, "usl": float(c["tolerance"]), "bound": 0.0, "nominal": None}
    lower, upper = c.get("lower"), c.get("upper")
    nominal = (c.get("details") or {}).get("nominal")
    if (lower is None and upper is None) or nominal is None or not math.isfinite(float(nominal)):
        return {"kind": "none", "lsl": None, "usl": None, "bound": None, "nominal": nominal}
    n = float(nominal)
    return {
        "kind": "size",
        "lsl": None if lower is None else n + float(lower),
        "usl": None if upper is None else n + float(upper),
        "bound": None,
        "nominal": n,
    }


def _capability(x: np.ndarray, lim: Mapping[str, Any], confidence: float, notes: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {"cp": None, "cp_ci": None, "cpk": None, "cpk_ci": None}
    n = len(x)
    lsl, usl = lim["lsl"], lim["usl"]
    if lim["kind"] == "none":
        notes.append("no tolerance or limits: no capability")
        return out
    if n < 2:
        notes.append(f"{n} value(s): s, Cp and Cpk need at least 2")
        return out
    mean, s = float(x.mean()), float(x.std(ddof=1))
    if not s > 0:
        notes.append("s = 0 (every value equal): Cp and Cpk not defined")
        return out
    if lsl is not None and usl is not None:
        out["cp"] = (usl - lsl) / (6 * s)
        out["cp_ci"] = list(cp_interval(out["cp"], n, confidence))
    elif lim["kind"] == "zone":
        notes.append("one-sided zone (upper limit the tolerance, natural lower bound 0): Cp not defined")
    else:
        notes.append("one-sided size limit: Cp not defined")
    sides = [(usl - mean) / (3 * s)] if usl is not None else []
    sides += [(mean - lsl) / (3 * s)] if lsl is not None else []
    out["cpk"] = min(sides)
    out["cpk_ci"] = list(cpk_interval(out["cpk"], n, confidence))
    return out


def individuals(x: np.ndarray, names: list[str], bound: float | None, notes: list[str]) -> dict[str, Any] | None:
    """The individuals / moving-range chart of values ``x`` (module docstring)."""
    if len(x) < 2:
        return None
    centre = float(x.mean())
    mr_bar = float(np.abs(np.diff(x)).mean())
    ucl, lcl = centre + E2 * mr_bar, centre - E2 * mr_bar
    out = {"kind": "individuals", "centre": centre, "ucl": ucl, "lcl": lcl, "mr_bar": mr_bar, "mr_ucl": D4 * mr_bar}
    if bound is not None and lcl < bound:
        out["lcl"] = None
        notes.append(f"lower control limit {lcl:.6g} below the natural bound {bound:g}: none")
    out["beyond"] = [p for p, v in zip(names, x, strict=True) if v > ucl or (out["lcl"] is not None and v < out["lcl"])]
    return out


def xbar_s(x: np.ndarray, names: list[str], m: int, bound: float | None, notes: list[str]) -> dict[str, Any] | None:
    """The X̄/s chart of ``x`` in consecutive subgroups of ``m`` (module docstring)."""
    g = len(x) // m
    if g < 2:
        notes.append(f"{len(x)} values make fewer than 2 subgroups of {m}: no X̄/s chart")
        return None
    if len(x) % m:
        notes.append(f"the last {len(x) % m} value(s) make no complete subgroup of {m}: left out of the chart")
    groups = x[: g * m].reshape(g, m)
    means, sds = groups.mean(axis=1), groups.std(axis=1, ddof=1)
    centre, s_bar, c = float(means.mean()), float(sds.mean()), c4(m)
    a3 = 3 / (c * math.sqrt(m))
    spread = 3 * math.sqrt(1 - c * c) / c
    ucl, lcl = centre + a3 * s_bar, centre - a3 * s_bar
    out: dict[str, Any] = {
        "kind": "xbar-s",
        "m": m,
        "centre": centre,
        "ucl": ucl,
        "lcl": lcl,
        "s_bar": s_bar,
        "s_ucl": (1 + spread) * s_bar,
        "s_lcl": max(0.0, 1 - spread) * s_bar,
        "subgroups": [
            {"parts": names[i * m : (i + 1) * m], "mean": float(means[i]), "s": float(sds[i])} for i in range(g)
        ],
    }
    if bound is not None and lcl < bound:
        out["lcl"] = None
        notes.append(f"lower control limit {lcl:.6g} below the natural bound {bound:g}: none")
    out["beyond"] = [
        i + 1
        for i in range(g)
        if means[i] > ucl or (out["lcl"] is not None and means[i] < out["lcl"]) or sds[i] > out["s_ucl"]
    ]
    return out


def _characteristics(parts: Iterable[Mapping[str, Any]]) -> list[str]:
    """The characteristic ids in the plan's order (the first evaluation that names each)."""
    ids: list[str] = []
    for p in parts:
        for c in (p.get("evaluation") or {}).get("characteristics", []):
            if c["id"] not in ids:
                ids.append(c["id"])
    return ids


def summarise(
    batch_json: Mapping[str, Any], *, confidence: float = CONFIDENCE, subgroup: int | None = None
) -> list[dict[str, Any]]:
    """Per characteristic (plan order): ``id``, ``type``, ``feature``, ``datums``,
    ``unit``, ``limits`` {kind, lsl, usl, bound, nominal}, ``n``, ``mean``, ``s``, ``cp``,
    ``cp_ci``, ``cpk``, ``cpk_ci`` ([low, high] at ``confidence``), ``confidence``,
    ``control`` {kind "individuals"|"xbar-s", centre, ucl, lcl, beyond, …} or None,
    ``points`` [{part, value, U, verdict, verdict_guarded}] (every evaluated part, for
    the run chart), ``out`` and ``undecided`` (part names), ``not_evaluated`` (parts
    whose value is missing), ``notes`` (why a figure is None). See the module docstring
    for the formulas. ``subgroup`` m ≥ 2 draws the X̄/s chart; None or 1 the individuals
    chart."""
    if not 0 < confidence < 1:
        raise ValueError(f"confidence {confidence!r} is not in (0, 1)")
    if subgroup is not None and not 1 <= subgroup <= MAX_SUBGROUP:
        raise ValueError(f"subgroup {subgroup!r} is not in 1 … {MAX_SUBGROUP}")
    parts = [p for p in batch_json.get("parts", []) if p.get("status") == "evaluated" and p.get("evaluation")]
    out = []
    for cid in _characteristics(parts):
        rows = [
            (p["part"], c)
            for p in parts
            for c in p["evaluation"]["characteristics"]
            if c["id"] == cid  # a characteristic appears once per evaluation
        ]
        first = rows[0][1]
        valued = [(name, c) for name, c in rows if c.get("value") is not None]
        names = [name for name, _ in valued]
        x = np.array([float(c["value"]) for _, c in valued])
        lim = limits(next((c for _, c in valued), first))
        notes: list[str] = []
        entry: dict[str, Any] = {
            "id": cid,
            "type": first.get("type"),
            "feature": first.get("feature"),
            "datums": list(first.get("datums") or []),
            "unit": first.get("unit", "mm"),
            "limits": lim,
            "n": len(x),
            "mean": float(x.mean()) if len(x) else None,
            "s": float(x.std(ddof=1)) if len(x) >= 2 else None,
            "confidence": confidence,
        }
        entry.update(_capability(x, lim, confidence, notes))
        if subgroup is not None and subgroup >= 2:
            entry["control"] = xbar_s(x, names, subgroup, lim["bound"], notes)
        else:
            entry["control"] = individuals(x, names, lim["bound"], notes)
        entry["points"] = [
            {
                "part": name,
                "value": c.get("value"),
                "U": c.get("U"),
                "verdict": c.get("verdict"),
                "verdict_guarded": c.get("verdict_guarded"),
            }
            for name, c in rows
        ]
        entry["out"] = [name for name, c in rows if c.get("verdict") == "not conform"]
        entry["undecided"] = [name for name, c in rows if c.get("verdict_guarded") == "undecided"]
        entry["not_evaluated"] = [name for name, c in rows if c.get("value") is None]
        entry["notes"] = notes
        out.append(entry)
    return out
