"""Laser speckle stability test (thesis ch. 4.2): how far a projected speckle pattern
moves in the images of a series taken over time with nothing moved on purpose.

Method (as the thesis): SIFT features (OpenCV) of every image are matched to those of
the first; a feature's radial motion is the length of its displacement (px); per image
the mean and the standard deviation of the radial motions of its matched features.
The thesis watched a series over one hour: the mean motion was ≈ 3 px, from the
camera's mount (a DSLR's mirror and shutter shake it; all features move together), and
the standard deviation stayed below 1 px (the speckle's own motion on the object).

Mismatches: Lowe's ratio test (0.75) and a mutual (cross-checked) best match, then a
robust cut on the displacement vectors: a match is kept when its displacement lies
within max(5 · 1.4826 · MAD, 2 px) of the median displacement. No homography or RANSAC
model: a model would absorb (and so hide) part of the motion the test is there to
measure, while the cut on the spread of the vectors only drops matches far off the
common motion (wrong grains, hundreds of px off).

Verdict: "pass" when every image's mean motion is at most ``limit`` px and its
standard deviation at most ``std_limit`` px. The defaults are the thesis's figures:
3 px (what its camera mount moved, with which it measured to 8 µm) and 1 px (the
pattern's own motion it accepted as stable).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Image, InputError, checked_path, read

#: Lowe's ratio test threshold.
RATIO = 0.75
#: Fewer kept matches than this leave an image's motion undetermined.
MIN_MATCHES = 10
#: SIFT features per image (the strongest); enough for a stable mean, bounded time.
MAX_FEATURES = 2000


def _gray(img: Any, name: str) -> np.ndarray:
    """An 8-bit grey image of ``img`` (Image, array (h, w) or (h, w, c))."""
    a = np.asarray(img.data if isinstance(img, Image) else img)
    if a.ndim == 3:
        a = a[..., :3].mean(axis=2)
    if a.ndim != 2 or min(a.shape) < 16:
        raise InputError(f"{name}: not a 2-D image of at least 16 x 16 px (shape {a.shape})")
    a = a.astype(np.float64)
    if not np.isfinite(a).all():
        raise InputError(f"{name}: the image holds non-finite values")
    lo, hi = float(a.min()), float(a.max())
    if np.asarray(img.data if isinstance(img, Image) else img).dtype == np.uint8:
        return np.asarray(a, np.uint8)
    return np.rint((a - lo) / ((hi - lo) or 1.0) * 255).astype(np.uint8)


#: Image files the series may hold (camcmm.api.read's image formats).
IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


def load_images(paths) -> tuple[list[np.ndarray], list[str]]:
    """Read image files as 8-bit grey through camcmm's one image reader (its pixel cap
    refuses a decompression bomb from the header); InputError naming a file that is
    missing, not an image or unreadable. The extensions are checked for the whole series
    before the first file is decoded."""
    import cv2

    paths = [Path(p) for p in paths]
    for p in paths:
        if p.suffix.lower() not in IMAGE_EXTS:
            raise InputError(f"{p}: not an image file; give {', '.join(IMAGE_EXTS)}")
        if not p.is_file():
            raise InputError(f"{p}: {'a folder, not an image file' if p.is_dir() else 'file not found'}")
    out, names = [], []
    for p in paths:
        img = read(p)
        if not isinstance(img, Image):  # the extension was checked: an image it is
            raise InputError(f"{p}: not an image")
        a = np.asarray(img.data)
        if a.ndim == 3:
            a = cv2.cvtColor(a[..., :3], cv2.COLOR_BGR2GRAY) if a.dtype == np.uint8 else a[..., :3].mean(axis=2)
        out.append(_gray(a, str(p)))
        names.append(p.name)
    return out, names


def _features(sift, img: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    kp, desc = sift.detectAndCompute(img, None)
    return np.array([k.pt for k in kp], float).reshape(-1, 2), desc


def _match(d0: np.ndarray, d1: np.ndarray) -> np.ndarray:
    """Index pairs (M, 2) of ratio-tested, mutual best matches of descriptors d0 -> d1."""
    import cv2

    if d0 is None or d1 is None or len(d0) < 2 or len(d1) < 2:
        return np.zeros((0, 2), int)
    bf = cv2.BFMatcher(cv2.NORM_L2)
    fwd = bf.knnMatch(d0, d1, k=2)
    back = {m.queryIdx: m.trainIdx for m in bf.match(d1, d0)}
    pairs = [(m.queryIdx, m.trainIdx) for m, n in (p for p in fwd if len(p) == 2) if m.distance < RATIO * n.distance]
    return np.array([(q, t) for q, t in pairs if back.get(t) == q], int).reshape(-1, 2)


def _robust(disp: np.ndarray) -> np.ndarray:
    """Mask of displacement vectors (M, 2) near the median one (see the module text)."""
    if len(disp) == 0:
        return np.zeros(0, bool)
    med = np.median(disp, axis=0)
    dev = np.linalg.norm(disp - med, axis=1)
    mad = 1.4826 * np.median(dev)
    return dev <= max(5.0 * mad, 2.0)


def stability(images, names=None, limit: float = 3.0, std_limit: float = 1.0, progress=None) -> dict[str, Any]:
    """Motion of the features of ``images`` (list of (h, w) arrays or Image, one size)
    relative to the first image.

    Returns ``mean_motion_px`` and ``std_px_per_image`` (per image, 0 for the first;
    None where fewer than MIN_MATCHES matches survive), ``std_px`` (the largest per-image
    standard deviation), ``mean_motion_std_px`` (standard deviation of the per-image means
    over the series), ``n_features`` (kept matches per image; the first image's own
    feature count), ``verdict``, ``reasons``, ``limit_px``, ``std_limit_px``, ``warnings``.
    """
    import cv2

    names = list(names or [getattr(im, "name", f"image {i}") for i, im in enumerate(images)])
    if len(images) < 2:
        raise InputError(f"speckle stability needs at least 2 images, got {len(images)}: {', '.join(names) or 'none'}")
    grays = [_gray(im, n) for im, n in zip(images, names)]
    for g, n in zip(grays[1:], names[1:]):
        if g.shape != grays[0].shape:
            raise InputError(
                f"{n}: {g.shape[1]} x {g.shape[0]} px, but {names[0]} is {grays[0].shape[1]} x {grays[0].shape[0]} px"
            )
    sift = cv2.SIFT_create(nfeatures=MAX_FEATURES)  # type: ignore[attr-defined]  # not in cv2's stubs
    p0, d0 = _features(sift, grays[0])
    warnings: list[str] = []
    if len(p0) < MIN_MATCHES:
        raise InputError(f"{names[0]}: only {len(p0)} SIFT features; no texture to follow (speckle off?)")
    mean: list[float | None] = [0.0]
    std: list[float | None] = [0.0]
    count = [len(p0)]
    for i in range(1, len(grays)):
        if progress:
            progress(i / len(grays), f"matching {names[i]}")
        p1, d1 = _features(sift, grays[i])
        m = _match(d0, d1) if d0 is not None and d1 is not None else np.zeros((0, 2), dtype=int)
        disp = p1[m[:, 1]] - p0[m[:, 0]] if len(m) else np.zeros((0, 2))
        disp = disp[_robust(disp)]
        count.append(len(disp))
        if len(disp) < MIN_MATCHES:
            warnings.append(f"{names[i]}: only {len(disp)} features matched to {names[0]}; its motion is unknown")
            mean.append(None)
            std.append(None)
            continue
        r = np.linalg.norm(disp, axis=1)
        mean.append(float(r.mean()))
        std.append(float(r.std(ddof=1)))
    known = [(n, mv, s) for n, mv, s in zip(names, mean, std) if mv is not None and s is not None]
    reasons = [f"{n}: mean motion {mv:.2f} px > {limit:g} px" for n, mv, _ in known if mv > limit]
    reasons += [f"{n}: motion spread {s:.2f} px > {std_limit:g} px" for n, _, s in known if s > std_limit]
    reasons += [f"{n}: motion unknown (too few matches)" for n, mv in zip(names, mean) if mv is None]
    means = np.array([mv for _, mv, _ in known])
    return {
        "images": names,
        "mean_motion_px": mean,
        "std_px_per_image": std,
        "std_px": float(max(s for _, _, s in known)),
        "mean_motion_std_px": float(means.std(ddof=1)) if len(means) > 1 else 0.0,
        "max_mean_motion_px": float(means.max()),
        "n_features": count,
        "verdict": "fail" if reasons else "pass",
        "reasons": reasons,
        "limit_px": float(limit),
        "std_limit_px": float(std_limit),
        "method": "SIFT (OpenCV), ratio 0.75 + mutual best match, 5-MAD cut on the displacement vectors",
        "warnings": warnings,
    }


#: What ``--plot`` may write: the formats of matplotlib's Agg backend camcmm documents.
PLOT_EXTS = (".png", ".pdf", ".svg")


def plot_target(path: str | Path) -> Path:
    """The file ``--plot`` names, checked before any work: a file name (not a folder,
    not a pipe or device) ending in one of :data:`PLOT_EXTS`, in a folder that exists.
    One-line InputError naming the value otherwise."""
    p = checked_path(path, "--plot")
    give = "give a file name ending in " + ", ".join(PLOT_EXTS)
    if p.is_dir():
        raise InputError(f"--plot {path}: a folder; {give}")
    if p.exists() and not p.is_file():
        raise InputError(f"--plot {path}: not a regular file; {give}")
    if p.suffix.lower() not in PLOT_EXTS:
        raise InputError(f"--plot {path}: {p.suffix or 'no extension'} is not a plot format; {give}")
    if not p.parent.is_dir():
        raise InputError(f"--plot {path}: the folder {p.parent} does not exist")
    return p


def plot(result: dict[str, Any], path: str | Path) -> str:
    """A PNG (or PDF, SVG) of mean ± standard deviation of the radial motion against
    image index, written to ``path`` (:func:`plot_target`); the path written."""
    path = plot_target(path)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    idx = [i for i, m in enumerate(result["mean_motion_px"]) if m is not None]
    m = np.array([result["mean_motion_px"][i] for i in idx])
    s = np.array([result["std_px_per_image"][i] for i in idx])
    fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
    ax.errorbar(idx, m, yerr=s, fmt="o-", ms=3, capsize=2, label="mean radial motion ± std")
    ax.axhline(result["limit_px"], color="tab:red", ls="--", lw=1, label=f"limit {result['limit_px']:g} px")
    ax.set_xlabel("image index")
    ax.set_ylabel("motion relative to the first image / px")
    ax.set_title(f"Speckle stability: {result['verdict']}")
    ax.legend(loc="upper left")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    try:
        fig.savefig(str(path))
    except OSError as exc:
        raise InputError(f"--plot {path}: cannot write ({exc.strerror})") from None
    finally:
        plt.close(fig)
    return str(path)


def run(ctx, images, limit: float = 3.0, std_limit: float = 1.0) -> dict[str, Any]:
    """Entry of ``speckle.stability`` (images: the host's Image list)."""
    res = stability(images, None, limit, std_limit, ctx.progress)
    for w in res["warnings"]:
        ctx.warn(w)
    return {"result": res, "verdict": res["verdict"]}
