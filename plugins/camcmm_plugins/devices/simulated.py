"""Simulated cameras: frames rendered from the simulated scene (stage positions, the
pattern on the projector, the speckle laser) by an injectable renderer.

``renderer`` is a callable ``f(**state) -> ndarray`` or the id of a plugin (reached with
``get_algorithm``) that takes the same keywords and returns ``{"image": ndarray}`` —
the virtual lab's image renderer once it exists. The state passed is:

``camera`` (name), ``camera_model`` (a CameraModel or None), ``size`` (w, h) px,
``exposure_ms``, ``gain_db``, ``pattern`` (the projector's current array or None),
``pattern_index``, ``stage_positions`` ({stage name: position in mm or deg}),
``stage_units`` ({name: "mm"|"deg"}), ``speckle`` (bool), ``frame`` (counter), ``seed``.

Without a renderer :func:`synthetic_frame` draws a deterministic test scene;
:class:`CaptureReplay` replays frames the virtual lab rendered (``virtuallab.capture``).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from camcmm.api import get_algorithm

from .camera import Camera
from .simulator import SimulatorProcess
from .zaber import ZaberStage


def synthetic_frame(
    size: Sequence[int] = (640, 480),
    exposure_ms: float = 10.0,
    gain_db: float = 0.0,
    pattern: np.ndarray | None = None,
    stage_positions: dict[str, float] | None = None,
    stage_units: dict[str, str] | None = None,
    speckle: bool = False,
    frame: int = 0,
    seed: int = 0,
    px_per_mm: float = 10.0,
    noise: float = 2.0,
    **_: Any,
) -> np.ndarray:
    """A uint8 (H, W) frame: a 16-px checkerboard moved ``px_per_mm`` px per mm of every
    linear stage along x and turned by every rotary stage's angle about the image
    centre, lit by the projector pattern (stretched over the frame) and the speckle
    texture; brightness ~ exposure x gain (10 ms, 0 dB: grey level ~ 200 on white)."""
    w, h = int(size[0]), int(size[1])
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    shift, angle = 0.0, 0.0
    for name, pos in (stage_positions or {}).items():
        if (stage_units or {}).get(name, "mm") == "deg":
            angle += np.deg2rad(pos)
        else:
            shift += pos * px_per_mm
    cx, cy = (w - 1) / 2.0, (h - 1) / 2.0
    c, s = np.cos(angle), np.sin(angle)
    x = c * (u - cx) + s * (v - cy) - shift
    y = -s * (u - cx) + c * (v - cy)
    albedo = 0.35 + 0.65 * ((np.floor(x / 16.0) + np.floor(y / 16.0)) % 2)
    light: np.ndarray = np.ones((h, w))
    if pattern is not None:
        import cv2

        p = np.asarray(pattern, dtype=np.float64)
        if p.ndim == 3:
            p = p.mean(axis=2)
        top = 65535.0 if pattern.dtype == np.uint16 else 255.0 if pattern.dtype.kind in "ui" else 1.0
        light = 0.05 + 0.95 * cv2.resize(p / top, (w, h), interpolation=cv2.INTER_LINEAR)
    if speckle:
        rng = np.random.default_rng(seed + 7919)
        tex = rng.random((h // 4 + 1, w // 4 + 1))
        xi = np.clip(((x + cx) / 4).astype(int), 0, tex.shape[1] - 1)
        yi = np.clip(((y + cy) / 4).astype(int), 0, tex.shape[0] - 1)
        light = light * (0.5 + tex[yi, xi])
    scale = 200.0 * float(exposure_ms) / 10.0 * 10 ** (float(gain_db) / 20.0)
    img = albedo * light * scale
    if noise:
        img += np.random.default_rng((seed, frame)).normal(0.0, noise, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


class SimulatedCamera(Camera):
    """A camera that renders its frames. ``projector`` (a PatternProjector), ``stages``
    (their ``position`` events are followed, so rendering never talks to a stage) and
    ``speckle`` (a SpeckleProjector) make up the scene; ``camera_model`` is handed to the
    renderer (needed by the virtual lab's)."""

    trigger_modes = ("software", "free-run", "hardware")

    def __init__(
        self,
        name: str = "sim-camera",
        size: Sequence[int] = (640, 480),
        renderer: Callable[..., np.ndarray] | str | None = None,
        projector: Any = None,
        stages: Sequence[Any] = (),
        speckle: Any = None,
        camera_model: Any = None,
        seed: int = 0,
        px_per_mm: float = 10.0,
        **settings: Any,
    ):
        self.size = (int(size[0]), int(size[1]))
        self.renderer, self.projector, self.speckle = renderer, projector, speckle
        self.camera_model, self.seed, self.px_per_mm = camera_model, int(seed), float(px_per_mm)
        self.positions: dict[str, float] = {}
        self.units: dict[str, str] = {}
        super().__init__(name, "simulated", **settings)
        self.sensor_size = self.size
        for st in stages:
            self.follow(st)

    def follow(self, stage: Any) -> None:
        """Take ``stage``'s positions from its ``position`` events."""
        self.units[stage.name] = getattr(stage, "unit", "mm")
        self.positions.setdefault(stage.name, 0.0)
        stage.events.on("position", lambda pos, n=stage.name: self.positions.__setitem__(n, float(pos)))

    def _render(self) -> Callable[..., Any]:
        if not self.renderer:
            return synthetic_frame
        if isinstance(self.renderer, str):
            plugin = get_algorithm(self.renderer)
            return lambda **state: plugin(**state)["image"]
        return self.renderer

    def _grab(self, timeout: float) -> tuple[np.ndarray, dict[str, Any]]:
        s = self._settings
        pattern = self.projector.current() if self.projector is not None else None
        index = self.projector.index if self.projector is not None else None
        state = {
            "camera": self.name,
            "camera_model": self.camera_model,
            "size": self.size,
            "exposure_ms": s["exposure_ms"],
            "gain_db": s["gain_db"],
            "pattern": pattern,
            "pattern_index": index,
            "stage_positions": dict(self.positions),
            "stage_units": dict(self.units),
            "speckle": bool(self.speckle is not None and self.speckle.is_on),
            "frame": self._count + 1,
            "seed": self.seed,
        }
        if not self.renderer:
            state["px_per_mm"] = self.px_per_mm
        img = np.asarray(self._render()(**state))
        extra = {"simulated": True, "stage_positions": state["stage_positions"]}
        if index is not None:
            extra["pattern_index"] = index
        return img, extra


class CaptureReplay:
    """A renderer for :class:`SimulatedCamera` that replays a capture rendered beforehand
    by a plugin — by default the virtual lab's ``virtuallab.capture`` (scene file in,
    ``files`` {camera: [frame paths in sequence order]} out). A simulated camera whose
    name is one of the plugin's cameras (or maps to one through ``cameras``) gets, for
    the pattern on display, that camera's frame with the same index. The capture runs
    on the first frame asked for, or at :meth:`prepare`.
    """

    def __init__(
        self,
        scene: Any,
        out: str,
        algorithm: str | Callable[..., dict] = "virtuallab.capture",
        cameras: dict[str, str] | None = None,
    ):
        self.scene, self.out, self.algorithm = scene, str(out), algorithm
        self.cameras = dict(cameras or {})
        self.files: dict[str, list[str]] | None = None
        self._cache: dict[tuple[str, int], np.ndarray] = {}
        self._lock = threading.Lock()  # two cameras ask at once; render once

    def prepare(self) -> dict[str, list[str]]:
        with self._lock:
            return self._prepare()

    def _prepare(self) -> dict[str, list[str]]:
        if self.files is None:
            fn = get_algorithm(self.algorithm) if isinstance(self.algorithm, str) else self.algorithm
            self.files = {str(k): [str(p) for p in v] for k, v in fn(scene=self.scene, out=self.out)["files"].items()}
        return self.files

    def __call__(self, camera: str = "", pattern_index: int | None = None, **_: Any) -> np.ndarray:
        from camcmm.api import InputError, read

        files = self.prepare()
        name = self.cameras.get(camera, camera)
        if name not in files:
            raise InputError(f"capture replay: no rendered camera {name!r}; rendered: {', '.join(files)}")
        k = 0 if pattern_index is None else int(pattern_index)
        if not 0 <= k < len(files[name]):
            raise InputError(f"capture replay: camera {name!r} has {len(files[name])} frames, asked for {k}")
        if (name, k) not in self._cache:
            frame = read(files[name][k])
            if not hasattr(frame, "data"):
                raise InputError(f"capture replay: {files[name][k]} holds a {type(frame).__name__}, not an image")
            self._cache[(name, k)] = frame.data
        return self._cache[(name, k)]


class SimulatedZaberStage(ZaberStage):
    """The real Zaber code against the stage simulator, started as a child process on a
    pseudo-terminal when the stage first connects (``rotary`` for a turntable). The
    process lives until :meth:`close_simulator` (or the app's exit)."""

    def __init__(
        self,
        name: str = "",
        rotary: bool = False,
        speed: float = 100.0,
        travel_mm: float = 150.0,
        interferometer: bool = True,
        resolution: float = 0.001,
        **kw: Any,
    ):
        self.rotary, self.sim_speed, self.travel_mm = bool(rotary), float(speed), float(travel_mm)
        self.with_interferometer = bool(interferometer)
        self.simulator: SimulatorProcess | None = None
        super().__init__(
            "",
            name=name or ("sim-rotary" if rotary else "sim-linear"),
            resolution=resolution,
            unit="deg" if rotary else "mm",
            **kw,
        )

    def _open(self) -> None:
        if self.simulator is None or self.simulator.proc is None or self.simulator.proc.poll() is not None:
            args = [
                "--speed",
                str(self.sim_speed),
                "--resolution",
                str(self.resolution),
                "--travel",
                str(self.travel_mm),
            ] + (["--rotary"] if self.rotary else [])
            if self.simulator is None:
                self.simulator = SimulatorProcess(*args, interferometer=self.with_interferometer)
            else:
                self.simulator.start()
            self.port = self.simulator.stage_port
        super()._open()

    @property
    def interferometer_port(self) -> str:
        return self.simulator.interferometer_port if self.simulator is not None else ""

    def release(self) -> None:
        """Disconnect and stop the simulator process this stage started."""
        self.close_simulator()

    def close_simulator(self) -> None:
        self.disconnect()
        if self.simulator is not None:
            self.simulator.kill()
