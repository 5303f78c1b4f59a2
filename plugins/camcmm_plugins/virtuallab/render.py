"""Render camera images of a scene lit by a projector (any pattern) or diffuse light.

Per camera the geometry is worked out once (``prepare``): every sub-pixel sample's ray
is cast into the scene; a surface point is lit by the projector when it lies inside the
projector's image, faces it, and the projector's own ray to it meets nothing first
(shadows); the point is projected into the projector with its distortion and the
bilinear weights of the four pattern pixels around it are kept. A frame (``radiance``)
is then only a gather from the pattern and a sum per pixel, so a whole fringe sequence
costs little more than its first frame.

Radiometry (relative units: 1.0 = the sensor's full well at the set exposure). A
Lambertian surface of albedo ρ reflects the same radiance to every camera:

    L = ρ [ ambient + diffuse max(n·l_d, 0) + projector P(u_p, v_p)^γ max(n·l_p, 0) (d_ref / d)² ]

P is the pattern value (0..1) at the point's projector pixel, γ the projector's response
(``gamma``; 1 = linear), l_p the unit vector to the projector centre at distance d,
d_ref the projector's distance to its target (``falloff``: inverse-square law), l_d the
diffuse lamp's direction. Normals are turned towards the camera (thin rectangles are
two-sided), so a sheet lit from behind stays dark. The sub-pixel samples of a pixel
are averaged (box filter over the pixel area: edges are anti-aliased).
Lengths in mm, images (h, w) in pixels.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from . import imaging, optics
from .raycast import cast, occluded

#: Rays cast per batch (bounds the memory of the intermediate (N, 3) arrays).
BATCH = 1 << 20
#: Shadow-ray tolerance (mm): a point is shadowed when the projector's ray meets
#: something this much before it (covers float32 mesh casting at ~1 m).
SHADOW_EPS = 1e-3


@dataclass
class Lighting:
    """Light levels (fractions of full scale for albedo 1 at normal incidence)."""

    projector: float = 0.8  # a white pattern at the reference distance
    ambient: float = 0.02
    diffuse: float = 0.6  # a distant diffuse lamp (frames that switch it on), no shadows
    diffuse_direction: tuple = (0.0, 0.0, 1.0)
    background: float = 0.0  # rays that hit nothing
    gamma: float = 1.0  # projector response: emitted = pattern ** gamma
    projector_blur: float = 0.0  # Gaussian sigma (projector px) of the projector's optics
    falloff: bool = True
    # a solid texture: f(points (N, 3) mm, normals (N, 3), primitive (N,)) -> albedo factor (N,)
    texture: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None
    # the lamp as a uniform hemisphere about diffuse_direction (a lighting enclosure, ch. 6.2):
    # irradiance (1 + n·l)/2 of an unoccluded Lambertian surface, so walls are lit too
    hemisphere: bool = False


@dataclass
class View:
    """One camera's geometry, ready to render frames.

    ``base`` (h, w): radiance that does not depend on the pattern (ambient, background),
    ``lamp`` (h, w) that of the diffuse lamp (added on frames that switch it on), both
    already averaged over sub-samples; ``pix`` (M,) the pixel index of each
    lit sub-sample, ``corner`` (M,) the flat index of its top-left pattern pixel and
    ``weights`` (4, M) its bilinear weights times ρ cosθ (d_ref/d)² / s²; ``depth`` (h, w)
    mean camera depth Z (mm) of the surface (NaN where nothing is hit), ``coverage``
    (h, w) the fraction of sub-samples on a surface, ``primitive`` (h, w) the primitive
    seen at the pixel centre's nearest sub-sample (-1: none), ``lit`` (h, w) the fraction
    of sub-samples lit by the projector."""

    shape: tuple[int, int]
    supersample: int
    base: np.ndarray
    lamp: np.ndarray
    pix: np.ndarray
    corner: np.ndarray
    weights: np.ndarray
    pattern_shape: tuple[int, int] | None
    depth: np.ndarray
    coverage: np.ndarray
    primitive: np.ndarray
    lit: np.ndarray
    extra: dict = field(default_factory=dict)


def _falloff_reference(projector) -> float:
    """Distance (mm) from the projector's centre to the point its optical axis aims at:
    the distance along the axis to the world origin (the measuring volume's centre)."""
    return float(abs(projector.translation[2])) or 1.0


def _batch(scene, albedo, camera, projector, light: Lighting, s: int, XY, r0: int, r1: int, plens=None) -> dict:
    """Geometry of the sub-pixel rows r0..r1 (see ``prepare``); per-pixel sums over the
    pixel rows they cover."""
    w, h = camera.image_size
    X, Y = XY
    d = optics.directions(camera, X[r0:r1], Y[r0:r1])
    C = optics.centre(camera)
    p0, p1 = r0 // s, r1 // s  # pixel rows of this batch
    npx = (p1 - p0) * w
    col = np.arange(w * s) // s
    pix_of = ((np.arange(r0, r1) // s - p0)[:, None] * w + col[None, :]).ravel()
    t, idx, nrm = cast(scene, C, d)
    hit = np.flatnonzero(idx >= 0)
    out = {
        "rows": (p0, p1),
        "prim": idx.reshape(r1 - r0, w * s)[(s // 2) :: s, (s // 2) :: s],
        "base": np.bincount(pix_of, minlength=npx) * light.background,
    }
    zero = np.zeros(npx)
    out.update(
        lamp=zero,
        depth=zero,
        hits=zero,
        lit=zero,
        pix=np.zeros(0, np.int32),
        corner=np.zeros(0, np.int32),
        weights=np.zeros((4, 0), np.float32),
        pblur=np.zeros(0, np.float32),
    )
    if not len(hit):
        return out
    dh = d[hit]
    Xw = C + t[hit, None] * dh
    n = nrm[hit]
    n[np.einsum("ij,ij->i", n, dh) > 0] *= -1  # face the camera
    rho = albedo[idx[hit]]
    if light.texture is not None:  # a material's texture, fixed on the part (AM artefacts, ch. 6.2)
        rho = rho * light.texture(Xw, n, idx[hit])
    p = pix_of[hit]
    ldir = np.asarray(light.diffuse_direction, float)
    ldir = ldir / np.linalg.norm(ldir)
    out["base"] = out["base"] + np.bincount(p, rho * light.ambient - light.background, minlength=npx)
    cos_d = 0.5 * (1.0 + n @ ldir) if light.hemisphere else np.clip(n @ ldir, 0, None)
    out["lamp"] = np.bincount(p, rho * light.diffuse * cos_d, minlength=npx)
    out["depth"] = np.bincount(p, Xw @ camera.rotation[2] + camera.translation[2], minlength=npx)
    out["hits"] = np.bincount(p, minlength=npx).astype(float)
    if projector is None or light.projector <= 0:
        return out
    P = optics.centre(projector)
    up, vp, Zp = optics.project(projector, Xw)
    pw, ph = projector.image_size
    L = P - Xw
    dist = np.sqrt(np.einsum("ij,ij->i", L, L))
    cos = np.einsum("ij,ij->i", n, L) / dist
    ok = np.flatnonzero((Zp > 0) & (up >= -0.5) & (up <= pw - 0.5) & (vp >= -0.5) & (vp <= ph - 0.5) & (cos > 0))
    if not len(ok):
        return out
    # shadows: nothing may meet the projector's ray towards the point before it does
    ok = ok[~occluded(scene, P, -L[ok] / dist[ok, None], dist[ok], idx[hit][ok], SHADOW_EPS)]
    g = rho[ok] * (light.projector / (s * s)) * cos[ok]
    if light.falloff:
        g = g * (_falloff_reference(projector) / dist[ok]) ** 2
    uc = np.clip(up[ok], 0, pw - 1)
    vc = np.clip(vp[ok], 0, ph - 1)
    u0 = np.minimum(np.floor(uc), pw - 2)
    v0 = np.minimum(np.floor(vc), ph - 2)
    fu, fv = uc - u0, vc - v0
    wts = np.empty((4, len(ok)), np.float32)
    gv = g * fv
    g -= gv  # g (1 - fv)
    wts[1] = g * fu
    wts[0] = g - wts[1]
    wts[3] = gv * fu
    wts[2] = gv - wts[3]
    out["weights"] = wts
    out["corner"] = (v0 * pw + u0).astype(np.int32)
    out["pix"] = (p[ok] + p0 * w).astype(np.int32)
    if plens is not None and plens.f_number and projector.pixel_pitch:
        f = projector.camera_matrix[0, 0] * projector.pixel_pitch
        sf = plens.focus_distance or _falloff_reference(projector)
        out["pblur"] = imaging.blur_diameter(Zp[ok], f, plens.f_number, sf, projector.pixel_pitch).astype(np.float32)
    out["lit"] = np.bincount(p[ok], minlength=npx).astype(float)
    return out


def prepare(
    scene: list,
    albedo,
    camera,
    projector=None,
    lighting: Lighting | None = None,
    supersample: int = 2,
    workers: int | None = None,
    projector_lens=None,
) -> View:
    """Cast the camera's sub-pixel rays (``camera``, ``projector``: CameraModel) and
    work out lighting geometry; ``albedo`` is one reflectance (0..1) per primitive.
    ``projector_lens`` (imaging.Lens with an f-number and the projector's pixel pitch)
    adds the projector's depth of field: each lit point sees the pattern blurred by the
    projector's blur circle at its depth (levels 0.5 px apart, as ``imaging.defocus``).
    Bands of image rows run on ``workers`` threads (default: the CPU count; numpy
    releases the GIL in its array loops)."""
    light = lighting or Lighting()
    w, h = camera.image_size
    s = int(supersample)
    if w <= 0 or h <= 0:
        raise ValueError(f"camera {camera.name!r}: image size {camera.image_size} is not set")
    if projector is not None and min(projector.image_size) < 2:
        raise ValueError(f"projector {projector.name!r}: image size {projector.image_size} is below 2 x 2 px")
    albedo = np.broadcast_to(np.asarray(albedo, float), (len(scene),))
    XY = optics.grid_normalised(camera, s)  # (h*s, w*s) each
    rows = max(s, (BATCH // (w * s)) // s * s)  # whole pixel rows per band
    bands = [(a, min(a + rows, h * s)) for a in range(0, h * s, rows)]
    n_workers = workers or min(os.cpu_count() or 1, 8)
    job = lambda r: _batch(scene, albedo, camera, projector, light, s, XY, r[0], r[1], plens=projector_lens)
    if n_workers > 1 and len(bands) > 1:
        with ThreadPoolExecutor(n_workers) as pool:
            parts = list(pool.map(job, bands))
    else:
        parts = [job(b) for b in bands]
    cat = lambda key: np.concatenate([q[key] for q in parts])
    hits = cat("hits")
    extra = {}
    pix, corner, weights = cat("pix"), cat("corner"), np.hstack([q["weights"] for q in parts])
    pblur = np.concatenate([q.get("pblur", np.zeros(0, np.float32)) for q in parts])
    if len(pblur) and len(pblur) == len(pix) and pblur.max() > 1e-3:
        # samples sorted by blur level: each frame then gathers contiguous runs
        n = int(np.ceil(pblur.max() / imaging.LEVEL_STEP))
        k = np.minimum((pblur / imaging.LEVEL_STEP).astype(np.int64), n - 1)
        order = np.argsort(k, kind="stable")
        k = k[order]
        pix, corner, weights = pix[order], corner[order], weights[:, order]
        a = (pblur[order] / imaging.LEVEL_STEP - k).astype(np.float32)
        bounds = np.searchsorted(k, np.arange(n + 1))
        extra["pblur"] = {
            "levels": np.arange(n + 1) * imaging.LEVEL_STEP,
            "psf": projector_lens.psf,
            "groups": [(slice(bounds[i], bounds[i + 1]), a[bounds[i] : bounds[i + 1]]) for i in range(n)],
        }
    with np.errstate(invalid="ignore"):
        depth = np.where(hits > 0, cat("depth") / np.maximum(hits, 1), np.nan)
    return View(
        (h, w),
        s,
        (cat("base") / (s * s)).reshape(h, w),
        (cat("lamp") / (s * s)).reshape(h, w),
        pix,
        corner,
        weights,
        (projector.image_size[1], projector.image_size[0]) if projector is not None else None,
        depth.reshape(h, w),
        (hits / (s * s)).reshape(h, w),
        np.vstack([q["prim"] for q in parts]),
        (cat("lit") / (s * s)).reshape(h, w),
        extra,
    )


def emitted(pattern: np.ndarray, lighting: Lighting) -> np.ndarray:
    """The light the projector sends for a pattern (h, w) of values 0..1 (or uint8/16,
    scaled by their range): response ``gamma``, then the projector optics' blur."""
    p = np.asarray(pattern)
    if p.ndim == 3:
        p = p.mean(axis=2)  # a colour pattern shown as grey
    if np.issubdtype(p.dtype, np.integer):
        p = p / float(np.iinfo(p.dtype).max)
    p = np.clip(p.astype(np.float64), 0.0, 1.0)
    if lighting.gamma != 1.0:
        p = p**lighting.gamma
    if lighting.projector_blur > 0:
        import cv2

        p = cv2.GaussianBlur(p, (0, 0), lighting.projector_blur, borderType=cv2.BORDER_REPLICATE)
    return p


def _gather(f: np.ndarray, c: np.ndarray, wts: np.ndarray, pw: int) -> np.ndarray:
    """Bilinear samples of the flat pattern ``f`` at corners ``c`` with weights (4, M)."""
    return f[c] * wts[0] + f[c + 1] * wts[1] + f[c + pw] * wts[2] + f[c + pw + 1] * wts[3]


def radiance(
    view: View, pattern: np.ndarray | None, lighting: Lighting | None = None, lamp: bool = False
) -> np.ndarray:
    """Radiance image (h, w) of one frame; ``pattern`` None: projector dark; ``lamp``:
    the diffuse lamp on."""
    h, w = view.shape
    img = view.base.ravel().copy()
    if lamp:
        img += view.lamp.ravel()
    if pattern is not None and view.pattern_shape is not None and len(view.pix):
        e = emitted(pattern, lighting or Lighting())
        if e.shape != view.pattern_shape:
            raise ValueError(
                f"pattern of {e.shape[1]} x {e.shape[0]} px; the projector shows "
                f"{view.pattern_shape[1]} x {view.pattern_shape[0]}"
            )
        pw = view.pattern_shape[1]
        pb = view.extra.get("pblur")
        if pb is None:
            val = _gather(e.ravel(), view.corner, view.weights, pw)
        else:  # projector defocus: two blur levels per point
            blurred = [imaging.defocus(e, float(c), pb["psf"]).ravel() for c in pb["levels"]]
            val = np.empty(len(view.pix))
            for i, (sel, a) in enumerate(pb["groups"]):
                if len(a):
                    c, wts = view.corner[sel], view.weights[:, sel]
                    val[sel] = (1 - a) * _gather(blurred[i], c, wts, pw) + a * _gather(blurred[i + 1], c, wts, pw)
        img += np.bincount(view.pix, val, minlength=h * w)
    return img.reshape(h, w)


def pixel_truth(scene: list, camera, projector=None) -> dict[str, np.ndarray]:
    """The truth at every pixel centre (one ray each): ``points`` (h, w, 3) world surface
    point (mm, NaN where nothing is hit), ``primitive`` (h, w) index (-1: none),
    ``normals`` (h, w, 3) facing the camera, and with a projector ``projector_uv``
    (h, w, 2) its exact projector coordinates (px, with its distortion) and ``lit``
    (h, w) whether the projector lights the point (inside its image, facing it, no
    shadow). What a decoder and a triangulation should recover, pixel by pixel."""
    w, h = camera.image_size
    d = optics.directions(camera, *optics.grid_normalised(camera, 1))
    C = optics.centre(camera)
    t, idx, nrm = cast(scene, C, d)
    hit = idx >= 0
    X = np.full((h * w, 3), np.nan)
    X[hit] = C + t[hit, None] * d[hit]
    nrm[np.einsum("ij,ij->i", nrm, d) > 0] *= -1
    out = {"points": X.reshape(h, w, 3), "primitive": idx.reshape(h, w), "normals": nrm.reshape(h, w, 3)}
    if projector is not None:
        uv = np.full((h * w, 2), np.nan)
        lit = np.zeros(h * w, bool)
        k = np.flatnonzero(hit)
        up, vp, Zp = optics.project(projector, X[k])
        uv[k, 0], uv[k, 1] = up, vp
        pw, ph = projector.image_size
        L = optics.centre(projector) - X[k]
        dist = np.sqrt(np.einsum("ij,ij->i", L, L))
        ok = (
            (Zp > 0)
            & (up >= -0.5)
            & (up <= pw - 0.5)
            & (vp >= -0.5)
            & (vp <= ph - 0.5)
            & (np.einsum("ij,ij->i", nrm[k], L) > 0)
        )
        j = np.flatnonzero(ok)
        blocked = occluded(scene, optics.centre(projector), -L[j] / dist[j, None], dist[j], idx[k[j]], SHADOW_EPS)
        lit[k[j[~blocked]]] = True
        out["projector_uv"] = uv.reshape(h, w, 2)
        out["lit"] = lit.reshape(h, w)
    return out
