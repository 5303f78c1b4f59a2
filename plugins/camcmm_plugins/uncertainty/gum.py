"""GUM uncertainty budgets (JCGM 100:2008; thesis ch. 2.6 and table 3.2).

A budget is a list of uncorrelated contributions, each with a standard uncertainty
``u`` of an input quantity, a sensitivity coefficient ``c`` (the contribution to the
measurand is ``|c|·u``), degrees of freedom ``dof`` (``inf`` for a type B evaluation
known exactly) and the distribution it was evaluated with. :func:`evaluate` gives

* the combined standard uncertainty ``u_c = sqrt(sum (c_i u_i)^2)`` (GUM eq. 10),
* the Welch–Satterthwaite effective degrees of freedom
  ``nu_eff = u_c^4 / sum((c_i u_i)^4 / nu_i)`` (GUM eq. G.2b),
* the coverage factor ``k = t_p(nu_eff)`` from Student's t for the coverage probability
  ``p`` (two-sided; GUM G.3), with ``nu_eff`` truncated to the next lower integer as
  GUM G.4.1 allows (``dof_rounding="none"`` uses the fractional value),
* the expanded uncertainty ``U = k·u_c`` and each contribution's share of ``u_c^2``.

A contribution may state a half-width ``a`` with its distribution (u = a/√3
rectangular, GUM 4.3.7; a/√6 triangular, GUM 4.3.9; a/√2 U-shaped, JCGM 101 6.4.6) or
an expanded uncertainty ``U`` with its coverage factor ``k`` (u = U/k, GUM 4.3.3)
instead of ``u``: :mod:`.distributions` converts, and the JSON says how each was
entered (``entered_as``, ``entered_value``, ``divisor``, ``conversion``).

Numbers only; no camcmm imports besides the error types.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camcmm.api import InputError

from .distributions import DISTRIBUTIONS, DIVISORS, Entered, standard_uncertainty  # noqa: F401 (re-exported)

INF_WORDS = {"inf", "infinity", "∞", "oo"}


@dataclass(frozen=True)
class Contribution:
    """One input quantity's contribution to the measurand."""

    name: str
    u: float
    c: float = 1.0
    dof: float = math.inf
    distribution: str = "normal"
    entered: Entered | None = field(default=None, compare=False)
    unit: str = ""  # the input quantity's unit when stated (u is in it; c converts)

    @property
    def value(self) -> float:
        """The contribution to the measurand's standard uncertainty, ``|c|·u``."""
        return abs(self.c) * self.u


@dataclass
class Budget:
    """The evaluated budget: what :func:`evaluate` returns."""

    contributions: list[Contribution]
    combined: float
    dof_eff: float
    k: float
    expanded: float
    coverage_probability: float
    quantity: str = ""
    unit: str = ""
    dof_rounding: str = "truncate"
    shares: list[float] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """The JSON form: ``combined, dof_eff, k, expanded, coverage_probability,
        contributions`` (each ``name, u, c, dof, distribution, contribution, share``, and
        how it was stated: ``entered_as, entered_value, divisor, coverage_factor, conversion,
        input_unit``) plus ``quantity, unit, dof_eff_infinite, dof_rounding`` and ``warnings`` (why the
        result may be meaningless). JSON has no infinity: an infinite ``dof`` or
        ``dof_eff`` is written as ``null`` and flagged."""
        return {
            "quantity": self.quantity,
            "unit": self.unit,
            "combined": self.combined,
            "dof_eff": self.dof_eff,
            "dof_eff_infinite": bool(math.isinf(self.dof_eff)),
            "dof_rounding": self.dof_rounding,
            "k": self.k,
            "expanded": self.expanded,
            "coverage_probability": self.coverage_probability,
            "contributions": [
                {
                    "name": c.name,
                    "u": c.u,
                    "c": c.c,
                    "dof": c.dof,
                    "dof_infinite": bool(math.isinf(c.dof)),
                    "distribution": c.distribution,
                    "contribution": c.value,
                    "share": s,
                    **_entered(c, self.unit),
                }
                for c, s in zip(self.contributions, self.shares)
            ],
            "warnings": list(self.warnings),
        }


def _entered(c: Contribution, unit: str) -> dict[str, Any]:
    """How the contribution was stated (keys added to the JSON of issue 15). The input's
    own unit if the entry states one, else the measurand's when c = 1 (else none: an
    input such as a temperature is not in the measurand's unit)."""
    e = c.entered or Entered(c.u, c.distribution, "u", c.u, 1.0)
    unit = c.unit or (unit if c.c == 1 else "")
    return {
        "input_unit": unit,
        "entered_as": e.entered_as,
        "entered_value": e.value,
        "divisor": e.divisor,
        "coverage_factor": e.k,
        "conversion": e.text(unit),
    }


def _number(value: Any, what: str) -> float:
    if isinstance(value, str) and value.strip().lower() in INF_WORDS:
        return math.inf
    if isinstance(value, bool):
        raise InputError(f"{what}: {value!r} is not a number")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what}: {value!r} is not a number") from None
    if math.isnan(x):
        raise InputError(f"{what}: is NaN")
    return x


def contribution_from_dict(d: Mapping[str, Any], index: int = 0) -> Contribution:
    """A :class:`Contribution` from a budget file entry, with a one-line error naming
    the entry for anything missing or out of range."""
    if not isinstance(d, Mapping):
        raise InputError(f"contribution {index + 1}: expected a mapping with name and u, got {d!r}")
    name = str(d.get("name", f"#{index + 1}"))
    tag = f"contribution {index + 1} ({name!r})"
    entered = standard_uncertainty(d, tag, _number)
    u = entered.u
    if not (u >= 0) or math.isinf(u):
        raise InputError(f"{tag}: standard uncertainty u = {u} must be a finite number >= 0")
    c = _number(d.get("c", 1.0), f"{tag} sensitivity c")
    if math.isinf(c):
        raise InputError(f"{tag}: sensitivity c must be finite")
    dof = _number(d.get("dof", math.inf) if d.get("dof") is not None else math.inf, f"{tag} dof")
    if not dof > 0:
        raise InputError(
            f"{tag}: degrees of freedom dof = {dof:g} must be > 0 (use inf for an exactly known type B contribution)"
        )
    unit = str(d.get("unit") or "")
    return Contribution(name=name, u=u, c=c, dof=dof, distribution=entered.distribution, entered=entered, unit=unit)


def welch_satterthwaite(contributions: Iterable[float], dofs: Iterable[float]) -> float | np.ndarray:
    """Effective degrees of freedom of ``sqrt(sum u_i^2)`` (GUM eq. G.2b); ``inf`` when
    every contribution with a non-zero value has infinite dof. Works on arrays too:
    ``contributions`` of shape (n, ...) give a result of shape (...)."""
    u = np.abs(
        np.asarray(list(contributions) if not isinstance(contributions, np.ndarray) else contributions, dtype=float)
    )
    nu = np.asarray(list(dofs) if not isinstance(dofs, np.ndarray) else dofs, dtype=float)
    nu = nu.reshape(nu.shape + (1,) * (u.ndim - nu.ndim))
    # nu is scale-free: dividing by the largest contribution keeps u^4 from overflowing
    top = np.max(u, axis=0)
    u = u / np.where(top > 0, top, 1.0)
    uc2 = np.sum(u**2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = np.sum(np.where(np.isinf(nu), 0.0, u**4 / nu), axis=0)
        out = np.where(denom > 0, uc2**2 / np.where(denom > 0, denom, 1.0), np.inf)
    return float(out) if out.ndim == 0 else out


def coverage_factor(dof: float, p: float = 0.95, dof_rounding: str = "truncate") -> float:
    """Two-sided coverage factor ``t_p(nu)`` (normal quantile for infinite ``nu``)."""
    from scipy import stats

    if not 0 < p < 1:
        raise InputError(f"coverage_probability {p} must lie between 0 and 1")
    if dof_rounding not in ("truncate", "none"):
        raise InputError(f"dof_rounding {dof_rounding!r}: use truncate or none")
    q = 0.5 * (1.0 + p)
    if math.isinf(dof):
        return float(stats.norm.ppf(q))
    nu = math.floor(dof) if dof_rounding == "truncate" and dof >= 1 else dof
    return float(stats.t.ppf(q, nu))


def evaluate(
    contributions: Iterable[Contribution | Mapping[str, Any]],
    coverage_probability: float = 0.95,
    quantity: str = "",
    unit: str = "",
    dof_rounding: str = "truncate",
) -> Budget:
    """Evaluate a budget; entries may be :class:`Contribution` or file-style dicts."""
    items = [c if isinstance(c, Contribution) else contribution_from_dict(c, i) for i, c in enumerate(contributions)]
    if not items:
        raise InputError("the budget has no contributions")
    p = _number(coverage_probability, "coverage_probability")
    vals = np.array([c.value for c in items])
    uc = math.hypot(*vals)  # no overflow in the squares
    nu = float(welch_satterthwaite(vals, [c.dof for c in items]))  # one budget: a number
    k = coverage_factor(nu, p, dof_rounding)
    if not math.isfinite(k * uc):
        raise InputError(f"U = k u_c overflows (u_c = {uc:g}, k = {k:g}); check the contributions' magnitudes")
    shares = ((vals / uc) ** 2).tolist() if uc > 0 else [0.0] * len(items)
    warnings = []
    if uc == 0:
        # legal arithmetic, but no measurement is exact: a budget of zeros is a mistake
        warnings.append(
            "the combined standard uncertainty u_c is 0: every contribution |c|·u is zero; "
            "check the budget's u and c values"
        )
    return Budget(items, uc, float(nu), k, k * uc, p, quantity, unit, dof_rounding, shares, warnings)


def budget_from_dict(doc: Mapping[str, Any]) -> Budget:
    """Evaluate a budget file's content (see ``tests/data/uncertainty/budget_*.yaml``)."""
    if not isinstance(doc, Mapping):
        raise InputError("budget file: expected a mapping with a 'contributions' list")
    contribs = doc.get("contributions")
    if not isinstance(contribs, list):
        raise InputError("budget file: missing 'contributions' (a list of {name, u, c, dof, distribution})")
    return evaluate(
        contribs,
        doc.get("coverage_probability", 0.95),
        str(doc.get("quantity", "")),
        str(doc.get("unit", "")),
        str(doc.get("dof_rounding", "truncate")),
    )
