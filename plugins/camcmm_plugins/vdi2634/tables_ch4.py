"""The thesis's tables 4.1 and 4.2, laid out as printed (ch. 4.5), from a VDI/VDE 2634
part-3 result (:mod:`.part3`).

* Table 4.1 "Sphere form and sizing errors": one row per camera position (A-E), the
  fitted radius r of each repeat (mm) and the standard deviation of its radial errors
  Δr (µm, after the 5 % outlier removal), then a "Mean" row (mean radius, mean
  standard deviation of Δr) and a "Standard deviation / µm" row (of all radii).
* Table 4.2 "Sphere spacing errors": one row per ball-plate position (1-7), the
  metric lengths L_m,1, L_m,2, L_m,3 of each repeat (eqs. 4.10-4.12, mm), then rows
  "Mean /mm", "L_m,i - L_c,i / µm", "Standard deviation / µm" and
  "Uncertainty U (k=2) / µm".

Expanded uncertainties follow ISO 15530-3 as the thesis reads it (eq. 4.1 with
u_b = u_w = 0): U = k sqrt(u_cal² + u_p²), k = 2, u_p the standard deviation of all
measured values. u_cal is the standard uncertainty of the calibrated workpiece that set
the scale: for the sphere (scaled by the two 5 mm spheres) the radius uncertainty of
those spheres, as the thesis says (ch. 4.5.1), else the probing sphere's own; for a
length the calibration of that length. Form: U = k sqrt(u_cal² + mean std(Δr)²)
(the thesis's 17 µm from its 8.3 µm).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

K = 2.0
UM = 1000.0


def _repeat_table(evs: list[dict[str, Any]], get) -> tuple[list[str], dict[str, dict[int, Any]]]:
    """Positions in the order measured and {position: {repeat: value}}."""
    order: list[str] = []
    cells: dict[str, dict[int, Any]] = {}
    for e in evs:
        if e.get("error"):
            continue
        pos = str(e.get("position") or e.get("file") or "?")
        if pos not in cells:
            order.append(pos)
            cells[pos] = {}
        cells[pos][int(e.get("repeat") or 1)] = get(e)
    return sorted(order), cells


def _u_cal_radius(result: dict[str, Any]) -> tuple[float, str]:
    """Standard uncertainty (mm) of the calibrated radius that scales the sphere."""
    arts = result.get("artefacts") or {}
    scale_cert = ((arts.get("ball_plate") or {}).get("certificates") or {}).get("sphere_diameter")
    if (result.get("scaling") or {}).get("sphere") == "radii" and scale_cert:
        return _std_u(scale_cert) / 2, "radius of the 5 mm scale spheres (thesis ch. 4.5.1)"
    cert = ((arts.get("sphere") or {}).get("certificates") or {}).get("diameter")
    return (_std_u(cert) / 2 if cert else 0.0), "radius of the probing sphere"


def _std_u(cert: dict[str, Any]) -> float:
    k = float(cert.get("k") or 2.0)
    return float(cert.get("uncertainty") or 0.0) / k


def _fmt(v: Any, digits: int) -> Any:
    return None if v is None or not math.isfinite(v) else round(float(v), digits) + 0.0


def table_4_1(result: dict[str, Any]) -> dict[str, Any] | None:
    """Table 4.1 of the result's sphere measurements, or None without any."""
    evs = (result.get("measurements") or {}).get("sphere") or []
    order, radii = _repeat_table(evs, lambda e: float(e["radius"]) if "radius" in e else e["diameter"] / 2)
    if not order:
        return None
    _, form = _repeat_table(evs, lambda e: float(e["form"]["std"]))
    n_rep = max(max(c) for c in radii.values())
    reps = list(range(1, n_rep + 1))
    rows: list[list[Any]] = []
    for i, pos in enumerate(order):
        label = chr(65 + i) if i < 26 else pos
        rows.append(
            [label]
            + [_fmt(radii[pos].get(r), 4) for r in reps]
            + [_fmt(None if form[pos].get(r) is None else form[pos][r] * UM, 1) for r in reps]
        )
    r_all = np.array([v for pos in order for v in radii[pos].values()], float)
    f_all = np.array([v for pos in order for v in form[pos].values()], float)
    sd = float(r_all.std(ddof=1)) if len(r_all) > 1 else float("nan")
    blank = [None] * (n_rep - 1)
    rows.append(["Mean", _fmt(float(r_all.mean()), 4), *blank, _fmt(float(f_all.mean()) * UM, 1), *blank])
    rows.append(["Standard deviation / µm", _fmt(sd * UM, 1), *blank, None, *blank])
    u_cal, basis = _u_cal_radius(result)
    u_p = sd if math.isfinite(sd) else 0.0
    summary = {
        "n": int(len(r_all)),
        "mean_radius": float(r_all.mean()),
        "std_radius": sd,
        "mean_form_std": float(f_all.mean()),
        "u_cal": u_cal,
        "u_cal_basis": basis,
        "U_size": K * math.sqrt(u_cal**2 + u_p**2),
        "U_form": K * math.sqrt(u_cal**2 + float(f_all.mean()) ** 2),
    }
    columns = ["Camera position"] + [f"r #{r} /mm" for r in reps] + [f"Std of Δr #{r} /µm" for r in reps]
    return {
        "columns": columns,
        "rows": rows,
        "positions": order,
        "summary": summary,
        "caption": "Sphere form and sizing errors (layout of thesis table 4.1): fitted radius r and standard "
        "deviation of the radial errors Δr per camera position and repeat, after 5 % outlier removal",
    }


def table_4_2(result: dict[str, Any]) -> dict[str, Any] | None:
    """Table 4.2 of the result's ball-plate measurements, or None without any."""
    evs = (result.get("measurements") or {}).get("ball_plate") or []
    order, lengths = _repeat_table(evs, lambda e: [float(x) for x in e["lengths"]])
    if not order:
        return None
    n_rep = max(max(c) for c in lengths.values())
    reps = list(range(1, n_rep + 1))
    rows: list[list[Any]] = []
    for i, pos in enumerate(order):
        row: list[Any] = [str(i + 1)]
        for j in range(3):
            row += [_fmt(None if lengths[pos].get(r) is None else lengths[pos][r][j], 4) for r in reps]
        rows.append(row)
    certs = ((result.get("artefacts") or {}).get("ball_plate") or {}).get("certificates") or {}
    blank = [None] * (n_rep - 1)
    per = []
    mean_row: list[Any] = ["Mean /mm"]
    dev_row: list[Any] = ["L_m,i - L_c,i / µm"]
    sd_row: list[Any] = ["Standard deviation / µm"]
    u_row: list[Any] = ["Uncertainty U (k=2) / µm"]
    for j in range(3):
        v = np.array([lengths[p][r][j] for p in order for r in lengths[p]], float)
        cert = certs.get(f"length_{j + 1}") or {}
        lc = cert.get("value")
        sd = float(v.std(ddof=1)) if len(v) > 1 else float("nan")
        u_cal = _std_u(cert) if cert else 0.0
        U = K * math.sqrt(u_cal**2 + (sd if math.isfinite(sd) else 0.0) ** 2)
        dev = None if lc is None else float(v.mean() - lc)
        per.append(
            {
                "name": f"L{j + 1}",
                "n": int(len(v)),
                "mean": float(v.mean()),
                "calibrated": lc,
                "deviation": dev,
                "std": sd,
                "u_cal": u_cal,
                "U": U,
            }
        )
        mean_row += [_fmt(float(v.mean()), 4), *blank]
        dev_row += [_fmt(None if dev is None else dev * UM, 1), *blank]
        sd_row += [_fmt(sd * UM, 1), *blank]
        u_row += [_fmt(U * UM, 1), *blank]
    rows += [mean_row, dev_row, sd_row, u_row]
    columns = ["Position"] + [f"L_m,{j} #{r} /mm" for j in (1, 2, 3) for r in reps]
    return {
        "columns": columns,
        "rows": rows,
        "positions": order,
        "lengths": per,
        "caption": "Sphere spacing errors (layout of thesis table 4.2): metric lengths by eqs. 4.10-4.12 per "
        "ball-plate position and repeat; U = k sqrt(u_cal² + u_p²), thesis eq. 4.1 with u_b = u_w = 0",
    }


def add_sections(report, result: dict[str, Any]) -> None:
    """The two tables as report sections (when the result has their measurements)."""
    t1 = table_4_1(result)
    if t1 is not None:
        s = report.section("Table 4.1: sphere form and sizing errors")
        s.table(t1["columns"], t1["rows"], caption=t1["caption"])
        sm = t1["summary"]
        s.keyvalues(
            {
                "Mean fitted radius": f"{sm['mean_radius']:.4f} mm",
                "Standard deviation of the radii u_p": f"{sm['std_radius'] * UM:.1f} µm",
                "u_cal": f"{sm['u_cal'] * UM:.2f} µm ({sm['u_cal_basis']})",
                "U size (k=2)": f"{sm['U_size'] * UM:.1f} µm (thesis: 8 µm)",
                "U form (k=2)": f"{sm['U_form'] * UM:.1f} µm (thesis: 17 µm)",
            }
        )
    t2 = table_4_2(result)
    if t2 is not None:
        s = report.section("Table 4.2: sphere spacing errors")
        s.table(t2["columns"], t2["rows"], caption=t2["caption"])
        s.paragraph("Thesis: U = 25, 25 and 20 µm for the 6, 8 and 10 mm lengths.")
