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

from dataclasses import dataclass, field

import numpy as np

from . import optics
from .raycast import cast

#: Rays cast per batch (bounds the memory of the intermediate (N, 3) arrays).
BATCH = 1 << 20
#: Shadow-ray tolerance (mm): a point is shadowed when the projector's ray meets
#: something this much before it (covers float32 mesh casting at ~1 m).
SHADOW_EPS = 1e-3


@dataclass
class Lighting:
    """Light levels (fractions of full scale for albedo 1 at normal incidence)."""

    projector: float = 0.8          # a white pattern at the reference distance
    ambient: float = 0.02
    diffuse: float = 0.6            # a distant diffuse lamp (frames that switch it on), no shadows
    diffuse_direction: tuple = (0.0, 0.0, 1.0)
    background: float = 0.0         # rays that hit nothing
    gamma: float = 1.0              # projector response: emitted = pattern ** gamma
    projector_blur: float = 0.0     # Gaussian sigma (projector px) of the projector's optics
    falloff: bool = True


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


def prepare(scene: list, albedo, camera, projector=None, lighting: Lighting | None = None,
            supersample: int = 2) -> View:
    """Cast the camera's sub-pixel rays (``camera``, ``projector``: CameraModel) and
    work out lighting geometry; ``albedo`` is one reflectance (0..1) per primitive."""
    light = lighting or Lighting()
    w, h = camera.image_size
    s = int(supersample)
    if w <= 0 or h <= 0:
        raise ValueError(f"camera {camera.name!r}: image size {camera.image_size} is not set")
    albedo = np.broadcast_to(np.asarray(albedo, float), (len(scene),))
    dirs = optics.grid_rays(camera, s)                     # (h*s*w*s, 3), row-major sub-pixel grid
    C = optics.centre(camera)
    n_sub = len(dirs)
    # sub-sample -> pixel index, for the grid laid out as (h, s, w, s)
    row = np.arange(h * s) // s
    col = np.arange(w * s) // s
    pix_of = (row[:, None] * w + col[None, :]).ravel()
    base_sub = np.full(n_sub, light.background)
    lamp_sub = np.zeros(n_sub)
    depth_sum = np.zeros(h * w)
    hits = np.zeros(h * w)
    litc = np.zeros(h * w)
    prim_sub = np.full(n_sub, -1, np.int64)
    pix_l, corner_l, wts_l = [], [], []
    d_ref = _falloff_reference(projector) if projector is not None else 1.0
    ldir = np.asarray(light.diffuse_direction, float)
    ldir = ldir / np.linalg.norm(ldir)
    for a in range(0, n_sub, BATCH):
        d = dirs[a:a + BATCH]
        t, idx, nrm = cast(scene, C, d)
        hit = np.flatnonzero(idx >= 0)
        prim_sub[a + hit] = idx[hit]
        if not len(hit):
            continue
        X = C + t[hit, None] * d[hit]
        n = nrm[hit]
        flip = np.einsum("ij,ij->i", n, d[hit]) > 0
        n[flip] *= -1                                       # face the camera
        rho = albedo[idx[hit]]
        base_sub[a + hit] = rho * light.ambient
        lamp_sub[a + hit] = rho * light.diffuse * np.clip(n @ ldir, 0, None)
        p = pix_of[a + hit]
        Zc = X @ camera.rotation[2] + camera.translation[2]
        depth_sum += np.bincount(p, Zc, minlength=h * w)
        hits += np.bincount(p, minlength=h * w)
        if projector is None or light.projector <= 0:
            continue
        P = optics.centre(projector)
        up, vp, Zp = optics.project(projector, X)
        pw, ph = projector.image_size
        inside = (Zp > 0) & (up >= -0.5) & (up <= pw - 0.5) & (vp >= -0.5) & (vp <= ph - 0.5)
        L = P - X
        dist = np.linalg.norm(L, axis=1)
        cos = np.einsum("ij,ij->i", n, L) / dist
        ok = np.flatnonzero(inside & (cos > 0))
        if not len(ok):
            continue
        # shadows: the projector's own ray towards the point must reach it first
        ray = -L[ok] / dist[ok, None]
        tp, _ = cast(scene, P, ray, want_normals=False)
        ok = ok[tp >= dist[ok] - SHADOW_EPS]
        g = rho[ok] * light.projector * cos[ok]
        if light.falloff:
            g = g * (d_ref / dist[ok]) ** 2
        uc = np.clip(up[ok], 0, pw - 1)
        vc = np.clip(vp[ok], 0, ph - 1)
        u0 = np.minimum(np.floor(uc), pw - 2).astype(np.int64) if pw > 1 else np.zeros(len(ok), np.int64)
        v0 = np.minimum(np.floor(vc), ph - 2).astype(np.int64) if ph > 1 else np.zeros(len(ok), np.int64)
        fu, fv = uc - u0, vc - v0
        g = g / (s * s)
        wts_l.append(np.stack([g * (1 - fu) * (1 - fv), g * fu * (1 - fv), g * (1 - fu) * fv, g * fu * fv]))
        corner_l.append(v0 * pw + u0)
        pix_l.append(p[ok])
        litc += np.bincount(p[ok], minlength=h * w)
    base = np.bincount(pix_of, base_sub, minlength=h * w) / (s * s)
    lamp = np.bincount(pix_of, lamp_sub, minlength=h * w) / (s * s)
    with np.errstate(invalid="ignore"):
        depth = np.where(hits > 0, depth_sum / np.maximum(hits, 1), np.nan)
    prim = prim_sub.reshape(h, s, w, s)[:, s // 2, :, s // 2]
    cat = (lambda xs, dt: np.concatenate(xs).astype(dt) if xs else np.zeros(0, dt))
    return View((h, w), s, base.reshape(h, w), lamp.reshape(h, w), cat(pix_l, np.int64), cat(corner_l, np.int64),
                np.hstack(wts_l) if wts_l else np.zeros((4, 0)),
                (projector.image_size[1], projector.image_size[0]) if projector is not None else None,
                depth.reshape(h, w), (hits / (s * s)).reshape(h, w), prim, (litc / (s * s)).reshape(h, w))


def emitted(pattern: np.ndarray, lighting: Lighting) -> np.ndarray:
    """The light the projector sends for a pattern (h, w) of values 0..1 (or uint8/16,
    scaled by their range): response ``gamma``, then the projector optics' blur."""
    p = np.asarray(pattern)
    if p.ndim == 3:
        p = p.mean(axis=2)                               # a colour pattern shown as grey
    if np.issubdtype(p.dtype, np.integer):
        p = p / float(np.iinfo(p.dtype).max)
    p = np.clip(p.astype(np.float64), 0.0, 1.0)
    if lighting.gamma != 1.0:
        p = p ** lighting.gamma
    if lighting.projector_blur > 0:
        import cv2

        p = cv2.GaussianBlur(p, (0, 0), lighting.projector_blur, borderType=cv2.BORDER_REPLICATE)
    return p


def radiance(view: View, pattern: np.ndarray | None, lighting: Lighting | None = None,
             lamp: bool = False) -> np.ndarray:
    """Radiance image (h, w) of one frame; ``pattern`` None: projector dark; ``lamp``:
    the diffuse lamp on."""
    h, w = view.shape
    img = view.base.ravel().copy()
    if lamp:
        img += view.lamp.ravel()
    if pattern is not None and view.pattern_shape is not None and len(view.pix):
        e = emitted(pattern, lighting or Lighting())
        if e.shape != view.pattern_shape:
            raise ValueError(f"pattern of {e.shape[1]} x {e.shape[0]} px; the projector shows "
                             f"{view.pattern_shape[1]} x {view.pattern_shape[0]}")
        f = e.ravel()
        pw = view.pattern_shape[1]
        c = view.corner
        val = (f[c] * view.weights[0] + f[c + 1] * view.weights[1]
               + f[c + pw] * view.weights[2] + f[c + pw + 1] * view.weights[3])
        img += np.bincount(view.pix, val, minlength=h * w)
    return img.reshape(h, w)
