"""Pattern sequences: the YAML file that declares what a projector shows, frame by frame.

    load_sequence(source) -> Sequence        # a path to a YAML/JSON file or a mapping

Schema (lengths in projector pixels; a pixel's centre is at its integer index)
------------------------------------------------------------------------------
::

    projector: {width: 912, height: 1140}   # required, px
                          # optional calibration_scale: [sx, sy], see below
    bit_depth: 8          # 8 (uint8 patterns) or 16 (uint16); default 8
    gamma: 1.0            # projector gamma pre-compensated in the sinusoids (value**(1/gamma)); default 1
    levels: [0.0, 1.0]    # black and white drive level as a fraction of full scale; default [0, 1]
    frames:               # in projection (= capture) order; each entry gives one or more frames
      - white             # one full-on frame (shorthand for {type: white})
      - black             # one full-off frame
      - {type: phase, direction: vertical, steps: 4, period: 32, offset: 0,
         shifts_deg: [0, 90, 180, 270], mean: 0.5, amplitude: 0.5}
      - {type: gray, direction: vertical, period: 32, bits: 6, offset: 0,
         inverse: interleaved, bit_order: msb_first}
      - {type: binary, direction: horizontal, period: 16, inverse: none}
      - {type: ignore, count: 1}   # captured frames that decoding skips (e.g. a focus frame)

``direction``: ``vertical`` fringes vary along the projector column u (they encode u),
``horizontal`` fringes vary along the row v (they encode v). ``span`` below is the
projector width (vertical) or height (horizontal).

``phase`` (N-step phase shifting, thesis eqs. 5.1-5.2): ``steps`` N >= 3 frames; frame k
shows ``I_k(x) = lo + (hi - lo) * (mean + amplitude * cos(phi(x) + delta_k))`` with the
projector phase ``phi(x) = 2 pi (x - offset) / period`` (eq. 5.1 with an origin ``offset``
in px) and ``delta_k`` from ``shifts_deg`` (default ``360 k / N``). Several ``phase``
entries with the same direction and different periods make a multi-frequency sequence
(heterodyne unwrapping, see :mod:`.unwrap`).

``gray`` / ``binary`` (fringe-order codes, thesis ch. 5.2.3, fig. 5.2): the code word of
projector coordinate x is ``c = floor((x - offset) / period)``; ``bits`` defaults to the
fewest that number every stripe of the span; the frames show the bits of gray(c)
(``gray``) or c (``binary``), most significant first unless ``bit_order: lsb_first``.
``inverse``: ``none`` (bits thresholded by the white/black mean or the phase frames'
mean), ``interleaved`` (bit, inverse, bit, inverse ... as OpenCV's GrayCodePattern) or
``after`` (all bits, then all inverses).

``projector.calibration_scale`` (default [1, 1]): pattern pixels to the projector
calibration's pixels, ``x_cal = s (x + 1/2) - 1/2``. A DLP with a diamond mirror array
(e.g. TI LightCrafter 4500: 912 x 1140 patterns of half-height rows) is calibrated in
square pixels, i.e. ``[1, 0.5]``. Decoded coordinates are pattern pixels; triangulation
applies the scale.

Limits (checked on reading, before anything is allocated): projector sides up to
``MAX_SIDE`` px, at most ``MAX_FRAMES`` frames in all, one frame within the memory limit
(``camcmm.api.check_budget``).

A phase group and a code group of the same direction are decoded together: the code gives
the fringe order (eq. 5.4). A code whose period is half the phase period (one more bit)
is the complementary Gray code: its boundaries fall mid-fringe and no order errors remain.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, check_budget, check_count, read_yaml

DIRECTIONS = ("vertical", "horizontal")
INVERSE_MODES = ("none", "interleaved", "after")
KINDS = ("white", "black", "phase", "gray", "binary", "ignore")
#: Largest projector side (px) a sequence may declare (an 8K projector is 7680 px wide).
MAX_SIDE = 16384
#: Most frames a sequence may hold (a long multi-frequency sequence has ~100).
MAX_FRAMES = 4096


@dataclass(frozen=True)
class PhaseGroup:
    """N phase-shifted sinusoids of one period; ``frames`` are their indices in the sequence."""

    direction: str
    steps: int
    period: float
    offset: float
    shifts: tuple[float, ...]  # delta_k, rad
    mean: float
    amplitude: float
    frames: tuple[int, ...]


@dataclass(frozen=True)
class CodeGroup:
    """Gray or binary code bits; ``frames[b]`` shows bit b (MSB first), ``inverse_frames[b]`` its inverse."""

    kind: str  # "gray" | "binary"
    direction: str
    bits: int
    period: float
    offset: float
    frames: tuple[int, ...]
    inverse_frames: tuple[int, ...] = ()

    @property
    def n_words(self) -> int:
        return 1 << self.bits


@dataclass(frozen=True)
class Frame:
    """One projected frame: ``kind`` in KINDS, its group (index into the phase or code
    groups), the step or bit index and whether it is an inverse."""

    kind: str
    direction: str = ""
    group: int = -1
    index: int = 0
    inverse: bool = False

    @property
    def name(self) -> str:
        if self.kind in ("white", "black", "ignore"):
            return self.kind
        d = self.direction[0]
        if self.kind == "phase":
            return f"phase_{d}{self.group}_step{self.index}"
        return f"{self.kind}_{d}{self.group}_bit{self.index}{'_inv' if self.inverse else ''}"


@dataclass
class Sequence:
    """A parsed sequence; ``frames`` in capture order, groups in declaration order."""

    width: int
    height: int
    bit_depth: int = 8
    gamma: float = 1.0
    levels: tuple[float, float] = (0.0, 1.0)
    frames: list[Frame] = field(default_factory=list)
    phase_groups: list[PhaseGroup] = field(default_factory=list)
    code_groups: list[CodeGroup] = field(default_factory=list)
    name: str = "sequence"
    calibration_scale: tuple[float, float] = (1.0, 1.0)

    def to_calibration_px(self, direction: str, x):
        """Pattern coordinate (px) along ``direction`` -> projector calibration px."""
        s = self.calibration_scale[0 if direction == "vertical" else 1]
        return x if s == 1.0 else s * (x + 0.5) - 0.5

    @property
    def n_frames(self) -> int:
        return len(self.frames)

    @property
    def projector_size(self) -> tuple[int, int]:
        """(width, height) px."""
        return self.width, self.height

    @property
    def max_value(self) -> int:
        return (1 << self.bit_depth) - 1

    @property
    def directions(self) -> list[str]:
        """Directions with at least one phase group, vertical first."""
        return [d for d in DIRECTIONS if any(g.direction == d for g in self.phase_groups)]

    def span(self, direction: str) -> int:
        return self.width if direction == "vertical" else self.height

    def indices(self, kind: str) -> list[int]:
        return [i for i, f in enumerate(self.frames) if f.kind == kind]

    def describe(self) -> list[dict[str, Any]]:
        """One JSON-able dict per frame (index, name, kind, direction, group, index, inverse)."""
        return [
            {
                "frame": i,
                "name": f.name,
                "kind": f.kind,
                "direction": f.direction,
                "group": f.group,
                "index": f.index,
                "inverse": f.inverse,
            }
            for i, f in enumerate(self.frames)
        ]


def _num(
    entry: Mapping[str, Any], key: str, default: Any, where: str, *, lo: float | None = None, integer: bool = False
) -> Any:
    value = entry.get(key, default)
    if value is None:
        raise InputError(f"{where}: '{key}' is required")
    try:
        v = int(value) if integer else float(value)
    except (TypeError, ValueError):
        raise InputError(f"{where}: '{key}' must be a number, got {value!r}") from None
    if integer and float(value) != v:
        raise InputError(f"{where}: '{key}' must be an integer, got {value!r}")
    if not math.isfinite(v) or (lo is not None and v < lo):
        raise InputError(f"{where}: '{key}' = {value!r} must be >= {lo}")
    return v


def _choice(entry: Mapping[str, Any], key: str, choices: tuple[str, ...], default: str | None, where: str) -> str:
    value = entry.get(key, default)
    if value not in choices:
        raise InputError(f"{where}: '{key}' must be one of {', '.join(choices)}, got {value!r}")
    return str(value)


def load_sequence(source: Any) -> Sequence:
    """Parse a sequence from a YAML/JSON path or a mapping (schema in the module docstring).

    Raises InputError with one line naming the file and the entry at fault.
    """
    if isinstance(source, Sequence):
        return source
    name = "sequence"
    if isinstance(source, (str, Path)):
        path = Path(source)
        name = path.name
        if not path.is_file():
            raise InputError(f"{path}: no such sequence file")
        source = read_yaml(path, name=name)
    if not isinstance(source, Mapping):
        raise InputError(f"{name}: a sequence must be a mapping with 'projector' and 'frames'")
    proj = source.get("projector")
    if not isinstance(proj, Mapping):
        raise InputError(f"{name}: 'projector: {{width: W, height: H}}' is required")
    width = _num(proj, "width", None, f"{name}: projector", lo=1, integer=True)
    height = _num(proj, "height", None, f"{name}: projector", lo=1, integer=True)
    check_count(f"{name}: projector.width", width, MAX_SIDE)
    check_count(f"{name}: projector.height", height, MAX_SIDE)
    # one frame at a time is what a writer holds (float64 while it is computed)
    check_budget(f"{name}: projector {width} x {height} px", 8.0 * width * height)
    bit_depth = _num(source, "bit_depth", 8, name, integer=True)
    if bit_depth not in (8, 16):
        raise InputError(f"{name}: bit_depth must be 8 or 16, got {bit_depth}")
    gamma = _num(source, "gamma", 1.0, name, lo=1e-3)
    levels = source.get("levels", [0.0, 1.0])
    if not (
        isinstance(levels, (list, tuple))
        and len(levels) == 2
        and all(isinstance(x, (int, float)) for x in levels)
        and 0 <= levels[0] < levels[1] <= 1
    ):
        raise InputError(f"{name}: 'levels' must be [black, white] with 0 <= black < white <= 1, got {levels!r}")
    scale = proj.get("calibration_scale", [1.0, 1.0])
    if not (
        isinstance(scale, (list, tuple))
        and len(scale) == 2
        and all(isinstance(x, (int, float)) and x > 0 for x in scale)
    ):
        raise InputError(f"{name}: projector.calibration_scale must be [sx, sy] > 0, got {scale!r}")
    seq = Sequence(
        width,
        height,
        bit_depth,
        gamma,
        (float(levels[0]), float(levels[1])),
        name=name,
        calibration_scale=(float(scale[0]), float(scale[1])),
    )
    entries = source.get("frames")
    if not isinstance(entries, list) or not entries:
        raise InputError(f"{name}: 'frames' must be a non-empty list")
    for i, entry in enumerate(entries):
        _add_entry(seq, entry, f"{name}: frames[{i}]")
        check_count(f"{name}: frames[{i}]: the sequence's frame count", seq.n_frames, MAX_FRAMES)
    for d in DIRECTIONS:
        if any(c.direction == d for c in seq.code_groups) and not any(p.direction == d for p in seq.phase_groups):
            raise InputError(f"{name}: a {d} code needs a {d} phase group to refine (a code alone is not decoded)")
    return seq


def _add_entry(seq: Sequence, entry: Any, where: str) -> None:
    if isinstance(entry, str):
        entry = {"type": entry}
    if not isinstance(entry, Mapping):
        raise InputError(f"{where}: expected a mapping or one of white, black, ignore; got {entry!r}")
    kind = _choice(entry, "type", KINDS, None, where)
    if kind in ("white", "black", "ignore"):
        count = _num(entry, "count", 1, where, lo=1, integer=True)
        check_count(f"{where}: count", count, MAX_FRAMES - seq.n_frames)
        seq.frames.extend(Frame(kind) for _ in range(count))
        return
    direction = _choice(entry, "direction", DIRECTIONS, None, where)
    span = seq.span(direction)
    period = _num(entry, "period", None, where, lo=0)
    if period < 2:
        raise InputError(f"{where}: 'period' = {period} px is too short (>= 2 px)")
    offset = _num(entry, "offset", 0.0, where)
    start = seq.n_frames
    if kind == "phase":
        steps = _num(entry, "steps", None, where, integer=True)
        if steps < 3:
            raise InputError(f"{where}: 'steps' = {steps}: N-step phase shifting needs N >= 3")
        check_count(f"{where}: steps", steps, MAX_FRAMES - seq.n_frames)
        shifts_deg = entry.get("shifts_deg", [360.0 * k / steps for k in range(steps)])
        if not (isinstance(shifts_deg, (list, tuple)) and len(shifts_deg) == steps):
            raise InputError(f"{where}: 'shifts_deg' must list {steps} phase shifts in degrees")
        if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in shifts_deg):
            raise InputError(f"{where}: 'shifts_deg' must be finite numbers (degrees), got {list(shifts_deg)!r}")
        shifts = tuple(math.radians(float(s)) for s in shifts_deg)
        # eq. 5.3 needs sum(sin delta) = sum(cos delta) = 0 and equal weights in both
        # quadratures; otherwise the arctangent is biased
        c, s = np.cos(shifts), np.sin(shifts)
        if abs(c.sum()) > 1e-6 or abs(s.sum()) > 1e-6 or abs((c * s).sum()) > 1e-6 or abs((c * c - s * s).sum()) > 1e-6:
            raise InputError(
                f"{where}: shifts_deg {list(shifts_deg)} are not evenly spread over 360 deg "
                "(eq. 5.3 needs N equal steps)"
            )
        mean = _num(entry, "mean", 0.5, where, lo=0)
        amp = _num(entry, "amplitude", 0.5, where, lo=0)
        if amp <= 0 or mean - amp < -1e-9 or mean + amp > 1 + 1e-9:
            raise InputError(f"{where}: mean {mean} +- amplitude {amp} must lie in [0, 1] with amplitude > 0")
        gi = len(seq.phase_groups)
        seq.phase_groups.append(
            PhaseGroup(direction, steps, period, offset, shifts, mean, amp, tuple(range(start, start + steps)))
        )
        seq.frames.extend(Frame("phase", direction, gi, k) for k in range(steps))
        return
    n_words = math.ceil((span - offset) / period) if span > offset else 1
    need = max(1, math.ceil(math.log2(max(n_words, 2))))
    bits = _num(entry, "bits", need, where, lo=1, integer=True)
    if bits < need:
        raise InputError(
            f"{where}: {bits} bits number only {1 << bits} stripes of {period} px; "
            f"the {direction} span of {span} px needs {need}"
        )
    if bits > 24:
        raise InputError(f"{where}: 'bits' = {bits} is more than 24")
    inverse = _choice(entry, "inverse", INVERSE_MODES, "none", where)
    order = _choice(entry, "bit_order", ("msb_first", "lsb_first"), "msb_first", where)
    gi = len(seq.code_groups)
    # shown[j] = which bit (MSB-first index) the j-th projected code frame carries
    shown = list(range(bits)) if order == "msb_first" else list(range(bits))[::-1]
    pos: dict[tuple[int, bool], int] = {}
    if inverse == "interleaved":
        layout = [(b, inv) for b in shown for inv in (False, True)]
    elif inverse == "after":
        layout = [(b, False) for b in shown] + [(b, True) for b in shown]
    else:
        layout = [(b, False) for b in shown]
    for j, (b, inv) in enumerate(layout):
        pos[(b, inv)] = start + j
        seq.frames.append(Frame(kind, direction, gi, b, inv))
    frames = tuple(pos[(b, False)] for b in range(bits))
    inv_frames = tuple(pos[(b, True)] for b in range(bits)) if inverse != "none" else ()
    seq.code_groups.append(CodeGroup(kind, direction, bits, period, offset, frames, inv_frames))
