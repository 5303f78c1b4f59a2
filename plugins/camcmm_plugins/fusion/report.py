"""The report of a ``fusion.csi`` result (HTML/PDF/JSON through camcmm.api's Report): per
map the two grey images with the inlier matches (thesis fig. 6.5), the registration, the
difference map CSI − photogrammetry, its histogram and Abbott-Firestone curve with the
95 % band (figs. 6.7-6.8)."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Report, charts, numbers


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=150)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return buf.getvalue()


def _fig(w_mm: float, h_mm: float):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.figure(figsize=(w_mm / 25.4, h_mm / 25.4))


def matches_figure(v: dict) -> bytes:
    """The CSI image and the cloud's image side by side, the inlier matches joined."""
    a, b = np.asarray(v["csi_image"], np.uint8), np.asarray(v["photo_image"], np.uint8)
    h = max(a.shape[0], b.shape[0])
    canvas = np.zeros((h, a.shape[1] + 8 + b.shape[1]), np.uint8)
    canvas[: a.shape[0], : a.shape[1]] = a
    canvas[: b.shape[0], a.shape[1] + 8 :] = b
    fig = _fig(170, 170 * h / canvas.shape[1] + 12)
    ax = fig.add_axes((0, 0, 1, 0.92))
    ax.imshow(canvas, cmap="gray", interpolation="nearest")
    pa, pb = np.asarray(v["matches"]["csi"]).reshape(-1, 2), np.asarray(v["matches"]["photo"]).reshape(-1, 2)
    step = max(1, len(pa) // 80)  # at most ~80 lines drawn: more hide the images
    for p, q in zip(pa[::step], pb[::step]):
        ax.plot([p[0], q[0] + a.shape[1] + 8], [p[1], q[1]], "-", lw=0.5, color="#2ca02c")
    ax.set_axis_off()
    fig.suptitle(f"{Path(v['file']).name}: CSI (left) and photogrammetry (right), {len(pa)} inlier matches", fontsize=8)
    return _png(fig)


def difference_figure(v: dict) -> bytes:
    g = np.asarray(v["difference"]["grid"], dtype=float)
    lim = float(np.nanmax(np.abs(g))) * 1000 if np.isfinite(g).any() else 1.0
    fig = _fig(120, 80)
    ax = fig.add_axes((0.1, 0.12, 0.72, 0.78))
    d, x0, y0 = v["difference"]["dx"], v["difference"]["x0"], v["difference"]["y0"]
    extent = (x0, x0 + g.shape[1] * d, y0 + g.shape[0] * d, y0)
    im = ax.imshow(g * 1000, cmap="coolwarm", vmin=-lim, vmax=lim, extent=extent, interpolation="nearest")
    ax.set_xlabel("x (mm, map)", fontsize=7)
    ax.set_ylabel("y (mm, map)", fontsize=7)
    ax.tick_params(labelsize=6)
    cb = fig.colorbar(im, cax=fig.add_axes((0.86, 0.12, 0.03, 0.78)))
    cb.set_label("CSI − photogrammetry (µm)", fontsize=7)
    cb.ax.tick_params(labelsize=6)
    return _png(fig)


def abbott_figure(v: dict) -> bytes | None:
    ab = v["abbott"]
    if ab.get("mr_percent") is None or len(ab["mr_percent"]) == 0:
        return None
    fig = _fig(120, 70)
    ax = fig.add_axes((0.12, 0.15, 0.84, 0.75))
    ax.plot(ab["mr_percent"], np.asarray(ab["height"]) * 1000, color="#1f77b4")
    for m, z in ((2.5, ab["p97_5"]), (97.5, ab["p2_5"])):
        ax.axvline(m, color="grey", ls="--", lw=0.6)
        ax.axhline(z * 1000, color="grey", ls=":", lw=0.6)
    ax.set_xlabel("material ratio (%)", fontsize=7)
    ax.set_ylabel("CSI − photogrammetry (µm)", fontsize=7)
    ax.set_title(
        f"Abbott-Firestone curve; 95 % band {numbers.deviation(ab['p97_5'])} / {numbers.deviation(ab['p2_5'])}",
        fontsize=8,
    )
    ax.tick_params(labelsize=6)
    return _png(fig)


def _um(x, signed: bool = True) -> str:
    """A difference or roughness (mm) in µm by the number rule; "—" when the run has none."""
    return "—" if x is None else numbers.deviation(x, signed=signed)


def build_report(o: dict[str, Any], cloud_file: str | None = None, run=None, **_: Any) -> Report:
    """The report of a ``fusion.csi`` run's outputs ``o``."""
    r_ = o["result"]
    s = r_["photogrammetry_scale"]
    rep = Report(
        "Fusion of CSI height maps with photogrammetry",
        subtitle=f"{cloud_file or o['fused'].name} with {len(r_['maps'])} map(s)",
        meta={"cloud": cloud_file or "", "points fused": r_["n_points_fused"], "rejection": r_.get("reject", "")},
    )
    sec = rep.section("Summary")
    sec.keyvalues(
        [
            (
                "photogrammetry scale",
                numbers.plain(s["value"], 7) + ("" if s["std"] is None else f" ± {numbers.plain(s['std'], 2)}"),
            ),
            ("points in the fused cloud", numbers.count(r_["n_points_fused"])),
            (
                "grey image of the cloud",
                f"{r_['grid'][0]} × {r_['grid'][1]} px of {numbers.length(r_['pixel_mm'], unit='µm')}",
            ),
        ]
    )
    for w in r_["warnings"]:
        sec.warning(w)
    for m, v in zip(r_["maps"], o["views"]["maps"]):
        sec = rep.section(Path(m["file"]).name)
        t, i, d, mr = m["transform2d"], m["icp"], m["difference"], m["material_ratio"]
        sec.keyvalues(
            [
                ("SIFT matches", m["n_matches"]),
                ("inliers (similarity / fundamental)", f"{m['n_inliers_similarity']} / {m['n_inliers_fundamental']}"),
                ("used in eq. 6.1", m["n_inliers"]),
                ("grey image of the map", m.get("grey", "intensity")),
                ("angle", numbers.angle(t["angle_deg"], "deg")),
                ("translation", f"({numbers.plain(t['tx'], 5)}, {numbers.plain(t['ty'], 5)}) px"),
                ("scale", numbers.plain(t["scale"], 7)),
                (
                    "ICP tz, rx, ry",
                    f"{numbers.length(i['tz'], signed=True)}, {numbers.angle(i['rx_deg'], 'deg')}, "
                    f"{numbers.angle(i['ry_deg'], 'deg')}",
                ),
                ("ICP rms / converged", f"{_um(i['rms'], False)} / {'yes' if i['converged'] else 'no'}"),
                ("difference mean / std", f"{_um(d['mean'])} / {_um(d['std'], False)}"),
                ("95 % band", f"{_um(d['p2_5'])} … {_um(d['p97_5'])}"),
                *(
                    [
                        ("Sk, Spk, Svk", f"{_um(mr['Sk'], False)}, {_um(mr['Spk'], False)}, {_um(mr['Svk'], False)}"),
                        ("Smr1, Smr2", f"{numbers.percent(mr['Smr1'] / 100)}, {numbers.percent(mr['Smr2'] / 100)}"),
                    ]
                    if mr.get("Sk") is not None
                    else []
                ),
            ]
        )
        sec.figure(matches_figure(v), caption="The two grey images with the inlier matches (fig. 6.5)")
        sec.figure(difference_figure(v), caption="Difference map CSI − photogrammetry (fig. 6.7)")
        h = v["histogram"]
        if sum(h["counts"]):
            centres = 0.5 * (np.asarray(h["edges"][1:]) + np.asarray(h["edges"][:-1]))
            vals = np.repeat(centres, h["counts"])
            sec.figure(charts.histogram(vals, xlabel="CSI − photogrammetry"), caption="Histogram of the difference")
        ab = abbott_figure(v)
        if ab is not None:
            sec.figure(ab, caption="Abbott-Firestone curve of the difference with the 95 % band (fig. 6.8)")
    if run is not None:
        rep.provenance(
            plugins=[{"id": run.plugin_id, "version": run.plugin_version, "params": run.params}],
            extra={"started": run.started, "finished": run.finished},
        )
    if cloud_file and Path(cloud_file).is_file():
        rep.provenance(inputs=[{"file": str(cloud_file)}])
    rep.data = {k: v for k, v in r_.items()}
    return rep
