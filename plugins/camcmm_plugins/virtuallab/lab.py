"""A virtual measuring system to drive frame by frame: what simulated devices (cameras,
projector, stages; issue #9) sit on.

    lab = VirtualSystem.from_file("scene.yaml")
    lab.move(rotation_deg=[0, 0, 30])            # a turntable step: artefacts turn about the origin
    img = lab.frame("camera1", pattern)          # pattern (h, w) 0..1 at the projector's size, or None
    truth = lab.truth()                          # artefacts where they are now

Each camera's ray casting is done once per artefact pose and reused for every pattern;
noise streams are seeded by (scene seed, camera, frame counter), so a run is
reproducible. Lengths in mm, angles in degrees.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError

from . import capture, imaging, render
from .raycast import Box, Mesh
from .scene import Cylinder, Rectangle, Sphere
from .scene_file import LabScene, load_scene
from .workpieces import rotation_xyz


def move_primitive(p, R: np.ndarray, t: np.ndarray):
    """A copy of primitive ``p`` under x -> R x + t."""
    q = copy.copy(p)
    if isinstance(p, Sphere):
        q.center = R @ p.center + t
    elif isinstance(p, Cylinder):
        q.p0, q.p1 = R @ p.p0 + t, R @ p.p1 + t
    elif isinstance(p, Rectangle):
        q.center, q.axis, q.normal = R @ p.center + t, R @ p.axis, R @ p.normal
    elif isinstance(p, Box):
        q.center, q.axes = R @ p.center + t, p.axes @ R.T
    elif isinstance(p, Mesh):
        q = Mesh(p.vertices @ R.T + t, p.triangles, p.label, p.measured)
    else:
        raise TypeError(f"cannot move a {type(p).__name__}")
    return q


class VirtualSystem:
    """A scene with its cameras and projector, imaging on demand."""

    def __init__(self, scene: LabScene):
        self.scene = scene
        self._base = list(scene.primitives)
        self._base_truth = copy.deepcopy(scene.artefacts)
        self.R, self.t = np.eye(3), np.zeros(3)
        self._views: dict[str, render.View] = {}
        self.frames_taken = 0

    @classmethod
    def from_file(cls, path: str | Path) -> VirtualSystem:
        return cls(load_scene(path))

    @property
    def cameras(self) -> list[str]:
        return [c.name for c in self.scene.cameras]

    @property
    def projector_size(self) -> tuple[int, int] | None:
        """(width, height) px of the projector, None without one."""
        if self.scene.projector is None:
            return None
        w, h = self.scene.projector.model.image_size
        return (w, h)

    def move(self, rotation_deg=(0.0, 0.0, 0.0), translation=(0.0, 0.0, 0.0), relative: bool = False) -> None:
        """Place the artefacts by x -> R x + t (R = Rz Ry Rx of ``rotation_deg`` about the
        volume's axes through its centre) from where the scene file put them, or on top
        of the current pose with ``relative``."""
        R = rotation_xyz(rotation_deg)
        t = np.asarray(translation, float).reshape(3)
        if relative:
            R, t = R @ self.R, R @ self.t + t
        self.R, self.t = R, t
        self.scene.primitives = [move_primitive(p, R, t) for p in self._base]
        self.scene.artefacts = capture._transform(self._base_truth, R, t)
        self._views.clear()

    def _index(self, camera: str) -> int:
        for i, c in enumerate(self.scene.cameras):
            if c.name == camera:
                return i
        raise InputError(f"camera {camera!r}: the virtual system has {', '.join(self.cameras)}")

    def view(self, camera: str) -> render.View:
        if camera not in self._views:
            i = self._index(camera)
            proj = self.scene.projector.model if self.scene.projector is not None else None
            self._views[camera] = render.prepare(
                self.scene.primitives,
                self.scene.albedo,
                self.scene.cameras[i].model,
                proj,
                self.scene.lighting,
                self.scene.supersample,
                projector_lens=self.scene.projector.lens if self.scene.projector is not None else None,
            )
        return self._views[camera]

    def frame(
        self,
        camera: str,
        pattern: np.ndarray | None = None,
        lamp: bool = False,
        exposure: float | None = None,
        noise: bool = True,
    ) -> np.ndarray:
        """One image (uint8, or uint16 above 8 bits) of ``camera`` while the projector
        shows ``pattern`` (None: dark) and the diffuse lamp is ``lamp``; ``exposure``
        scales the sensor's."""
        i = self._index(camera)
        if pattern is not None and self.projector_size is not None:
            want = (self.projector_size[1], self.projector_size[0])
            if np.shape(pattern)[:2] != want:
                raise InputError(
                    f"pattern of {np.shape(pattern)[1]} x {np.shape(pattern)[0]} px; the projector "
                    f"shows {want[1]} x {want[0]}"
                )
        v = self.view(camera)
        dev = self.scene.cameras[i]
        L = render.radiance(v, pattern, self.scene.lighting, lamp)
        L = imaging.optics(L, v.depth, dev.model, dev.lens)
        sensor = self.scene.sensor
        if exposure is not None:
            sensor = copy.copy(sensor)
            sensor.exposure = float(exposure)
        rng = (
            np.random.default_rng(np.random.SeedSequence([self.scene.seed, i, self.frames_taken, 1])) if noise else None
        )
        self.frames_taken += 1
        return imaging.expose(L, sensor, rng)

    def set_stages(self, positions: dict[str, float], units: dict[str, str] | None = None) -> None:
        """Place the artefacts where stages at ``positions`` ({name: mm or deg}) carry them.
        The scene file's ``stages`` ({name: {type: linear|rotary, axis: [x, y, z],
        origin: [x, y, z]}}) says how; an undeclared stage in "deg" (``units``) is a
        turntable about the volume's z axis, one in mm a linear stage along x. Stages
        act in the order given (the last carries the others)."""
        decl = self.scene.stages
        R, t = np.eye(3), np.zeros(3)
        for name, pos in positions.items():
            d = decl.get(name, {})
            kind = d.get("type", "rotary" if (units or {}).get(name) == "deg" else "linear")
            axis = np.asarray(d.get("axis", [0, 0, 1] if kind == "rotary" else [1, 0, 0]), float)
            axis = axis / np.linalg.norm(axis)
            if kind == "rotary":
                o = np.asarray(d.get("origin", [0, 0, 0]), float)
                a = np.radians(float(pos))
                K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
                Rk = np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K  # Rodrigues
                R, t = Rk @ R, Rk @ (t - o) + o
            else:
                t = t + float(pos) * axis
        if not (np.allclose(R, self.R) and np.allclose(t, self.t)):
            self.R, self.t = R, t
            self.scene.primitives = [move_primitive(p, R, t) for p in self._base]
            self.scene.artefacts = capture._transform(self._base_truth, R, t)
            self._views.clear()

    def calibration(self, with_errors: bool = True) -> dict[str, Any]:
        """The calibration dict the system believes (``with_errors``) or the true one."""
        return capture.calibration(self.scene, with_errors)

    def truth(self) -> dict[str, Any]:
        tr = capture.truth(self.scene)
        tr["pose"] = {"rotation": self.R.tolist(), "translation": self.t.tolist()}
        return tr


_SYSTEMS: dict[tuple[str, float], VirtualSystem] = {}


def system_for(scene: str | Path) -> VirtualSystem:
    """One VirtualSystem per scene file (and its modification time), kept between calls:
    a simulated camera asks for frame after frame of the same scene."""
    p = Path(scene).resolve()
    try:
        key = (str(p), p.stat().st_mtime)
    except OSError:
        raise InputError(f"scene {scene}: file not found") from None
    if key not in _SYSTEMS:
        for k in [k for k in _SYSTEMS if k[0] == key[0]]:
            del _SYSTEMS[k]
        _SYSTEMS[key] = VirtualSystem.from_file(p)
    return _SYSTEMS[key]
