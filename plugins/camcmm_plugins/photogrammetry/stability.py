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

from collections.abc import Sequence
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
#: SIFT runs on tiles of at most this many pixels (memory ~215 bytes a pixel, see _features).
TILE_PIXELS = 1_000_000


def _gray(img: Any, name: str) -> np.ndarray:
    """An 8-bit grey image of ``img`` (Image, array (h, w) or (h, w, c)); an 8-bit image
    is kept as it is (no float copy: 8 bytes a pixel of a large frame), others are
    stretched over 0..255."""
    a = np.asarray(img.data if isinstance(img, Image) else img)
    if a.ndim == 3:
        a = a[..., :3].mean(axis=2, dtype=np.float32) if a.dtype != np.uint8 else _bgr_grey(a)
    if a.ndim != 2 or min(a.shape) < 16:
        raise InputError(f"{name}: not a 2-D image of at least 16 x 16 px (shape {a.shape})")
    if a.dtype == np.uint8:
        return a
    a = a.astype(np.float32)
    if not np.isfinite(a).all():
        raise InputError(f"{name}: the image holds non-finite values")
    lo, hi = float(a.min()), float(a.max())
    return np.rint((a - lo) / ((hi - lo) or 1.0) * 255).astype(np.uint8)


def _bgr_grey(a: np.ndarray) -> np.ndarray:
    import cv2

    return cv2.cvtColor(np.ascontiguousarray(a[..., :3]), cv2.COLOR_BGR2GRAY)


#: Image files the series may hold (camcmm.api.read's image formats).
IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


def _checked_paths(paths) -> list[Path]:
    """The series' paths, each an image file by its extension and present; checked for
    the whole series before the first file is decoded."""
    paths = [Path(p) for p in paths]
    for p in paths:
        if p.suffix.lower() not in IMAGE_EXTS:
            raise InputError(f"{p}: not an image file; give {', '.join(IMAGE_EXTS)}")
        if not p.is_file():
            raise InputError(f"{p}: {'a folder, not an image file' if p.is_dir() else 'file not found'}")
    return paths


def _load(p: Path) -> np.ndarray:
    """One file through camcmm's one image reader (its pixel cap refuses a decompression
    bomb from the header), as 8-bit grey."""
    img = read(p)
    if not isinstance(img, Image):  # the extension was checked: an image it is
        raise InputError(f"{p}: not an image")
    return _gray(img, str(p))


class ImageSeries(Sequence):
    """The series' files, each read when :func:`stability` reaches it and not kept: a
    long series of large frames never sits in memory at once."""

    def __init__(self, paths):
        self.paths = _checked_paths(paths)

    def __len__(self) -> int:
        return len(self.paths)

    def __getitem__(self, i):  # type: ignore[override]
        return _load(self.paths[i])

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.paths]


def load_images(paths) -> tuple[list[np.ndarray], list[str]]:
    """Read image files as 8-bit grey through camcmm's one image reader; InputError naming
    a file that is missing, not an image or unreadable (all checked before any decode)."""
    series = ImageSeries(paths)
    return [series[i] for i in range(len(series))], series.names


def _tiles(h: int, w: int) -> list[tuple[int, int, int, int]]:
    """(y0, y1, x0, x1) of a grid of tiles of at most :data:`TILE_PIXELS` covering (h, w)."""
    ny = nx = 1
    while (h / ny) * (w / nx) > TILE_PIXELS:
        if h / ny >= w / nx:
            ny += 1
        else:
            nx += 1
    ys = np.linspace(0, h, ny + 1).round().astype(int)
    xs = np.linspace(0, w, nx + 1).round().astype(int)
    return [(ys[j], ys[j + 1], xs[i], xs[i + 1]) for j in range(ny) for i in range(nx)]


def _features(img: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """SIFT keypoints (K, 2) px and descriptors of ``img``, detected tile by tile.

    OpenCV's SIFT doubles the image first and keeps six blurred copies of each octave:
    about 215 bytes a pixel (an 81 Mpx frame took 19 GB). Tiles of at most
    :data:`TILE_PIXELS` bound that to ~250 MB whatever the frame; each keeps its share of
    :data:`MAX_FEATURES` (the strongest), which spreads the features over the frame.
    An image of one grey value has no features: SIFT is not run on it."""
    import cv2

    if int(img.max()) == int(img.min()):
        return np.zeros((0, 2)), None
    tiles = _tiles(*img.shape)
    sift = cv2.SIFT_create(nfeatures=-(-MAX_FEATURES // len(tiles)))  # type: ignore[attr-defined]  # not in stubs
    pts, descs = [], []
    for y0, y1, x0, x1 in tiles:
        kp, desc = sift.detectAndCompute(np.ascontiguousarray(img[y0:y1, x0:x1]), None)
        if desc is None or not kp:
            continue
        pts.append(np.array([k.pt for k in kp], float).reshape(-1, 2) + (x0, y0))
        descs.append(desc)
    if not pts:
        return np.zeros((0, 2)), None
    return np.vstack(pts), np.vstack(descs)


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
    if names is None:
        names = [getattr(images[i], "name", None) or f"image {i}" for i in range(len(images))]
    names = list(names)
    if len(images) < 2:
        raise InputError(f"speckle stability needs at least 2 images, got {len(images)}: {', '.join(names) or 'none'}")
    # one image at a time (images may be an ImageSeries that reads each file when asked)
    first = _gray(images[0], names[0])
    shape = first.shape
    p0, d0 = _features(first)
    del first
    warnings: list[str] = []
    if len(p0) < MIN_MATCHES:
        raise InputError(f"{names[0]}: only {len(p0)} SIFT features; no texture to follow (speckle off?)")
    mean: list[float | None] = [0.0]
    std: list[float | None] = [0.0]
    count = [len(p0)]
    for i in range(1, len(images)):
        if progress:
            progress(i / len(images), f"matching {names[i]}")
        g = _gray(images[i], names[i])
        if g.shape != shape:
            raise InputError(
                f"{names[i]}: {g.shape[1]} x {g.shape[0]} px, but {names[0]} is {shape[1]} x {shape[0]} px"
            )
        p1, d1 = _features(g)
        del g
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
