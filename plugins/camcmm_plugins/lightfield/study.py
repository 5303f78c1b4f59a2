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

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, checked_path, document_path, read_yaml

from . import fit, lytro

#: The keys a study may hold (a misspelt key is refused, not ignored).
STUDY_KEYS = ("name", "predict_focal_mm", "pixel_pitch_um", "runs", "truth")
#: The keys a run may hold.
RUN_KEYS = (
    "set",
    "artefact",
    "focal_length_mm",
    "cloud",
    "views",
    "depth_maps",
    "lambda_range",
    "gradient_mm_per_lambda",
    "pixel_pitch_um",
)
#: A run's files: the key and whether it names a folder (True), a file (False) or either (None).
RUN_PATHS = (("cloud", False), ("views", None), ("depth_maps", True))


class _Schema:
    """The one validation of a study document: every refusal is one line naming the
    file, the key path (``runs[3].focal_length_mm``, runs counted from 0) and the value."""

    def __init__(self, file: Path | None):
        self.file = file
        self.label = str(file) if file is not None else "study"

    def refuse(self, key: str, value: Any, why: str) -> InputError:
        shown = repr(value)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        return InputError(f"{self.label}: {key} = {shown}: {why}")

    def number(self, value: Any, key: str, *, positive: bool = False) -> float:
        """A finite number (a numeric string too, as YAML keeps quoted numbers text);
        > 0 with ``positive``."""
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            raise self.refuse(key, value, "not a number")
        try:
            x = float(value)
        except (ValueError, OverflowError):
            raise self.refuse(key, value, "not a number") from None
        if not math.isfinite(x):
            raise self.refuse(key, value, "not a finite number")
        if positive and x <= 0:
            raise self.refuse(key, value, "must be above 0")
        return x

    def label_of(self, value: Any, key: str) -> str:
        """A set or artefact name: text or a whole number, not empty."""
        if isinstance(value, bool) or not isinstance(value, (str, int)) or not str(value).strip():
            raise self.refuse(key, value, "give a name (text)")
        return str(value).strip()

    def path(self, value: Any, key: str, folder: bool | None) -> Path:
        """A run's file, resolved (relative to the study's folder) and, in a confined
        run, refused outside the allowed folders before anything looks at it; it must exist."""
        if not isinstance(value, str) or not value.strip():
            raise self.refuse(key, value, "give a path (text)")
        p = document_path(value, self.file, key) if self.file is not None else checked_path(value, key)
        if folder is True and not p.is_dir():
            raise self.refuse(key, value, "no such folder")
        if folder is False and not p.is_file():
            raise self.refuse(key, value, "no such file")
        if folder is None and not p.exists():
            raise self.refuse(key, value, "no such file or folder")
        return p

    def lambda_range(self, value: Any, key: str) -> str:
        """``"MIN,MAX"`` or [MIN, MAX]: finite, MAX above MIN; returned as ``"MIN,MAX"``."""
        if isinstance(value, (list, tuple)):
            if len(value) != 2:
                raise self.refuse(key, value, "give MIN,MAX")
            lo, hi = (self.number(v, key) for v in value)
            text = f"{lo!r},{hi!r}"
        elif isinstance(value, str):
            text = value
        else:
            raise self.refuse(key, value, "give MIN,MAX, e.g. -6.5,9.2")
        try:
            lytro.parse_range(text)
        except InputError as exc:
            raise self.refuse(key, value, str(exc).split(": ", 1)[-1]) from None
        return text

    def run(self, r: Any, i: int, pitch: float | None) -> dict[str, Any]:
        at = f"runs[{i}]"
        if not isinstance(r, dict):
            raise self.refuse(at, r, "a run is a mapping {set, artefact, focal_length_mm, cloud, views, depth_maps}")
        for k in r:
            if k not in RUN_KEYS:
                raise self.refuse(f"{at}.{k}", r[k], f"unknown key; a run holds {', '.join(RUN_KEYS)}")
        for k in ("set", "artefact"):
            if k not in r:
                raise InputError(f"{self.label}: {at}: no '{k}'; a run needs set and artefact")
        out: dict[str, Any] = {"set": self.label_of(r["set"], f"{at}.set")}
        out["artefact"] = self.label_of(r["artefact"], f"{at}.artefact")
        f = r.get("focal_length_mm")
        out["focal_length_mm"] = None if f is None else self.number(f, f"{at}.focal_length_mm", positive=True)
        own_pitch = r.get("pixel_pitch_um")
        out["pixel_pitch_um"] = (
            pitch if own_pitch is None else self.number(own_pitch, f"{at}.pixel_pitch_um", positive=True)
        )
        files = [k for k, _ in RUN_PATHS if r.get(k) is not None]
        if "gradient_mm_per_lambda" in r:
            if files:
                raise self.refuse(
                    f"{at}.{files[0]}", r[files[0]], "a run measured before (gradient_mm_per_lambda) names no files"
                )
            out["gradient_mm_per_lambda"] = self.number(r["gradient_mm_per_lambda"], f"{at}.gradient_mm_per_lambda")
            return out
        missing = [k for k, _ in RUN_PATHS if k not in files]
        if missing:
            raise InputError(
                f"{self.label}: {at}: no {', '.join(missing)}; a run needs cloud, views and depth_maps "
                "(or a gradient_mm_per_lambda measured before)"
            )
        for k, folder in RUN_PATHS:
            out[k] = str(self.path(r[k], f"{at}.{k}", folder))
        if r.get("lambda_range") is not None:
            out["lambda_range"] = self.lambda_range(r["lambda_range"], f"{at}.lambda_range")
        return out

    def truth(self, t: Any, sets: set[str]) -> dict[str, Any] | None:
        """The truth (the virtual lab's): ``sets`` [{set, gradient_mm_per_lambda}] of sets
        the runs have, each once; its other keys are kept as they are."""
        if t is None:
            return None
        if not isinstance(t, dict):
            raise self.refuse("truth", t, "a mapping {sets: [{set, gradient_mm_per_lambda}]}")
        rows = t.get("sets")
        if rows is None:
            return dict(t, sets=[])
        if not isinstance(rows, list):
            raise self.refuse("truth.sets", rows, "a list [{set, gradient_mm_per_lambda}]")
        known: dict[str, float] = {}
        for j, row in enumerate(rows):
            at = f"truth.sets[{j}]"
            if not isinstance(row, dict) or "set" not in row or "gradient_mm_per_lambda" not in row:
                raise self.refuse(at, row, "a mapping {set, gradient_mm_per_lambda}")
            name = self.label_of(row["set"], f"{at}.set")
            if name in known:
                raise self.refuse(f"{at}.set", row["set"], "repeats an earlier truth of that set")
            if name not in sets:
                raise self.refuse(f"{at}.set", row["set"], "no run has that set")
            known[name] = self.number(row["gradient_mm_per_lambda"], f"{at}.gradient_mm_per_lambda")
        return dict(t, sets=[{"set": k, "gradient_mm_per_lambda": v} for k, v in known.items()])

    def study(self, doc: Any) -> dict[str, Any]:
        if not isinstance(doc, dict):
            raise InputError(f"{self.label}: a study is a mapping with 'runs' (docs/studies.md)")
        for k in doc:
            if k not in STUDY_KEYS:
                raise self.refuse(str(k), doc[k], f"unknown key; a study holds {', '.join(STUDY_KEYS)}")
        runs = doc.get("runs")
        if not isinstance(runs, list) or not runs:
            raise self.refuse(
                "runs", runs, "a study lists runs [{set, artefact, focal_length_mm, cloud, views, depth_maps}]"
            )
        name = doc.get("name")
        if name is not None and not isinstance(name, (str, int, float)):
            raise self.refuse("name", name, "give the study's name as text")
        pitch = doc.get("pixel_pitch_um")
        pitch = None if pitch is None else self.number(pitch, "pixel_pitch_um", positive=True)
        predict = doc.get("predict_focal_mm")
        predict = None if predict is None else self.number(predict, "predict_focal_mm", positive=True)
        out_runs: list[dict[str, Any]] = []
        seen: dict[tuple[str, str], int] = {}
        for i, r in enumerate(runs):
            run = self.run(r, i, pitch)
            key = (run["set"], run["artefact"])
            if key in seen:  # a repeated run would silently replace the first in table 6.3
                raise InputError(
                    f"{self.label}: runs[{i}]: set {run['set']!r}, artefact {run['artefact']!r} repeats "
                    f"runs[{seen[key]}]; one run per set and artefact"
                )
            seen[key] = i
            out_runs.append(run)
        truth = self.truth(doc.get("truth"), {r["set"] for r in out_runs})
        return {
            "name": None if name is None else str(name),
            "predict_focal_mm": predict,
            "runs": out_runs,
            "truth": truth,
        }


def load_study(study: Any) -> tuple[dict[str, Any], Path]:
    """The study validated (:class:`_Schema`: one line naming the file, the key path and
    the value for any problem; every path resolved through ``document_path`` and checked
    to exist before any run is read) and the folder its relative paths start from."""
    if isinstance(study, (str, Path)):
        p = checked_path(study, "study")
        if not p.is_file():
            raise InputError(f"{study}: no such study file")
        doc, file = read_yaml(p), p
    else:
        doc, file = study, None
    return _Schema(file).study(doc), (file.parent if file is not None else Path.cwd())


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
    doc, _ = load_study(study)
    params = dict(params or {})
    runs_out, scatter = [], []
    n = len(doc["runs"])
    for i, r in enumerate(doc["runs"]):
        if progress:
            progress(0.02 + 0.9 * i / n, f"{r['set']} / {r['artefact']}")
        row = {"set": r["set"], "artefact": r["artefact"], "focal_length_mm": r["focal_length_mm"]}
        if "gradient_mm_per_lambda" in r:
            row.update(gradient_mm_per_lambda=r["gradient_mm_per_lambda"], std=None, n_views=None, views=[])
        else:
            p = dict(params)
            if r.get("lambda_range") is not None:
                p["lambda_range"] = r["lambda_range"]
            o = gradient(cloud=r["cloud"], views=r["views"], depth_maps=r["depth_maps"], **p)
            res = o["result"]
            row.update(gradient_mm_per_lambda=res["mean"], std=res["std"], n_views=res["n_views"], views=res["views"])
            pitch = r["pixel_pitch_um"]
            if row["focal_length_mm"] is None and pitch is not None:
                # the calibrated focal length of fig. 6.16: the reconstruction's own fx (px) times the pixel pitch
                row["focal_length_mm"] = res["focal_length_px"] * pitch / 1000.0
            scatter.append({"set": row["set"], "artefact": row["artefact"], "views": o["scatter"]})
        runs_out.append(row)
    tab = table(runs_out)
    predict = predict_focal_mm if predict_focal_mm is not None else doc["predict_focal_mm"]
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
    if doc["truth"] is not None and doc["truth"]["sets"]:
        known = {t["set"]: t["gradient_mm_per_lambda"] for t in doc["truth"]["sets"]}
        truth = {
            "sets": [
                {"set": s, "true": known[s], "mean": m, "difference": m - known[s]}
                for s, m in zip(tab["sets"], tab["mean"])
                if s in known and m is not None
            ],
            "gradient_law": doc["truth"].get("gradient_law"),
        }
    return {"table": tab, "focal": focal, "runs": runs_out, "scatter": scatter, "truth": truth, "name": doc.get("name")}
