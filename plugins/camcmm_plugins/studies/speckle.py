"""The speckle on/off study of thesis ch. 6.2 (plugin ``studies.speckle``): every
artefact × material measured with and without laser speckle, tables 6.1 (std of the
deviations from CAD, µm) and 6.2 (point counts), plus the coverage by area of the CAD
surface per face class that the thesis names as its missing piece (ch. 6.2.4).

Resuming: each finished case is stored in the study's work folder
(``<work>/<case>/result.json`` and ``deviations.ply``), written last and atomically, with
a key of the settings it was computed with; a rerun reuses every case whose key matches
and computes only the others, so an interrupted study loses at most the case it was on.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import CamcmmError, Cancelled, InputError, read, write

from . import cases, studyfile


def _load_case(folder: Path, key: str) -> dict[str, Any] | None:
    f = folder / "result.json"
    try:
        d = json.loads(f.read_text("utf-8"))
    except (OSError, ValueError):
        return None
    if d.get("key") != key or not (folder / "deviations.ply").is_file():
        return None
    return d


def _store_case(folder: Path, key: str, out: dict[str, Any]) -> None:
    write(out["deviations"], folder / "deviations.ply")
    tmp = folder / "result.json.tmp"
    tmp.write_text(json.dumps({**out["result"], "key": key}, indent=1), encoding="utf-8")
    os.replace(tmp, folder / "result.json")  # the result appears only when the case is whole


def summary(results: list[dict[str, Any]]) -> dict[str, Any]:
    """Per material: the mean change with speckle (on − off, over the artefacts with both)
    of std_um, n_points and coverage_area_fraction; the thesis's "101 µm decrease for
    nylon" is ``std_um_change = -101``."""
    by = {(r["artefact"], r["material"], r["condition"]): r for r in results if "std_um" in r}
    out: dict[str, Any] = {}
    for m in dict.fromkeys(r["material"] for r in results):
        pairs = [
            (by[(a, m, "off")], by[(a, m, "on")])
            for a in dict.fromkeys(r["artefact"] for r in results)
            if (a, m, "off") in by and (a, m, "on") in by
        ]
        if not pairs:
            out[m] = {"n_artefacts": 0}
            continue
        ch = lambda k: float(np.mean([on[k] - off[k] for off, on in pairs]))  # noqa: E731
        out[m] = {
            "n_artefacts": len(pairs),
            "std_um_change": ch("std_um"),
            "std_um_relative_change": float(np.mean([on["std_um"] / off["std_um"] - 1 for off, on in pairs])),
            "n_points_change": ch("n_points"),
            "coverage_area_fraction_change": ch("coverage_area_fraction"),
        }
    return out


def run_study(ctx, study: dict[str, Any], fresh: bool = False) -> dict[str, Any]:
    """Run (or resume) every case of ``study`` (studyfile.load); returns the outputs of
    ``studies.speckle``."""
    work = Path(study["work"])
    try:  # studyfile.load checked it can be; a folder changed since is still one line
        work.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{Path(study['file']).name}: work: {work} cannot be created ({exc.strerror})") from None
    results, clouds, computed, failed = [], {}, [], []
    n = len(study["cases"])
    for k, case in enumerate(study["cases"]):
        folder = work / case["id"]
        key = studyfile.case_key(study, case)
        done = None if fresh else _load_case(folder, key)
        if done is None:
            ctx.progress(k / n, f"case {k + 1}/{n}: {case['id']}")
            if folder.exists():
                shutil.rmtree(folder)
            folder.mkdir(parents=True)
            try:
                out = cases.run_case(ctx, study, case, folder)
            except Cancelled:
                raise
            except CamcmmError as exc:  # one failed case must not lose the others
                ctx.warn(f"case {case['id']}: {exc}")
                failed.append(case["id"])
                results.append({**case, "error": str(exc)})
                continue
            if study["simulated"] is not None:
                shutil.rmtree(folder / "images", ignore_errors=True)  # rendered again on demand
            _store_case(folder, key, out)
            computed.append(case["id"])
            done = {**out["result"], "key": key}
            clouds[case["id"]] = out["deviations"]
        else:
            clouds[case["id"]] = read(folder / "deviations.ply")
        if done.get("warning"):
            ctx.warn(done["warning"])
        results.append(done)
    ctx.progress(1.0, "done")
    return {
        "cases": results,
        "summary": summary(results),
        "deviation_clouds": clouds,
        "computed": computed,
        "reused": [c["id"] for c in study["cases"] if c["id"] not in computed and c["id"] not in failed],
        "failed": failed,
        "study": {k: study[k] for k in ("file", "name", "work", "artefacts", "materials", "conditions")},
    }


def speckle_study(ctx, study: str, fresh: bool = False) -> dict[str, Any]:
    """studies.speckle: run or resume the study of STUDY.yaml ``study`` (validated whole,
    its artefacts' CAD built once, before the work folder is created)."""
    st = studyfile.load(study)
    studyfile.check_cad(ctx, st)
    return run_study(ctx, st, fresh)
