"""The report of a batch (``camcmm gdt batch … --report DIR``): the trend and capability of
each characteristic over the parts, HTML, PDF and JSON through ``camcmm.api.Report``.

Body: the batch in one line (parts evaluated, failed), the characteristics in which parts
are out of tolerance or undecided, named; the parts × characteristics table (value and
ISO 14253-1 verdict); the failed parts with their reasons; per characteristic its figures
(n, mean, s, Cp and Cpk with their confidence intervals, control limits) and its **run
chart**: each part's value in production order with the tolerance limits, the mean and
the control limits, a part out of tolerance drawn red, an undecided one amber, with its U
as an error bar. Appendix: how the figures are computed (:mod:`.capability`) and the
provenance (camcmm version, the plugin, each part's file SHA-256).

The input is :meth:`.batch.Batch.to_json` (with ``summary``); nothing is recomputed here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from camcmm.api import Report

#: Verdict words of the table (the evaluate JSON's, read as a person says them).
_WORDS = {"conform": "conform", "not conform": "NOT CONFORM", "undecided": "undecided", "not evaluated": "—"}
_COLOURS = {"conform": "#4a6fa5", "not conform": "#c62828", "undecided": "#e0a000"}


def _f(x: Any, digits: int = 4) -> str:
    return "—" if x is None else f"{x:.{digits}f}"


def _ci(v: Any, ci: Any) -> str:
    if v is None:
        return "not defined"
    return f"{v:.3f}" + ("" if ci is None else f" [{ci[0]:.3f}, {ci[1]:.3f}]")


def run_chart(s: dict[str, Any]) -> Any:
    """The run chart of one characteristic's summary (a matplotlib Figure, no pyplot):
    values by part, U as error bars, the limits (red dashed), the mean (grey) and the
    control limits (blue dotted)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(170 / 25.4, 62 / 25.4), dpi=150)
    ax = fig.add_axes((0.09, 0.22, 0.89, 0.66))
    pts = [p for p in s["points"] if p["value"] is not None]
    xs = list(range(1, len(pts) + 1))
    for verdict, colour in _COLOURS.items():
        sel = [(x, p) for x, p in zip(xs, pts, strict=True) if (p["verdict_guarded"] or p["verdict"]) == verdict]
        if sel:
            ax.errorbar(
                [x for x, _ in sel],
                [p["value"] for _, p in sel],
                yerr=[p["U"] or 0.0 for _, p in sel],
                fmt="o",
                ms=3.5,
                color=colour,
                elinewidth=0.8,
                capsize=2,
                label=verdict,
            )
    ax.plot(xs, [p["value"] for p in pts], color="#9ca3af", lw=0.6, zorder=0)
    lim = s["limits"]
    for name, y in (("LSL", lim.get("lsl")), ("USL", lim.get("usl"))):
        if y is not None:
            ax.axhline(y, color="#b71c1c", ls="--", lw=0.9, label=f"{name} {y:g}")
    if s.get("mean") is not None:
        ax.axhline(s["mean"], color="#555", lw=0.8, label="mean")
    ctl = s.get("control") or {}
    if ctl.get("kind") == "individuals":
        shown = [y for y in (ctl.get("ucl"), ctl.get("lcl")) if y is not None]
        for j, y in enumerate(shown):
            ax.axhline(y, color="#4a6fa5", ls=":", lw=0.9, label="control limits" if j == 0 else None)
    ax.set_xticks(xs)
    ax.set_xticklabels([p["part"] for p in pts], rotation=45, ha="right", fontsize=6)
    ax.tick_params(axis="y", labelsize=6.5)
    ax.set_ylabel(s["unit"], fontsize=7)
    if pts:
        ax.legend(fontsize=5.5, loc="lower left", bbox_to_anchor=(0.0, 1.0), frameon=False, ncol=6)
    return fig


def build_trend_report(doc: dict[str, Any]) -> Report:
    """The batch's report (module docstring) from its JSON ``doc``."""
    c = doc["counts"]
    summary = doc["summary"]
    r = Report(
        "Series report: trend and capability",
        subtitle="One inspection plan over a batch of parts: ISO 22514-2 capability, Shewhart control limits, "
        "ISO 14253-1 verdicts",
        meta={
            "Inspection plan": Path(str(doc["plan"])).name,
            "Parts": f"{c['parts']} ({c['evaluated']} evaluated, {c['failed']} failed)",
            "Nominal": Path(str(doc["nominal"])).name if doc.get("nominal") else "the plan's nominal geometry",
            "Alignment": str((doc.get("params") or {}).get("align", "best-fit")),
        },
    )
    s = r.section("Result")
    flagged = [x for x in summary if x["out"] or x["undecided"]]
    if not flagged:
        s.paragraph(f"Every evaluated part is in tolerance in every characteristic ({len(summary)} characteristics).")
    for x in flagged:
        parts = []
        if x["out"]:
            parts.append("out of tolerance: " + ", ".join(x["out"]))
        if x["undecided"]:
            parts.append("undecided (ISO 14253-1): " + ", ".join(x["undecided"]))
        s.paragraph(f"{x['id']}: " + "; ".join(parts) + ".")
    ids = [x["id"] for x in summary]
    rows = []
    for p in doc["parts"]:
        by_id = {ch["id"]: ch for ch in (p.get("evaluation") or {}).get("characteristics", [])}
        cells = []
        for i in ids:
            ch = by_id.get(i)
            cells.append(
                "—" if ch is None or ch.get("value") is None else f"{ch['value']:.4f} {_WORDS[ch['verdict_guarded']]}"
            )
        rows.append([p["part"], *cells])
    s.table(["Part", *ids], rows, caption="Value (mm) and ISO 14253-1 verdict (guard band U) of every part")
    failed = [p for p in doc["parts"] if p["status"] != "evaluated"]
    if failed:
        s.table(
            ["Part", "File", "Why it failed"],
            [[p["part"], Path(p["file"]).name, p["reason"]] for p in failed],
            caption="Failed parts (not counted in the figures below)",
        )
    for x in summary:
        sec = r.section(f"{x['id']}: {x['type']}")
        lim, ctl = x["limits"], x.get("control") or {}
        items: list[tuple[str, Any]] = [
            ("Limits", f"LSL {_f(lim.get('lsl'))}, USL {_f(lim.get('usl'))} {x['unit']}"),
            ("Parts counted", x["n"]),
            ("Mean, s", f"{_f(x['mean'])}, {_f(x['s'], 5)} {x['unit']}"),
            (f"Cp [{x['confidence'] * 100:g} % interval]", _ci(x["cp"], x["cp_ci"])),
            (f"Cpk [{x['confidence'] * 100:g} % interval]", _ci(x["cpk"], x["cpk_ci"])),
        ]
        if ctl:
            kind = "individuals / moving range" if ctl["kind"] == "individuals" else f"X̄/s, subgroups of {ctl['m']}"
            items.append(
                (f"Control limits ({kind})", f"centre {_f(ctl['centre'])}, UCL {_f(ctl['ucl'])}, LCL {_f(ctl['lcl'])}")
            )
            items.append(("Beyond the control limits", ", ".join(map(str, ctl["beyond"])) or "none"))
        items.append(("Out of tolerance", ", ".join(x["out"]) or "none"))
        items.append(("Undecided", ", ".join(x["undecided"]) or "none"))
        sec.keyvalues(items)
        for note in x["notes"]:
            sec.paragraph(f"Note: {note}.")
        if x["points"]:
            sec.figure(run_chart(x), caption=f"Run chart of {x['id']}", data={"points": x["points"], "limits": lim})
    m = r.section("How the figures are computed", appendix=True)
    m.paragraph(
        "Only evaluated parts count. s is the sample standard deviation (n − 1) of all values: without evidence "
        "of a stable process these are the performance indices of ISO 22514-2. A zone (form, orientation, "
        "location, runout) has the upper limit USL = tolerance and the natural lower bound 0: Cp is not defined, "
        "Cpk = (USL − x̄)/(3s). A size has LSL/USL = nominal + lower/upper: Cp = (USL − LSL)/(6s), "
        "Cpk = min(USL − x̄, x̄ − LSL)/(3s)."
    )
    m.paragraph(
        "Cp's interval: Cp·√(χ²(α/2; n − 1)/(n − 1)) … Cp·√(χ²(1 − α/2; n − 1)/(n − 1)); Cpk's: "
        "Ĉpk ∓ z(1 − α/2)·√(1/(9n) + Ĉpk²/(2(n − 1))) (A. F. Bissell, Applied Statistics 39 (1990) 331–340)."
    )
    m.paragraph(
        "Control limits (ISO 7870-2): individuals x̄ ± 2.66·MR̄ (MR̄ the mean moving range of two); subgroups "
        "of m: x̿ ± A₃·s̄ with A₃ = 3/(c₄√m). A lower limit below a zone's bound 0 is none. Verdicts: ISO "
        "14253-1, the guard band U = k·u of each part's evaluation."
    )
    r.provenance(
        software=f"camcmm {doc.get('camcmm', '')}",
        plugins=[{"id": "gdt.evaluate", "params": doc.get("params") or {}}],
        inputs=[{"file": p["file"], "sha256": p["sha256"]} for p in doc["parts"] if p.get("sha256")],
        extra={"started": doc.get("started"), "finished": doc.get("finished"), "folder": doc.get("folder")},
    )
    r.data = {"summary": summary, "counts": c}
    return r
