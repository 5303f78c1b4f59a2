"""Scale factor of a camera system against a laser interferometer (thesis 3.2.3,
figs. 3.10-3.11, eq. 3.22).

A target on a linear stage is tracked by the camera system while an interferometer
measures the stage position. Per run, the camera displacement d_cam (from the run's
first position) is regressed on the interferometer displacement d_int:
d_cam = s d_int + b (scipy.stats.linregress; the interferometer is taken as exact, its
error enters as u_cal). The correction for camera lengths is ``scale_factor`` = 1 / s.

CSV columns (a header row; ',', ';' or tab separated; lengths in mm):

    run             optional: repeat id (number or text); rows of a run in stage order
    interferometer  interferometer position (aliases: laser, reference)
    camera          the camera system's 1-D position along the motion (aliases:
                    position, measured), OR
    x, y, z         the camera system's 3-D target position; the displacement is the
                    projection of (p - p_first) on the run's fitted line of motion

Uncertainty (eq. 3.22) for a length L (default: the travel): u(length) = sqrt(u_cal^2 +
u_p^2), u_cal = accuracy L / sqrt(3) (the interferometer's relative accuracy as a
rectangular half-width; Renishaw XL-80: 5e-7), u_p = std of the runs' slopes x L
(repeatability over runs; a single run: the slope's standard error x L).
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, ParameterError

_ALIASES = {
    "interferometer": ("interferometer", "laser", "reference"),
    "camera": ("camera", "position", "measured"),
    "x": ("x",),
    "y": ("y",),
    "z": ("z",),
    "run": ("run",),
}


def read_interferometer_csv(path: str | Path) -> dict[str, Any]:
    """{"run": (N,) str, "interferometer": (N,), "camera": (N,) or (N, 3)} from a CSV
    (see the module docstring); InputError naming the file, row or column."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p.name}: file not found ({p})")
    try:
        text = p.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{p.name}: not a CSV text file (not UTF-8 at byte {exc.start})") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 2:
        raise InputError(f"{p.name}: needs a header row and at least 2 data rows")
    delim = max((",", ";", "\t"), key=lines[0].count) if any(d in lines[0] for d in ",;\t") else None
    rows = list(csv.reader(lines, delimiter=delim)) if delim else [ln.split() for ln in lines]
    header = [h.strip().lower() for h in rows[0]]
    col = {}
    for key, names in _ALIASES.items():
        for n in names:
            if n in header:
                col[key] = header.index(n)
                break
    if "interferometer" not in col:
        raise InputError(f"{p.name}: no 'interferometer' column (header: {', '.join(header)})")
    three = all(k in col for k in ("x", "y", "z"))
    if "camera" not in col and not three:
        raise InputError(
            f"{p.name}: needs a 'camera' column (1-D positions) or 'x', 'y', 'z' columns (header: {', '.join(header)})"
        )
    keys = ["x", "y", "z"] if "camera" not in col else ["camera"]
    vals, runs = [], []
    for i, row in enumerate(rows[1:], start=2):
        try:
            vals.append([float(row[col["interferometer"]])] + [float(row[col[k]]) for k in keys])
        except (ValueError, IndexError):
            raise InputError(
                f"{p.name}: row {i} is not numeric in the interferometer/camera columns: {','.join(row)[:80]}"
            ) from None
        runs.append(row[col["run"]].strip() if "run" in col and col["run"] < len(row) else "1")
    a = np.array(vals)
    if not np.all(np.isfinite(a)):
        raise InputError(f"{p.name}: NaN or infinite values")
    cam = a[:, 1] if keys == ["camera"] else a[:, 1:4]
    return {"run": np.array(runs), "interferometer": a[:, 0], "camera": cam, "file": p.name}


def _displacement(cam: np.ndarray, d_int: np.ndarray) -> np.ndarray:
    if cam.ndim == 1:
        return cam - cam[0]
    rel = cam - cam[0]
    centred = cam - cam.mean(0)
    direction = np.linalg.svd(centred, full_matrices=False)[2][0]
    d = rel @ direction
    return d if np.dot(d, d_int) >= 0 else -d


def scale_factor(
    interferometer, camera, run=None, *, accuracy: float = 5e-7, length: float | None = None, source: str = ""
) -> dict[str, Any]:
    """Scale factor by linear regression per run (module docstring).

    Parameters
    ----------
    interferometer : array_like, shape (N,)
        Reference displacements, mm.
    camera : array_like, shape (N,) or (N, 3)
        The camera system's displacements (or positions), mm.
    run : array_like, shape (N,), optional
        Run labels; None: one run.
    accuracy : float, default 5e-7
        The interferometer's relative accuracy (dimensionless), 0 <= accuracy < 1.
    length : float, optional
        mm, the length L the uncertainty is stated for (default the longest run's travel).
    source : str, default ""
        The data's file name, put in front of the messages about the data.

    Returns
    -------
    dict
        ``slope`` (mean over runs), ``scale_factor`` = 1 / slope, ``u_scale_factor``,
        ``runs`` [{run, slope, intercept, stderr, rms_residual, n}], ``repeatability``
        (std of the slopes, and in ppm), ``residuals`` {run: (n,) mm} and
        ``displacement`` {run: (n,) mm} (fig. 3.11), ``residual_std_per_position`` (when
        all runs have the same count), ``length`` L mm, ``u_cal``, ``u_p``, ``u_length``
        mm (eq. 3.22).
    """
    from scipy import stats

    if not (np.isfinite(accuracy) and 0 <= accuracy < 1):
        raise ParameterError(
            f"accuracy {accuracy!r}: the interferometer's relative accuracy must be a finite number from 0 to below 1"
        )
    if length is not None and not (np.isfinite(length) and length > 0):
        raise ParameterError(f"length {length!r} must be a positive number of mm")
    where = f"{source}: " if source else ""
    x_all = np.asarray(interferometer, np.float64).ravel()
    c_all = np.asarray(camera, np.float64)
    if c_all.ndim == 2 and c_all.shape[1] != 3 or c_all.shape[0] != x_all.size:
        raise InputError(f"{where}camera positions {c_all.shape} do not match {x_all.size} interferometer positions")
    labels = np.array(["1"] * x_all.size) if run is None else np.asarray(run).astype(str)
    order = list(dict.fromkeys(labels.tolist()))
    runs, residuals, displ = [], {}, {}
    for r in order:
        m = labels == r
        if m.sum() < 3:
            raise InputError(f"{where}run {r!r} has {int(m.sum())} position(s); a regression needs at least 3")
        d_int = x_all[m] - x_all[m][0]
        if np.ptp(d_int) <= 0:
            raise InputError(f"{where}run {r!r}: the interferometer positions do not change")
        d_cam = _displacement(c_all[m], d_int)
        fit = stats.linregress(d_int, d_cam)
        res = d_cam - (fit.slope * d_int + fit.intercept)
        runs.append(
            {
                "run": r,
                "slope": float(fit.slope),
                "intercept": float(fit.intercept),
                "stderr": float(fit.stderr),
                "rms_residual": float(np.sqrt(np.mean(res**2))),
                "n": int(m.sum()),
                "travel": float(np.ptp(d_int)),
            }
        )
        residuals[r], displ[r] = res, d_int
    slopes = np.array([r["slope"] for r in runs])
    slope = float(slopes.mean())
    L = float(max(r["travel"] for r in runs) if length is None else length)
    if len(runs) > 1:
        rep = float(slopes.std(ddof=1))
        u_slope = rep / np.sqrt(len(runs))
        u_p = rep * L
    else:
        rep = float("nan")
        u_slope = runs[0]["stderr"]
        u_p = u_slope * L
    u_cal = accuracy * L / np.sqrt(3.0)
    counts = {len(v) for v in residuals.values()}
    per_pos = np.std(np.array(list(residuals.values())), axis=0, ddof=1) if len(runs) > 1 and len(counts) == 1 else None
    return {
        "slope": slope,
        "u_slope": float(u_slope),
        "scale_factor": 1.0 / slope,
        "u_scale_factor": float(u_slope / slope**2),
        "runs": runs,
        "n_runs": len(runs),
        "repeatability": rep,
        "repeatability_ppm": rep * 1e6 if np.isfinite(rep) else None,
        "residuals": residuals,
        "displacement": displ,
        "residual_std_per_position": per_pos,
        "length": L,
        "u_cal": float(u_cal),
        "u_p": float(u_p),
        "u_length": float(np.hypot(u_cal, u_p)),
        "unit": "mm",
    }


def apply_scale(cal: dict[str, Any], factor: float) -> dict[str, Any]:
    """A copy of the calibration dict with its lengths multiplied by ``factor``: camera
    translations, T, E, the rectified P2/P1 translation column, Q's 1/baseline term, the
    board poses and the translation rows of ``parameter_covariance``."""
    import copy

    if not (np.isfinite(factor) and factor > 0):
        raise InputError(f"scale factor {factor!r} must be a positive number")
    out = copy.deepcopy(cal)
    for cam in out["cameras"]:
        cam.translation = cam.translation * factor
    for key in ("T", "E", "std_T"):
        if out.get(key) is not None:
            out[key] = np.asarray(out[key], np.float64) * factor
    for key in ("baseline", "baseline_std"):
        if out.get(key) is not None:
            out[key] = float(out[key]) * factor
    rect = out.get("rectification") or {}
    for key in ("P1", "P2"):
        if key in rect:
            rect[key] = np.array(rect[key], np.float64)
            rect[key][:, 3] *= factor
    if "Q" in rect:
        rect["Q"] = np.array(rect["Q"], np.float64)
        rect["Q"][3, :] /= factor  # the row holding -1/Tx and (cx - cx')/Tx
    views = out.get("views")
    if views and views.get("tvecs") is not None:
        views["tvecs"] = np.asarray(views["tvecs"], np.float64) * factor
    names, cov = out.get("parameter_names"), out.get("parameter_covariance")
    if names is not None and cov is not None:
        s = np.array([factor if n.split(".")[-1] in ("tx", "ty", "tz") else 1.0 for n in names])
        out["parameter_covariance"] = np.asarray(cov, np.float64) * np.outer(s, s)
    out["scale_factor"] = float(factor) * float(cal.get("scale_factor", 1.0))
    return out
