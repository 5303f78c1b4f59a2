"""Expanded uncertainty U (k = 2, mm) of the acceptance test itself, for guarded
acceptance per ISO 14253-1:2017 (pass when |E| <= MPE - U).

Only the artefacts' calibration certificates enter: they are what the test's
traceability rests on (VDI/VDE 2634 part 2, section on the test uncertainty; ISO
14253-1 asks for the uncertainty of the *test*, not of the system under test). Our
choices, one per parameter:

* P_S = D_a - D_r: U(P_S) = U(D_r), the certificate's diameter uncertainty
  (re-expressed for k = 2: U = 2 u, u = U_cert / k_cert).
* SD = L_a - L_r: U(SD) = U(L_r).
* P_F: the sphere's own form deviation f adds up to f to the measured range; taken as
  U(P_F) = f + U(f) when the certificate states the form (a conservative, linear sum
  for a known bound), else 0 — and the report says the form is not certified.
* F: likewise U(F) = flatness + U(flatness) of the flat's certificate, else 0.

Part 3 with scaled reconstructions (thesis eqs. 4.10-4.12, or calibrated radii) adds
the scale's calibration: a length scaled by a calibrated length L_c carries the
relative uncertainty u(L_c)/L_c of that reference; scaled by calibrated sphere
diameters d_c, u(d_c)/d_c (no credit for averaging several spheres: their
calibrations are likely correlated). Contributions combine in quadrature (GUM).
"""

from __future__ import annotations

import math
from typing import Any

from .plan import Plan

K = 2.0


def _u(cert) -> float:
    return 0.0 if cert is None else cert.standard_uncertainty


def _result(contribs: dict[str, float], basis: str) -> dict[str, Any]:
    u = math.sqrt(sum(v * v for v in contribs.values()))
    return {"U": K * u, "k": K, "basis": basis, "contributions": {k: K * v for k, v in contribs.items()}}


def _bound(cert, what: str) -> dict[str, Any]:
    if cert is None:
        return {"U": 0.0, "k": K, "basis": f"{what} not certified: taken as 0", "contributions": {}}
    return {
        "U": cert.value + cert.expanded_uncertainty * K / cert.k,
        "k": K,
        "basis": f"certified {what} {cert.value:g} mm + its U {cert.expanded_uncertainty * K / cert.k:g} mm",
        "contributions": {what: cert.value + cert.expanded_uncertainty * K / cert.k},
    }


def probing_form(plan: Plan) -> dict[str, Any]:
    return _bound(plan.certificate("sphere", "form"), "sphere form")


def probing_size(plan: Plan) -> dict[str, Any]:
    c = {"D_r": _u(plan.certificate("sphere", "diameter"))}
    basis = "U(D_r) of the sphere certificate"
    if plan.scaling.get("sphere") == "radii":
        ref = plan.certificate("ball_plate", "sphere_diameter")
        if ref is not None:
            c["scale (calibrated radii)"] = plan.required("sphere", "diameter") * _u(ref) / ref.value
            basis += " and the scale spheres' diameter certificate"
    return _result(c, basis)


def _plate_length(plan: Plan, i: int) -> dict[str, float]:
    """Contributions for ball-plate length i (1..3) after the plan's scaling."""
    cert = {j: plan.required_certificate("ball_plate", f"length_{j}") for j in (1, 2, 3)}
    c = {f"L_c{i}": _u(cert[i])}
    mode = plan.scaling.get("ball_plate", "none")
    li = cert[i].value
    if mode == "lengths":  # eqs. 4.10-4.12: L1, L2 scaled by L3; L3 by the mean of L1, L2 ratios
        refs = [3] if i in (1, 2) else [1, 2]
        w = 1.0 / len(refs)
        for j in refs:
            c[f"scale by L_c{j}"] = w * li * _u(cert[j]) / cert[j].value
    elif mode == "radii":
        ref = plan.certificate("ball_plate", "sphere_diameter")
        if ref is not None:
            c["scale (calibrated radii)"] = li * _u(ref) / ref.value
    return c


def spacing(plan: Plan, test: str) -> dict[str, Any]:
    if test == "ball_plate":
        per = [_result(_plate_length(plan, i), "") for i in (1, 2, 3)]
        worst = max(range(3), key=lambda i: per[i]["U"])
        out = per[worst]
        mode = plan.scaling.get("ball_plate", "none")
        out["basis"] = f"calibrated lengths and the scaling ({mode}); largest of L1-L3"
        out["per_length"] = [p["U"] for p in per]
        return out
    c = {"L_r": _u(plan.certificate("ball_bar", "length"))}
    basis = "U(L_r) of the ball-bar certificate"
    if plan.scaling.get("ball_bar") == "radii":
        ref = plan.certificate("ball_bar", "sphere_diameter")
        if ref is not None and ref.value > 0:
            c["scale (calibrated radii)"] = plan.required("ball_bar", "length") * _u(ref) / ref.value
            basis += " and the ball-bar spheres' diameter certificate"
    return _result(c, basis)


def flatness(plan: Plan) -> dict[str, Any]:
    return _bound(plan.certificate("flat", "flatness"), "flatness")


def for_parameter(plan: Plan, parameter: str, test: str) -> dict[str, Any]:
    """U of the test for one quality parameter measured with ``test``."""
    if parameter == "PF":
        return probing_form(plan)
    if parameter == "PS":
        return probing_size(plan)
    if parameter == "SD":
        return spacing(plan, test)
    return flatness(plan)
