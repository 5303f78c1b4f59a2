"""Reports of ``lightfield.gradient`` (per-view table, depth-vs-lambda scatter with its line,
fig. 6.15) and ``lightfield.study`` (table 6.3's layout, fig. 6.16's fit and prediction)."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Report


def _fig(w_mm: float, h_mm: float):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.figure(figsize=(w_mm / 25.4, h_mm / 25.4))


def _png(fig) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=150)
    plt.close(fig)
    return buf.getvalue()


def scatter_figure(s: dict[str, Any]) -> bytes:
    """Depth against lambda of one view, the pixels left out in grey, the fitted line (fig. 6.15)."""
    lam, d, used = np.asarray(s["lambda"]), np.asarray(s["depth"]), np.asarray(s["used"], bool)
    fig = _fig(85, 65)
    ax = fig.add_axes((0.17, 0.16, 0.78, 0.74))
    ax.plot(lam[~used], d[~used], ".", ms=1.5, color="#bbbbbb", label="left out")
    ax.plot(lam[used], d[used], ".", ms=1.5, color="#1f77b4", label="fitted")
    if len(lam):
        x = np.array([lam.min(), lam.max()])
        ax.plot(x, s["gradient_mm_per_lambda"] * x + s["intercept"], "-", color="#d62728", lw=1)
    ax.set_xlabel("λ (eq. 6.5)", fontsize=7)
    ax.set_ylabel("photogrammetric depth (mm)", fontsize=7)
    ax.set_title(f"{Path(s['image']).name}: {s['gradient_mm_per_lambda']:.4f} mm/λ", fontsize=8)
    ax.tick_params(labelsize=6)
    ax.legend(fontsize=6, markerscale=4)
    return _png(fig)


def focal_figure(f: dict[str, Any]) -> bytes:
    """Set mean gradient against focal length with the first-order fit (fig. 6.16)."""
    pts = f["points"]
    x = np.array([p["focal_length_mm"] for p in pts])
    y = np.array([p["mean"] for p in pts])
    e = np.array([p["std"] or 0.0 for p in pts])
    fig = _fig(100, 70)
    ax = fig.add_axes((0.14, 0.15, 0.82, 0.75))
    ax.errorbar(x, y, yerr=e, fmt="o", ms=3, color="#1f77b4", capsize=2)
    xs = np.linspace(x.min(), x.max(), 50)
    p = f.get("predicted")
    if p:
        xs = np.linspace(min(x.min(), p["focal_length"]), max(x.max(), p["focal_length"]), 50)
        ax.errorbar(
            [p["focal_length"]],
            [p["gradient_mm_per_lambda"]],
            yerr=[p["u"] or 0.0],
            fmt="s",
            color="#d62728",
            ms=3,
            capsize=2,
        )
    ax.plot(xs, f["slope"] * xs + f["intercept"], "-", color="#555555", lw=1)
    ax.set_xlabel("calibrated focal length (mm)", fontsize=7)
    ax.set_ylabel("gradient (mm λ⁻¹)", fontsize=7)
    ax.set_title(f"gradient = {f['slope']:.5f} f {f['intercept']:+.4f} (r² {f['r2']:.4f})", fontsize=8)
    ax.tick_params(labelsize=6)
    return _png(fig)


def _provenance(rep: Report, run) -> None:
    if run is not None:
        rep.provenance(
            plugins=[{"id": run.plugin_id, "version": run.plugin_version, "params": run.params}],
            extra={"started": run.started, "finished": run.finished},
        )


def gradient_report(o: dict[str, Any], run=None, max_figures: int = 12, **_: Any) -> Report:
    """The report of a ``lightfield.gradient`` run's outputs ``o``."""
    r = o["result"]
    rep = Report("Light-field depth gradient", subtitle=f"{r['n_views']} view(s)", meta={"band": r.get("band")})
    sec = rep.section("Summary")
    std = "—" if r["std"] is None else f"{r['std'] * 1000:.1f} µm λ⁻¹ (sample, n-1)"
    sec.keyvalues([("mean gradient", f"{r['mean']:.4f} mm λ⁻¹"), ("standard deviation", std), ("views", r["n_views"])])
    for w in r.get("warnings", []):
        sec.warning(w)
    sec.table(
        ["view", "gradient / mm λ⁻¹", "u / mm λ⁻¹", "intercept / mm", "r²", "pixels", "band", "rejected"],
        [
            [
                Path(v["image"]).name,
                round(v["gradient_mm_per_lambda"], 5),
                round(v["u_gradient"], 5),
                round(v["intercept"], 3),
                round(v["r2"], 5),
                v["n_pixels"],
                v["n_band"],
                v["n_rejected"],
            ]
            for v in r["views"]
        ],  # fmt: skip
        caption="Per view: least-squares line of photogrammetric depth against λ",
    )
    figs = rep.section("Depth against λ (fig. 6.15)")
    for s in o["scatter"][:max_figures]:
        figs.figure(scatter_figure(s), caption=Path(s["image"]).name, data={"lambda": s["lambda"], "depth": s["depth"]})
    _provenance(rep, run)
    rep.data = {k: v for k, v in r.items()}
    return rep


def study_report(o: dict[str, Any], run=None, **_: Any) -> Report:
    """The report of a ``lightfield.study`` run: table 6.3, fig. 6.16, the truth when known."""
    t = o["table"]
    rep = Report("Light-field scale study", subtitle=o["result"].get("name") or "", meta={"sets": len(t["sets"])})
    sec = rep.section("Gradient data (table 6.3)")
    rows = [[a, *[None if g is None else round(g, 4) for g in row]] for a, row in zip(t["artefacts"], t["gradients"])]
    rows.append(["Standard deviation / µm λ⁻¹", *[None if s is None else round(s * 1000, 1) for s in t["std"]]])
    rows.append(["Mean / mm λ⁻¹", *[None if m is None else round(m, 4) for m in t["mean"]]])
    rows.append(["Focal length / mm", *[None if f is None else round(f, 2) for f in t["focal_length_mm"]]])
    sec.table(
        ["Artefact", *t["sets"]],
        rows,
        caption="Gradient / mm λ⁻¹ per artefact and set; the standard deviation of each set is the sample one (n-1)",
    )
    for w in o["result"].get("warnings", []):
        sec.warning(w)
    f = o.get("focal")
    if f:
        fs = rep.section("Gradient against focal length (fig. 6.16)")
        kv = [
            ("slope", f"{f['slope']:.6f} mm λ⁻¹ per mm"),
            ("intercept", f"{f['intercept']:.5f} mm λ⁻¹"),
            ("r²", f"{f['r2']:.5f}"),
        ]
        if f.get("cov"):
            kv.append(("u(slope), u(intercept)", f"{np.sqrt(f['cov'][0][0]):.6f}, {np.sqrt(f['cov'][1][1]):.5f}"))
        p = f.get("predicted")
        if p:
            u = "—" if p["u"] is None else f"{p['u']:.5f} (line), {p['u_new_set']:.5f} (a new set)"
            kv.append((f"predicted at {p['focal_length']:g} mm", f"{p['gradient_mm_per_lambda']:.5f} mm λ⁻¹, u {u}"))
        fs.keyvalues(kv)
        fs.figure(focal_figure(f), caption="Set mean gradient against calibrated focal length, first-order fit")
    tr = o.get("truth")
    if tr:
        ts = rep.section("Against the truth (virtual lab)")
        ts.table(
            ["set", "true / mm λ⁻¹", "recovered / mm λ⁻¹", "difference / µm λ⁻¹"],
            [
                [s["set"], round(s["true"], 5), round(s["mean"], 5), round(s["difference"] * 1000, 2)]
                for s in tr["sets"]
            ],
        )
    _provenance(rep, run)
    rep.data = {k: v for k, v in o["result"].items()}
    return rep
