"""The chapter-4 turntable photo series: a DSLR-like camera, an artefact on a turntable
and a laser speckle projector mounted on the turntable above the artefact (thesis
ch. 4.2, fig. 4.1-4.2; ch. 6.2).

The projector turns with the artefact, so the speckle is fixed on the object; in the
turntable's frame (world: origin on the axis at the artefact, +z up the axis) only the
camera moves: turning the table by θ is the camera at azimuth −θ. Each view is rendered
with the virtual lab's renderer (``render.prepare`` / ``render.radiance``: exact ray
casting of the artefact's primitives, the projector's pattern gathered where it lights
them, shadows, Lambertian shading), then the DSLR's lens (``dslr``), the subjective
speckle of the camera (``speckle.subjective_*``) and the sensor (``imaging.expose``).

Speckle off: the diffuse lamp above the table lights the artefact; the polished carbide
and the holders have no texture, only shading and sensor noise. Speckle on: the laser
only (the room's ambient light stays).

Output (``write_series``): ``image000.png`` … and ``truth.json`` with each view's K, R, t
(world → camera, mm), the artefact's spheres, the speckle and camera figures.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import CameraModel, Image, InputError, check_calibration, check_disk, write, write_calibration

from . import am_artefacts, artefacts, imaging, materials, render
from .dslr import Dslr
from .speckle import (
    MIN_GRAIN,
    objective_grain,
    speckle,
    subjective_contrast,
    subjective_field,
    subjective_grain,
)

#: The chapter-4 artefacts and the four AM artefacts of ch. 6.2 (``am_artefacts``).
ARTEFACTS = ("sphere", "ball_plate", "sphere_with_scale", *am_artefacts.NAMES)
#: Thesis ch. 4.3: the ball plate's calibrated lengths (mm) and its 5 mm spheres.
BALL_PLATE_LENGTHS = (5.942, 7.956, 9.957)
#: Largest projector pattern side (px): its FFT must stay a few hundred MB.
MAX_PATTERN = 4096
#: Albedo of the holders, plates and posts; the carbide's own.
ALBEDO_HOLDER, ALBEDO_CARBIDE = 0.35, 0.55


@dataclass
class SeriesSpec:
    """What to render; lengths in mm, angles in degrees."""

    artefact: str = "sphere"
    n_images: int = 30
    arc_deg: float = 180.0
    elevation_deg: float = 30.0
    downscale: float = 1.0
    f_number: float = 8.0
    magnification: float = 0.0  # 0: the artefact fills ~70 % of the image height
    speckle: bool = True
    wavelength_nm: float = 532.0
    distance_mm: float = 80.0  # projector (diffuser) to the artefact
    diffuser_mm: float = 0.25  # illuminated spot on the diffuser
    grain_mm: float = 0.0  # 0: λ z / D
    speckle_mean: float = 0.3
    supersample: int = 2
    depth_of_field: bool = True
    seed: int = 0
    extra: dict = field(default_factory=dict)
    material: str = ""  # AM artefacts: materials.NAMES (default ti6al4v)
    sizes: dict = field(default_factory=dict)  # AM artefacts: overrides of am_artefacts.DEFAULTS


def build_artefact(name: str, material: str = "", sizes: dict | None = None) -> tuple[list, np.ndarray, dict[str, Any]]:
    """(primitives, albedo per primitive, truth) of a catalogue artefact at the origin."""
    if name in am_artefacts.NAMES:
        from .raycast import Mesh

        try:
            V, F, cls, used = am_artefacts.build(name, sizes)
            mat = materials.get(material or "ti6al4v")
        except (ValueError, TypeError) as exc:
            raise InputError(str(exc)) from None
        truth = {
            "kind": name,
            "spheres": [],
            "sizes": used,
            "material": mat.name,
            "face_classes": list(am_artefacts.FACE_CLASSES),
            "class_areas": am_artefacts.class_areas(V, F, cls),
            "bounds": [V.min(axis=0).tolist(), V.max(axis=0).tolist()],
        }
        return [Mesh(V, F, name)], np.array([mat.albedo]), truth
    if name == "sphere":
        prims, truth = artefacts.sphere((0, 0, 0), 10.0)
    elif name == "ball_plate":
        prims, truth = artefacts.ball_plate((0, 0, 0), BALL_PLATE_LENGTHS, 5.0)
    elif name == "sphere_with_scale":
        prims, truth = artefacts.sphere_with_scale((0, 0, 0), 10.0, 5.0)
    else:
        raise InputError(f"artefact {name!r}: use one of {', '.join(ARTEFACTS)}")
    albedo = np.array([ALBEDO_CARBIDE if p.measured else ALBEDO_HOLDER for p in prims])
    return prims, albedo, truth


def _extent(truth: dict[str, Any]) -> tuple[np.ndarray, float]:
    """The point on the table's axis at the spheres' mean height (the camera's aim: it
    must lie on the axis, or the artefact would wander through the images) and the
    radius (mm) of a ball about it holding all spheres."""
    if not truth["spheres"]:  # a mesh artefact: the ball about its box's centre on the axis
        lo, hi = (np.asarray(b, float) for b in truth["bounds"])
        mid = np.array([0.0, 0.0, (lo[2] + hi[2]) / 2])
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        return mid, float(np.max(np.linalg.norm(corners - mid, axis=1)))
    c = np.array([s["center"] for s in truth["spheres"]], float)
    r = np.array([s["diameter"] / 2 for s in truth["spheres"]])
    mid = np.array([0.0, 0.0, c[:, 2].mean()])
    return mid, float(np.max(np.linalg.norm(c - mid, axis=1) + r))


class TurntableSeries:
    """The scene, the camera and the projector of one series; ``image(k)`` renders view k."""

    def __init__(self, spec: SeriesSpec):
        self.spec = spec
        if not 1 <= spec.n_images <= 10000:
            raise InputError(f"n_images {spec.n_images}: use 1 .. 10000")
        self.prims, self.albedo, self.artefact_truth = build_artefact(spec.artefact, spec.material, spec.sizes)
        self.target, radius = _extent(self.artefact_truth)
        mag = spec.magnification or float(np.clip(0.7 * 15.6 / (2.6 * radius), 0.05, 2.0))
        try:
            self.dslr = Dslr(spec.downscale, spec.f_number, mag, spec.wavelength_nm, depth_of_field=spec.depth_of_field)
        except ValueError as exc:
            raise InputError(str(exc)) from None
        self.angles = np.linspace(0.0, spec.arc_deg, spec.n_images, endpoint=False)
        self.lighting = render.Lighting(projector=3.0, ambient=0.03, diffuse=1.2, diffuse_direction=(0.0, 0.0, 1.0))
        self.grain = spec.grain_mm or objective_grain(spec.wavelength_nm, spec.distance_mm, spec.diffuser_mm)
        self.projector, self.pattern = self._projector(radius)
        if spec.artefact in am_artefacts.NAMES:
            mat = materials.get(self.artefact_truth["material"])
            self.lighting.texture = lambda p, n, _i: mat.texture(p, n, spec.seed)
            self.lighting.hemisphere = True  # ch. 6.2's lighting enclosure: diffuse from above and around
            self.lighting.diffuse = 0.9
            # translucency: the projected light spreads under the surface (σ in projector px)
            n_px = self.projector.image_size[0]
            self.lighting.projector_blur = mat.subsurface_mm * n_px / (3.0 * radius)
        sg = subjective_grain(spec.wavelength_nm, spec.f_number, mag)
        self.subjective = {
            "grain_mm": sg,
            "grain_px": sg / self.dslr.pitch,
            "contrast": subjective_contrast(sg, self.dslr.pitch),
        }

    def _projector(self, radius: float) -> tuple[CameraModel, np.ndarray]:
        """The speckle projector above the artefact on the table's axis, its pattern
        holding grains of ``grain`` mm at the target (angular grain λ/D)."""
        z = self.spec.distance_mm
        if not z > 2 * radius:
            raise InputError(
                f"speckle distance {z} mm: the projector must stand above the artefact (> {2 * radius:.1f} mm)"
            )
        fov = 3.0 * radius  # the projector's field at the target
        n = int(np.clip(np.ceil(fov / self.grain * 1.25 * MIN_GRAIN), 64, MAX_PATTERN))
        grain_px = self.grain * n / fov
        if grain_px < MIN_GRAIN:
            raise InputError(
                f"speckle grain {self.grain * 1000:.1f} µm over a {fov:.1f} mm field needs more than "
                f"{MAX_PATTERN} projector px; give a larger grain (smaller diffuser spot D or longer z)"
            )
        P = self.target + np.array([0.0, 0.0, z])
        proj = self.dslr.camera(P, self.target, "speckle projector", up=(0.0, 1.0, 0.0))
        K = np.array([[n * z / fov, 0, (n - 1) / 2], [0, n * z / fov, (n - 1) / 2], [0, 0, 1.0]])
        proj = CameraModel(K, np.zeros(5), proj.rotation, proj.translation, (n, n), None, "speckle projector")
        return proj, speckle((n, n), grain_px, self.spec.seed, self.spec.speckle_mean)

    def camera(self, k: int) -> CameraModel:
        """View k's camera: the table turned by angles[k] = the camera at azimuth −angle."""
        return self.camera_at(float(self.angles[k]), f"view {k:03d}")

    def camera_at(self, angle_deg: float, name: str = "dslr") -> CameraModel:
        phi, e = np.radians(-angle_deg), np.radians(self.spec.elevation_deg)
        u = self.dslr.object_distance
        pos = self.target + u * np.array([np.cos(e) * np.cos(phi), np.cos(e) * np.sin(phi), np.sin(e)])
        return self.dslr.camera(pos, self.target, name)

    def render_at(self, angle_deg: float, speckle_on: bool, noise_key: tuple[int, ...]) -> np.ndarray:
        """The uint8 image of the table at ``angle_deg`` (speckle laser on/off)."""
        cam = self.camera_at(angle_deg)
        view = render.prepare(
            self.prims,
            self.albedo,
            cam,
            self.projector if speckle_on else None,
            self.lighting,
            self.spec.supersample,
        )
        L = render.radiance(view, self.pattern if speckle_on else None, self.lighting, lamp=not speckle_on)
        if not speckle_on:
            img = self.dslr.blur(L, view.depth)[0]
        else:
            img, dark = self.dslr.blur([L, render.radiance(view, None, self.lighting, lamp=False)], view.depth)
            # subjective speckle forms in the image plane: it modulates the laser's light only
            # ... and depends on the viewpoint (the angle), not on the frame
            key = np.random.SeedSequence([self.spec.seed, 7, round(angle_deg * 1000) % (1 << 32)])
            s = subjective_field(
                view.shape, self.subjective["grain_px"], self.subjective["contrast"], int(key.generate_state(1)[0])
            )
            img = dark + (img - dark) * s
        rng = np.random.default_rng(np.random.SeedSequence([self.spec.seed, *noise_key]))
        return imaging.expose(img, imaging.Sensor(bits=8, full_well=20000.0, read_noise=8.0), rng)

    def image(self, k: int, speckle_on: bool | None = None) -> np.ndarray:
        on = self.spec.speckle if speckle_on is None else bool(speckle_on)
        return self.render_at(float(self.angles[k]), on, (self.spec.seed, k, int(on)))

    def view_truth(self, k: int, name: str) -> dict[str, Any]:
        cam = self.camera(k)
        return {
            "image": name,
            "angle_deg": float(self.angles[k]),
            "K": cam.camera_matrix.tolist(),
            "R": cam.rotation.tolist(),
            "t": cam.translation.tolist(),
            "centre": (-cam.rotation.T @ cam.translation).tolist(),
        }

    def truth(self, names: list[str]) -> dict[str, Any]:
        s = self.spec
        return {
            "unit": "mm",
            "frame": "turntable: origin on the axis at the artefact, +z up the axis; x_cam = R x + t",
            "artefact": s.artefact,
            "spheres": self.artefact_truth["spheres"],
            "artefact_truth": self.artefact_truth,
            "target": self.target.tolist(),
            "camera": {**self.dslr.describe(), "elevation_deg": s.elevation_deg},
            "turntable": {"n_images": s.n_images, "arc_deg": s.arc_deg},
            "speckle": {
                "on": s.speckle,
                "wavelength_nm": s.wavelength_nm,
                "distance_mm": s.distance_mm,
                "diffuser_mm": s.diffuser_mm,
                "objective_grain_mm": self.grain,
                "objective_grain_px": self.grain * self.dslr.magnification / self.dslr.pitch,
                "subjective_grain_um": self.subjective["grain_mm"] * 1000,
                "subjective_grain_px": self.subjective["grain_px"],
                "subjective_contrast": self.subjective["contrast"],
                "projector_size": list(self.projector.image_size),
                "seed": s.seed,
            },
            "views": [self.view_truth(k, n) for k, n in enumerate(names)],
        }


def write_series(spec: SeriesSpec, out: str | Path, progress=None) -> dict[str, Any]:
    """Render the series into ``out`` (PNG per view + truth.json); returns the outputs
    of ``virtuallab.turntable-series``."""
    series = TurntableSeries(spec)
    d = Path(out)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"out {out}: cannot create the folder ({exc.strerror})") from None
    w, h = series.dslr.size
    check_disk(f"{spec.n_images} images of {w} x {h} px", float(spec.n_images) * w * h, d)
    for old in d.glob("image*.png"):
        old.unlink()  # a shorter series must not leave stale images
    names, files, warnings = [], [], []
    gpx = series.grain * series.dslr.magnification / series.dslr.pitch
    if spec.speckle and gpx < 6:
        warnings.append(
            f"speckle grain {gpx:.1f} px in the images: SIFT follows few grains below ~6 px; "
            "give a smaller diffuser spot, a longer distance or less down-scaling"
        )
    for k in range(spec.n_images):
        if progress:
            progress(k / spec.n_images, f"rendering view {k + 1}/{spec.n_images}")
        img = series.image(k)
        name = f"image{k:03d}.png"
        write(Image(img, name=name), d / name)
        names.append(name)
        files.append(str(d / name))
        if np.mean(img >= 255) > 0.005:
            warnings.append(f"{name}: {100 * np.mean(img >= 255):.1f} % of the pixels saturate")
    truth = series.truth(names)
    truth["warnings"] = warnings
    (d / "truth.json").write_text(json.dumps(truth, indent=1), encoding="utf-8")
    cam = series.camera(0)
    cal = {"cameras": [cam], "source": "camcmm virtual lab: the DSLR's true intrinsics (turntable series)"}
    write_calibration(d / "calibration.yaml", check_calibration(cal, "turntable calibration"))
    if progress:
        progress(1.0, "written")
    return {
        "out": str(d),
        "files": files,
        "truth": str(d / "truth.json"),
        "calibration": str(d / "calibration.yaml"),
        "speckle": truth["speckle"],
        "warnings": warnings,
    }


class TurntableRenderer:
    """Renderer for ``devices.camera.simulated`` (``renderer=TurntableRenderer(spec)``): the
    frame of a turntable sequence from the rotary stages' angles (deg) and the speckle
    relay's state, so ``devices.sequence.turntable`` with a simulated rotary stage, this
    camera and ``devices.speckle.relay`` acquires the same series ``write_series`` writes."""

    def __init__(self, spec: SeriesSpec):
        self.series = TurntableSeries(spec)

    def __call__(self, size=None, stage_positions=None, stage_units=None, speckle=False, frame=0, seed=0, **_: Any):
        if size is not None and tuple(int(x) for x in size) != self.series.dslr.size:
            want = self.series.dslr.size
            raise InputError(
                f"turntable renderer: the camera asks for {size[0]} x {size[1]} px, "
                f"the DSLR renders {want[0]} x {want[1]}"
            )
        units = stage_units or {}
        angle = sum(float(p) for n, p in (stage_positions or {}).items() if units.get(n) == "deg")
        return self.series.render_at(angle, bool(speckle), (int(seed), int(frame), int(bool(speckle))))
