"""The traceable report of an acceptance test, built with the core report module
(``camcmm.report``: one document rendered as HTML, PDF and JSON).

Contents: the verdict of every quality parameter under both decision rules (simple
acceptance per VDI/VDE 2634, guarded acceptance per ISO 14253-1), the system, the
artefacts with their certificates, the artefact-rule checks, a table and a chart per
test with every position, the deviation colour map of each sphere and flat, part-3
lengths with their ISO 15530-3 uncertainties, the test uncertainty behind the guarded
rule, warnings, and the provenance: software version, plugin versions (this standard
and the fits it used), and the SHA-256 of every input file. The JSON file carries the
full result of ``camcmm verify --json`` as its ``data``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from camcmm.api import Report, charts, numbers, to_jsonable, verdict_words

from . import tables_ch4
from .declaration import SYMBOLS

TEST_TITLES = {
    "sphere": "Probing errors P_F and P_S (sphere)",
    "ball_bar": "Sphere-spacing error SD (ball bar)",
    "flat": "Flatness measurement error F (flat)",
    "ball_plate": "Sphere-spacing error SD (ball plate)",
}
CERT_NAMES = {
    "diameter": "diameter",
    "form": "form deviation",
    "length": "length",
    "flatness": "flatness",
    "sphere_diameter": "sphere diameter",
    "length_1": "L1 = |c1 c2|",
    "length_2": "L2 = |c2 c3|",
    "length_3": "L3 = |c3 c1|",
}


def _mm(v: Any, signed: bool = False) -> str:
    """A size (a diameter, a length) in mm, 0.1 µm resolution (the number rule)."""
    return "-" if v is None else numbers.length(v, signed=signed)


def _um(v: Any, signed: bool = False) -> str:
    """A quality parameter, an MPE, a form or an uncertainty in µm (the number rule)."""
    return "-" if v is None else numbers.deviation(v, signed=signed)


def _um_cell(v: Any) -> Any:
    """A table cell in µm (from mm) to 0.01 µm; the JSON data keeps mm at full precision."""
    return round(v * 1e3, 2) + 0.0 if isinstance(v, float) else v  # + 0.0: no "-0.0"


def _label(ev: dict[str, Any], repeats: bool = False) -> str:
    """ "sphere-03", or "sphere-03 #2" where positions are repeated."""
    pos = ev.get("position") or ev.get("file") or "?"
    return pos + (f" #{ev.get('repeat') or 1}" if repeats else "")


def _short(ev: dict[str, Any], repeats: bool) -> str:
    """A chart label: the position's number (and repeat), e.g. "03" or "03#2"."""
    pos = str(ev.get("position") or ev.get("file") or "?").rsplit("-", 1)[-1]
    return pos + (f"#{ev.get('repeat') or 1}" if repeats else "")


def _result_section(r, result: dict[str, Any]) -> None:
    s = r.section("Result")
    s.paragraph(
        f"Verdict: {verdict_words(result['verdict'])} (simple acceptance); "
        f"{verdict_words(result['verdict_guarded'])} under guarded acceptance (ISO 14253-1)."
    )
    for key, p in result["parameters"].items():
        signed = key in ("PS", "SD")
        note = "; ".join(p.get("incomplete_reasons") or [])
        s.verdict(
            SYMBOLS.get(key, key),
            simple=p["verdict"],
            guarded=p["verdict_guarded"],
            value=_um(p["value"], signed),
            limit=_um(p["mpe"]),
            uncertainty=_um(p["U"]),
            note=note,
        )
    # each rule's text names it in words ("Guarded acceptance (ISO 14253-1:2017): ..."): not
    # under its JSON key, "verdict_guarded: ..." (issue 30)
    for text in result.get("decision_rules", {}).values():
        s.paragraph(f"{text[:1].upper()}{text[1:]}.")
    s.paragraph(
        "A parameter is incomplete when one of its measurements failed or fewer measurements than the "
        "standard requires were evaluated; an incomplete test never passes."
    )


def _system_section(r, result: dict[str, Any]) -> None:
    sysd = result["system"]
    s = r.section("System and test")
    kv = {
        "System": sysd.get("name") or "-",
        "Measuring volume": " x ".join(f"{v:g}" for v in sysd["measuring_volume"]) + " mm",
        "Longest diagonal L0": f"{sysd['diagonal']:.2f} mm",
        "Standard": result.get("standard_name", ""),
        "Outlier rules": ", ".join(f"{t.replace('_', ' ')}: {rule}" for t, rule in result.get("outliers", {}).items()),
    }
    if result.get("scaling"):
        kv["Scaling"] = ", ".join(f"{t}: {m}" for t, m in result["scaling"].items())
    if result.get("repeats"):
        kv["Repeats per position"] = result["repeats"]
    s.keyvalues(kv)
    rows = []
    for test, art in result["artefacts"].items():
        for name, c in art["certificates"].items():
            rows.append(
                [test.replace("_", " "), CERT_NAMES.get(name, name), c["value"], _um_cell(c["uncertainty"]), c["k"]]
            )
        for name, v in art["nominal"].items():
            if name not in art["certificates"] and isinstance(v, (int, float)) and not isinstance(v, bool):
                rows.append([test.replace("_", " "), f"{CERT_NAMES.get(name, name)} (nominal)", v, None, None])
    s.table(
        ["Artefact", "Quantity", "Value [mm]", "U [µm]", "k"], rows, caption="Artefacts and calibration certificates"
    )
    checks = result.get("artefact_checks") or []
    if checks:
        s.table(
            ["Artefact", "Rule", "Value [mm]", "Limit", "Met"],
            [[c["artefact"], c["rule"], c["value"], c["limit"], "yes" if c["ok"] else "NO"] for c in checks],
            caption="Artefact rules (VDI/VDE 2634 part 2) against the measuring volume",
        )
        for c in checks:
            if not c["ok"]:
                s.warning(c["text"])


def _test_rows(test: str, evs: list[dict[str, Any]], reps: bool) -> tuple[list[str], list[list[Any]]]:
    if test == "sphere":
        cols = ["Position", "File", "Points", "Removed", "D_a [mm]", "P_F [µm]", "P_S [µm]", "Scale"]
        get = lambda e: [
            e.get("n_points"),
            e.get("n_removed"),
            _round(e.get("diameter")),
            _um_cell(e["values"]["PF"]),  # noqa: E731
            _um_cell(e["values"]["PS"]),
            _round(e.get("scale"), 6),
        ]
    elif test == "ball_bar":
        cols = ["Position", "File", "Points", "D1 [mm]", "D2 [mm]", "L_a [mm]", "SD [µm]"]
        get = lambda e: [
            e.get("n_points"),
            _round(e["spheres"][0]["diameter"]),
            _round(e["spheres"][1]["diameter"]),  # noqa: E731
            _round(e["length"]),
            _um_cell(e["values"]["SD"]),
        ]
    elif test == "flat":
        cols = ["Position", "File", "Points", "Removed", "Covered [mm]", "F [µm]"]
        get = lambda e: [  # noqa: E731
            e.get("n_points"),
            e.get("n_removed"),
            _round(e.get("covered_length")),
            _um_cell(e["values"]["F"]),
        ]
    else:
        cols = ["Position", "File", "Scale", "L1 [mm]", "L2 [mm]", "L3 [mm]", "SD1 [µm]", "SD2 [µm]", "SD3 [µm]"]
        get = lambda e: [  # noqa: E731
            _round(e.get("scale"), 6),
            *(_round(x) for x in e["lengths"]),
            *(_um_cell(x) for x in e["values"]["SD"]),
        ]
    if test == "sphere" and all((e.get("scale") or 1.0) == 1.0 for e in evs):
        cols, full = cols[:-1], get
        get = lambda e: full(e)[:-1]  # noqa: E731  (no scale column for metric systems)
    rows = []
    for e in evs:
        if e.get("error"):
            rows.append([_label(e, reps), e.get("file"), *([None] * (len(cols) - 2)), f"ERROR: {e['error']}"])
        else:
            rows.append([_label(e, reps), e.get("file"), *get(e)])
    return cols, rows


def _round(v: Any, digits: int = 4) -> Any:
    """Table cells to 0.1 um (the JSON data keeps full precision)."""
    return round(v, digits) + 0.0 if isinstance(v, float) else v  # + 0.0: no "-0.0"


def _map(charts, e: dict[str, Any], test: str, reps: bool):
    dev = e.get("deviations")
    if dev is None or not hasattr(dev, "points") or "deviation" not in getattr(dev, "fields", {}):
        return None
    if test == "sphere":
        return charts.deviation_map(
            dev.points, dev.fields["deviation"], kind="sphere", center=e["center"], title=_label(e, reps)
        )
    return charts.deviation_map(
        dev.points, dev.fields["deviation"], kind="plane", normal=e["normal"], title=_label(e, reps)
    )


def _test_section(r, charts, test: str, evs: list[dict[str, Any]], result: dict[str, Any]) -> None:
    s = r.section(TEST_TITLES[test])
    reps = any((e.get("repeat") or 1) > 1 for e in evs)
    cols, rows = _test_rows(test, evs, reps)
    if any(len(row) > len(cols) for row in rows):
        cols = cols + ["Note"]
        rows = [row + [""] * (len(cols) - len(row)) for row in rows]
    s.table(cols, rows, caption=f"Every {test.replace('_', ' ')} measurement")
    for key in ("PF", "PS", "SD", "F"):
        p = result["parameters"].get(key)
        rws = [] if p is None else [row for row in p["per_measurement"] if row.get("test") == test]
        items = sorted({row.get("item") for row in rws}, key=str)
        for item in items:  # one chart per ball-plate length, else one per parameter
            sel = [row for row in rws if row.get("item") == item]
            what = p["name"] + (f", {item}" if item else "")
            s.figure(
                charts.bar_chart(
                    [_short(row, reps) for row in sel],
                    [row["value"] for row in sel],
                    limit=p["mpe"],
                    unit="mm",
                    title=f"{what} per measurement, MPE {p['mpe']:g} mm",
                ),
                caption=f"{what}: bars per position{' and repeat' if reps else ''}, dashed lines at the MPE",
            )
    if test in ("sphere", "flat"):
        for e in evs:
            if e.get("error"):
                continue
            try:
                png = _map(charts, e, test, reps)
            except Exception as exc:  # a map that cannot be drawn must not lose the report
                s.warning(f"{_label(e, reps)}: no deviation map ({exc})")
                continue
            if png is not None:
                s.figure(
                    png,
                    caption=f"{_label(e, reps)} ({e.get('file')}): deviations from the least-squares "
                    f"{'sphere' if test == 'sphere' else 'plane'}",
                    width_mm=80,
                )


def _part3_sections(r, result: dict[str, Any]) -> None:
    if result.get("lengths"):
        s = r.section("Ball-plate lengths (thesis table 4.2, ISO 15530-3)")
        s.table(
            ["Length", "Calibrated [mm]", "Mean [mm]", "Mean − cal. [µm]", "Std [µm]", "n", "U (k = 2) [µm]"],
            [
                [
                    x["name"],
                    x.get("calibrated"),
                    _round(x.get("mean"), 5),
                    *(_um_cell(x.get(k)) for k in ("mean_deviation", "std")),
                    x["n"],
                    _um_cell(x.get("U_iso15530_3")),
                ]
                for x in result["lengths"]
            ],
            caption="U = k sqrt(u_cal² + u_p²) (thesis eq. 4.1, u_b = u_w = 0)",
        )
    iso = result.get("iso15530_3")
    if iso:
        s = r.section("Sphere size and form (thesis table 4.1, ISO 15530-3)")
        s.keyvalues(
            {
                "Mean diameter": _mm(iso["size"].get("mean")),
                "Std of diameters": _um(iso["size"].get("std")),
                "U size (k = 2)": _um(iso["size"].get("U_iso15530_3")),
                "Mean std of radial deviations": _um(iso["form"].get("mean_std")),
                "U form (k = 2)": _um(iso["form"].get("U_iso15530_3")),
            }
        )


def _uncertainty_section(r, result: dict[str, Any]) -> None:
    s = r.section("Uncertainty of the test (for guarded acceptance)")
    s.table(
        ["Parameter", "U (k = 2) [µm]", "Basis"],
        [[p["name"], _um_cell(p["U"]), p["uncertainty"]["basis"]] for p in result["parameters"].values()],
    )
    s.paragraph(
        "Only the artefacts' calibration enters U: ISO 14253-1 asks for the uncertainty of the test. "
        "Form and flatness certificates are counted in full (a known bound on the artefact's share)."
    )


def write(result: dict[str, Any], directory: Path, plan=None) -> dict[str, str]:
    """Render the report of ``result`` (from a standard's __call__/summarize) into
    ``directory``; returns {"html", "pdf", "json"} paths."""
    prov = result.get("provenance", {})
    r = Report(
        f"{result.get('standard_name', result['standard'])} acceptance test",
        subtitle=result["system"].get("name") or "",
        meta={
            "Standard": result.get("standard_name") or result["standard"],  # its id is in the provenance
            # a plan given as a dict without a name is called "plan": nothing a person reads
            **({"Test plan": prov.get("plan")} if prov.get("plan") not in (None, "", "plan") else {}),
            "Verdict": verdict_words(result["verdict"]),
            "Verdict with the test uncertainty (guarded, ISO 14253-1)": verdict_words(result["verdict_guarded"]),
        },
    )
    _result_section(r, result)
    _system_section(r, result)
    for test, evs in result["measurements"].items():
        _test_section(r, charts, test, evs, result)
    _part3_sections(r, result)
    if result.get("standard") == "vdi2634-3":
        tables_ch4.add_sections(r, result)
    _uncertainty_section(r, result)
    if result.get("warnings"):
        s = r.section("Warnings")
        for w in result["warnings"]:
            s.warning(w)
    inputs = [i for i in prov.get("inputs", []) if i.get("sha256")]
    r.provenance(
        software=f"camcmm {prov.get('software', {}).get('camcmm', '?')}",
        plugins=prov.get("plugins", []),
        inputs=inputs,
        extra={
            "test plan": prov.get("plan") if prov.get("plan") not in (None, "", "plan") else "given as data (no file)",
            "missing inputs": ", ".join(str(i.get("file")) for i in prov.get("inputs", []) if not i.get("sha256"))
            or "none",
        },
    )
    r.data = _data(result)
    return r.write(Path(directory))


def _data(result: dict[str, Any]) -> Any:
    """The result as JSON data: clouds left out (their summary stays)."""
    return to_jsonable(result)
