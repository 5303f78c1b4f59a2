"""The report of a GD&T evaluation (``camcmm gdt evaluate --report DIR``): one
:class:`camcmm.api.Report` rendered as HTML, PDF and JSON.

A report for the customer. Its head: customer, part number, order, drawing revision,
operator, instrument, date, temperature (the plan's ``report:`` mapping, the command's
``--customer`` … options). Body: the overall verdict (every characteristic in tolerance,
or which are not / undecided), the characteristics as on a drawing (ISO 1101 symbol,
datums, tolerance or limits, value, U = k·u, ISO 14253-1 guarded verdict), a view of the
part in plan coordinates coloured by feature with the characteristics' labels, the
signature fields. No internal key or parameter in the body: the appendix holds the
uncertainty methods and the evaluation's notes, alignment (method, transform, rms, free
degrees of freedom, stages), features (type, association, points, form) and the
provenance (plugin ids, parameters, input hashes).

Symbols: ISO 1101's where the report's font (DejaVu Sans) has the glyph; position ⊕,
straightness —, cylindricity /○/, profiles ◠, symmetry ≡, total runout ⇗ stand in for
the missing ones (⌖ ⏤ ⌭ ⌒ ⌓ ⌯ ⌰).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Report, charts, numbers

#: Drawing symbol of each characteristic type (see the module docstring for stand-ins).
SYMBOLS = {
    "straightness": "—",
    "flatness": "⏥",
    "roundness": "○",
    "cylindricity": "/○/",
    "line-profile": "◠",
    "surface-profile": "◠",
    "profile": "◠",
    "parallelism": "∥",
    "perpendicularity": "⊥",
    "angularity": "∠",
    "position": "⊕",
    "coaxiality": "◎",
    "concentricity": "◎",
    "symmetry": "≡",
    "circular-runout": "↗",
    "total-runout": "⇗",
    "diameter": "⌀",
    "width": "↔",
    "distance": "↔",
}
_MM = 1 / 25.4
_DPI = 150


def _mm(x: Any, digits: int = 4) -> str:
    """A length in mm by the number rule: a real minus, 0 (not "-0.0000") for what rounds to zero."""
    return "—" if x is None else numbers.mm(x, None, digits)


def _limits(c: dict[str, Any]) -> str:
    if c.get("tolerance") is not None:
        return numbers.significant(c["tolerance"], 6)
    lo, hi = c.get("lower"), c.get("upper")
    return " / ".join("—" if v is None else f"{v:+g}" for v in (lo, hi))


def part_view(points: np.ndarray, feature: np.ndarray, names: list[str], labels: list[dict[str, Any]]) -> bytes:
    """Two orthographic views of the part (plan coordinates) coloured by feature, grey for
    points of none, the characteristics' decisive points ringed and their ids written at
    their anchors. PNG bytes with the chart's info."""
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    P = np.asarray(points, float)
    rng = np.random.default_rng(0)
    idx = np.arange(len(P)) if len(P) <= 30000 else rng.choice(len(P), 30000, replace=False)
    views = ((np.array([1.0, -1.0, 0.8]), "from +x −y +z"), (np.array([-1.0, 1.0, 0.8]), "from −x +y +z"))
    fig = Figure(figsize=(170 * _MM, 80 * _MM), dpi=_DPI)
    cmap = colormaps["tab10"]
    for i, (d, title) in enumerate(views):
        ax = fig.add_subplot(1, 2, i + 1)
        d = d / np.linalg.norm(d)
        ex = np.cross([0.0, 0.0, 1.0], d)
        ex /= np.linalg.norm(ex)
        ey = np.cross(d, ex)
        depth = P[idx] @ d
        order = idx[np.argsort(depth)]
        f = feature[order]
        colours = np.where(f[:, None] >= 0, np.array([cmap(int(k) % 10) for k in np.maximum(f, 0)]), (0.8, 0.8, 0.8, 1))
        ax.scatter(P[order] @ ex, P[order] @ ey, s=1.0, c=colours, linewidths=0)
        anchors: dict[tuple[float, ...], list[str]] = {}
        for lab in labels:
            dec = np.asarray(lab["decisive"], float).reshape(-1, 3)
            if len(dec):
                ax.scatter(dec @ ex, dec @ ey, s=12, facecolors="none", edgecolors="k", linewidths=0.6)
            anchors.setdefault(tuple(np.round(lab["anchor"], 3)), []).append(lab["id"])
        for a, ids in anchors.items():  # one text per anchor: a feature's characteristics together
            ax.annotate("\n".join(ids), (np.dot(a, ex), np.dot(a, ey)), fontsize=6, ha="center", va="bottom")
        ax.set_aspect("equal")
        ax.set_axis_off()
        ax.set_title(f"view {title}", fontsize=7)
    handles = [Line2D([], [], marker="o", ls="", color=cmap(i % 10), label=n) for i, n in enumerate(names)]
    fig.legend(handles=handles, loc="lower center", ncol=min(len(names), 8), fontsize=6, frameon=False)
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI)
    return charts.ChartPNG(
        buf.getvalue(), {"chart": "gdt_part_view", "n_points": int(len(P)), "n_drawn": int(len(idx))}
    )


#: The alignment methods as a person reads them.
ALIGNMENTS = {
    "best-fit": "best fit to the nominal",
    "datums": "datum reference frame",
    "rps": "reference point system (RPS)",
    "3-2-1": "3-2-1 from features",
    "none": "none (measured in the drawing's coordinates)",
}


def _title(kind: str) -> str:
    """A characteristic's type in words: ``surface-profile`` -> ``Surface profile``."""
    return str(kind).replace("-", " ").capitalize()


def _name(f: Any) -> str:
    """A file's name as the body shows it (its full path is in the provenance)."""
    return Path(str(f)).name if f else ""


def customer_fields(plan: Any) -> Any:
    """The ``report:`` mapping of a plan (a Plan's options or a plan document), or None."""
    if isinstance(plan, dict):
        return plan.get("report")
    return (getattr(plan, "options", None) or {}).get("report")


def build_report(
    o: dict[str, Any],
    plan: Any = None,
    plan_file: str | None = None,
    cloud_file: str | None = None,
    nominal_file: str | None = None,
    run: Any = None,
    customer: dict[str, str] | None = None,
) -> Report:
    """The customer report of a ``gdt.evaluate`` result ``o`` (its outputs dict).

    Body: the order's fields (``customer`` — checked fields, e.g. from
    ``Report.customer_fields`` — else the plan's ``report:`` mapping), the overall verdict,
    the characteristics as on the drawing, the measured part, the signature fields.
    Appendix: uncertainty methods and the evaluation's notes, alignment, features,
    provenance (plugin ids, parameters, input hashes)."""
    chars, feats, a = o["characteristics"], o["features"], o["alignment"]
    aligned = o.get("aligned")
    fields = customer if customer is not None else Report.customer_fields(customer_fields(plan), where="plan: report")
    r = Report(
        "Inspection report: geometric tolerances",
        subtitle="ISO 1101 characteristics with their measurement uncertainty, decided by ISO 14253-1",
        meta={
            "Measured data": _name(cloud_file) or (aligned.name if aligned is not None else "—"),
            "Inspection plan": _name(plan_file) or "—",
            "Nominal": _name(nominal_file) or "the plan's nominal geometry",
            "Alignment": ALIGNMENTS.get(str(a.get("method")), str(a.get("method", ""))),
        },
    ).customer(fields)

    s = r.section("Result")
    names = [(str(c["id"]), c["verdict_guarded"]) for c in chars]
    word, sentence = Report.overall_verdict(names)
    simple, _ = Report.overall_verdict([(str(c["id"]), c["verdict"]) for c in chars])
    ok = sum(c["verdict_guarded"] == "conform" for c in chars)
    s.verdict("Part", simple, word, value=f"{ok} of {len(chars)} in tolerance", limit="drawing tolerances")
    s.paragraph(sentence)
    warnings = list(run.warnings) if run is not None else []
    if warnings:
        s.paragraph(f"The evaluation noted {len(warnings)} point(s) to check; they are listed in the appendix.")

    s = r.section("Characteristics")
    ks = {c["k"] for c in chars}
    one_k = len(ks) == 1
    s.table(
        [
            "No.",
            "Characteristic",
            "Feature",
            "Datums",
            "Tolerance mm",
            "Value mm",
            f"U mm (k = {numbers.significant(next(iter(ks)), 3)})" if one_k else "U mm (k)",
            "Verdict",
        ],
        [
            [
                c["id"],
                f"{SYMBOLS.get(c['type'], '')}\u2002{_title(c['type'])}".strip(),
                c["feature"],
                "|".join(c["datums"]) or "—",
                _limits(c),
                _mm(c["value"]),
                _mm(c["U"]) if one_k or c["U"] is None else f"{_mm(c['U'])} ({numbers.significant(c['k'], 3)})",
                c["verdict_guarded"],
            ]
            for c in chars
        ],
        caption="As on the drawing: a zone's width, or a size's limits as deviations from the nominal; "
        "U the expanded uncertainty; the verdict by ISO 14253-1 (U as guard band).",
        align=["left", "left", "left", "left", "right", "right", "right", "left"],
    )
    if aligned is not None and "feature" in aligned.fields:
        s = r.section("Measured part")
        s.figure(
            part_view(
                aligned.points, np.asarray(aligned.fields["feature"]).astype(int), [f["id"] for f in feats], o["labels"]
            ),
            caption="The measured points in the drawing's coordinates, coloured by feature (grey: none); "
            "ringed: the points that decide each characteristic.",
        )
    s = r.section("Signatures")
    s.signature((("Inspected by", fields.get("operator", "")), ("Approved by", "")))

    s = r.section("Uncertainty and notes", appendix=True)
    notes = [(c["id"], c.get("u_method") or (c.get("details") or {}).get("reason", "")) for c in chars]
    s.keyvalues(notes, caption="Uncertainty method (or why not evaluated)")
    for c in chars:
        if c["verdict"] != c["verdict_guarded"]:
            s.paragraph(f"{c['id']}: simple verdict {c['verdict']}, with U as guard band {c['verdict_guarded']}.")
    for w in warnings:
        s.warning(w)

    s = r.section("Alignment", appendix=True)
    kv = [
        ("method", a.get("method")),
        ("settled", a.get("converged")),
        ("iterations", a.get("iterations")),
        ("rms to the nominals", f"{_mm(a.get('rms'), 5)} mm"),
        ("rotation", f"{a.get('rotation_angle_deg', 0):.6f}°"),
        ("translation", "(" + ", ".join(f"{v:.5f}" for v in a.get("translation", [])) + ") mm"),
        ("free (held)", "; ".join(a.get("free") or []) or "none"),
    ]
    for st in a.get("stages", []):
        kv.append((str(st.get("stage")), str(st.get("kind", ""))))
    s.keyvalues(kv)
    s.table(
        ["", "1", "2", "3", "4"],
        [[f"row {i + 1}", *[f"{v:.9g}" for v in row]] for i, row in enumerate(a["transform"])],
        caption="Transform measured → plan coordinates (4×4)",
    )

    s = r.section("Features", appendix=True)
    s.table(
        ["id", "type", "association", "points", "form range mm", "status"],
        [
            [
                f["id"],
                f["type"],
                f["association"],
                f["n_points"],
                _mm((f.get("form") or {}).get("range")),
                f["status"] if f["status"] == "evaluated" else f"not evaluated: {f.get('reason', '')}",
            ]
            for f in feats
        ],
    )
    if o.get("datums"):
        s.keyvalues([(d["label"], d["feature"]) for d in o["datums"]], caption="Datums")

    if run is not None:
        r.provenance(
            plugins=[{"id": run.plugin_id, "version": run.plugin_version, "params": run.params}],
            extra={"started": run.started, "finished": run.finished},
        )
    r.provenance(
        inputs=[{"file": str(f)} for f in (plan_file, cloud_file, nominal_file) if f and Path(str(f)).is_file()]
    )
    r.data = {
        "characteristics": chars,
        "features": feats,
        "alignment": a,
        "datums": o.get("datums"),
        "customer": fields,
        "verdict": word,
    }
    return r
