"""A light-field scale study: table 6.3 (artefacts × sets of mean gradients, each set's
sample standard deviation) and fig. 6.16 (set mean against calibrated focal length, a
first-order fit, the gradient predicted for a new focal length).

A study file (YAML or JSON) lists runs; paths are relative to the file::

    name: my parts
    predict_focal_mm: 45          # optional
    pixel_pitch_um: 1.4           # optional: a run without focal_length_mm gets fx (px) × pitch
    runs:
      - {set: Set 1, artefact: Pillars, focal_length_mm: 30.2,
         cloud: p1/cloud.ply, views: p1/views.json, depth_maps: p1/depth, lambda_range: "-6,9"}
      - {set: Set 1, artefact: Pyramid, focal_length_mm: 30.2, gradient_mm_per_lambda: 3.9422}  # measured before
    truth: {sets: [{set: Set 1, gradient_mm_per_lambda: 3.5}]}   # optional (the virtual lab's)
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, read_yaml

from . import fit


def load_study(study: Any) -> tuple[dict[str, Any], Path]:
    """The study dict and the folder its relative paths start from."""
    if isinstance(study, (str, Path)):
        p = Path(study)
        if not p.is_file():
            raise InputError(f"{p}: no such study file")
        doc, base = read_yaml(p), p.parent
    else:
        doc, base = study, Path.cwd()
    name = str(study) if isinstance(study, (str, Path)) else "study"
    if not isinstance(doc, dict) or not isinstance(doc.get("runs"), list) or not doc["runs"]:
        raise InputError(f"{name}: a study lists 'runs' [{{set, artefact, focal_length_mm, cloud, views, depth_maps}}]")
    for i, r in enumerate(doc["runs"]):
        if not isinstance(r, dict) or "set" not in r or "artefact" not in r:
            raise InputError(f"{name}: run {i + 1} needs 'set' and 'artefact'")
        if "gradient_mm_per_lambda" not in r and not all(k in r for k in ("cloud", "views", "depth_maps")):
            raise InputError(f"{name}: run {i + 1} needs cloud, views and depth_maps (or a gradient_mm_per_lambda)")
    return doc, base


def table(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Table 6.3 from runs [{set, artefact, gradient_mm_per_lambda, focal_length_mm}]:
    ``sets``, ``artefacts`` (first-seen order), ``gradients`` [artefact][set] (None: not
    run), per set ``mean``, ``std`` (sample, ddof 1), ``n``, ``focal_length_mm`` (the
    set's mean, None if not given)."""
    sets = list(dict.fromkeys(str(r["set"]) for r in runs))
    arts = list(dict.fromkeys(str(r["artefact"]) for r in runs))
    grid: list[list[float | None]] = [[None] * len(sets) for _ in arts]
    focal: dict[str, list[float]] = {s: [] for s in sets}
    for r in runs:
        grid[arts.index(str(r["artefact"]))][sets.index(str(r["set"]))] = float(r["gradient_mm_per_lambda"])
        if r.get("focal_length_mm") is not None:
            focal[str(r["set"])].append(float(r["focal_length_mm"]))
    stats = [fit.set_stats([v for v in (row[j] for row in grid) if v is not None]) for j in range(len(sets))]
    return {
        "sets": sets,
        "artefacts": arts,
        "gradients": grid,
        "mean": [s["mean"] for s in stats],
        "std": [s["std"] for s in stats],
        "n": [s["n"] for s in stats],
        "std_ddof": 1,
        "focal_length_mm": [float(np.mean(focal[s])) if focal[s] else None for s in sets],
    }


def run_study(
    study: Any,
    gradient: Callable[..., dict[str, Any]],
    *,
    predict_focal_mm: float | None = None,
    params: dict[str, Any] | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> dict[str, Any]:
    """Run every run's ``gradient`` (lightfield.gradient as a callable, with ``params``),
    build table 6.3, fit the focal length and compare with the truth when the study has it.

    Returns
    -------
    dict ``table`` (:func:`table`), ``focal`` (``points`` [{set, focal_length_mm, mean,
    std, n}] and :func:`fit.focal_fit`'s keys, or None with fewer than two focal lengths),
    ``runs`` [{set, artefact, focal_length_mm, gradient_mm_per_lambda, std, n_views,
    views}], ``scatter`` [{set, artefact, views: [...]}], ``truth`` (per set the true
    gradient and the recovered mean's difference, when known).
    """
    doc, base = load_study(study)
    params = dict(params or {})
    runs_out, scatter = [], []
    n = len(doc["runs"])
    for i, r in enumerate(doc["runs"]):
        if progress:
            progress(0.02 + 0.9 * i / n, f"{r['set']} / {r['artefact']}")
        row = {"set": str(r["set"]), "artefact": str(r["artefact"]), "focal_length_mm": r.get("focal_length_mm")}
        if "gradient_mm_per_lambda" in r:
            row.update(gradient_mm_per_lambda=float(r["gradient_mm_per_lambda"]), std=None, n_views=None, views=[])
        else:
            p = dict(params)
            if r.get("lambda_range") is not None:
                p["lambda_range"] = str(r["lambda_range"])
            o = gradient(
                cloud=str(base / r["cloud"]), views=str(base / r["views"]), depth_maps=str(base / r["depth_maps"]), **p
            )
            res = o["result"]
            row.update(gradient_mm_per_lambda=res["mean"], std=res["std"], n_views=res["n_views"], views=res["views"])
            pitch = r.get("pixel_pitch_um", doc.get("pixel_pitch_um"))
            if row["focal_length_mm"] is None and pitch is not None:
                # the calibrated focal length of fig. 6.16: the reconstruction's own fx (px) times the pixel pitch
                row["focal_length_mm"] = res["focal_length_px"] * float(pitch) / 1000.0
            scatter.append({"set": row["set"], "artefact": row["artefact"], "views": o["scatter"]})
        runs_out.append(row)
    tab = table(runs_out)
    predict = predict_focal_mm if predict_focal_mm is not None else doc.get("predict_focal_mm")
    pts = [
        {"set": s, "focal_length_mm": f, "mean": m, "std": sd, "n": k}
        for s, f, m, sd, k in zip(tab["sets"], tab["focal_length_mm"], tab["mean"], tab["std"], tab["n"])
        if f is not None and m is not None
    ]
    focal = None
    if len({p["focal_length_mm"] for p in pts}) >= 2:
        focal = {
            "points": pts,
            **fit.focal_fit(
                [p["focal_length_mm"] for p in pts],
                [p["mean"] for p in pts],
                None if predict is None else float(predict),
            ),
        }
    truth = None
    if isinstance(doc.get("truth"), dict) and doc["truth"].get("sets"):
        known = {str(t["set"]): float(t["gradient_mm_per_lambda"]) for t in doc["truth"]["sets"]}
        truth = {
            "sets": [
                {"set": s, "true": known[s], "mean": m, "difference": m - known[s]}
                for s, m in zip(tab["sets"], tab["mean"])
                if s in known and m is not None
            ],
            "gradient_law": doc["truth"].get("gradient_law"),
        }
    return {"table": tab, "focal": focal, "runs": runs_out, "scatter": scatter, "truth": truth, "name": doc.get("name")}
