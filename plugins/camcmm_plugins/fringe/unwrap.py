"""Absolute projector coordinates from wrapped phases: code-based (eq. 5.4) and
multi-frequency (heterodyne) unwrapping, with correction of Gray-code boundary errors.

    Level(period, offset, frac)            a wrapped phase: x = offset + period (k + frac)
    beat(a, b)                             heterodyne beat of two levels
    refine(x_est, level)                   fringe order k = rint((x_est - offset)/period - frac)
    unwrap(levels, span, code=...)         coarse-to-fine unwrapping -> (x, unreliable)
    correct_boundaries(x, period, valid, code_period, code_offset)

Every step is the same rule: a coarse estimate x_est of the projector coordinate (from a
code word, or from a coarser level) fixes the order k of a finer wrapped phase (eq. 5.4,
``Phi = phi + 2 pi k``), which is correct while |x_est - x| < period / 2.

* A code word c of stripe width T_c gives x_est = offset_c + (c + 1/2) T_c, good to
  T_c / 2. A code as fine as half the fringe period (the complementary Gray code: one more
  bit) therefore unwraps without order errors. A code of the fringe period itself leaves
  one-pixel strips of wrong order (+-1 fringe) where the captured code boundary and the
  phase wrap disagree; these are corrected against the 5x5 median of the unwrapped
  coordinate (the thesis's "search for 2 pi jumps with respect to neighbouring pixels").
* Heterodyne: two periods T1 < T2 beat with period T12 = T1 T2 / (T2 - T1), the beat
  phase being frac1 - frac2 (mod 1). Beats of beats continue until one period covers the
  span; then the levels are refined from the coarsest to the finest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from camcmm.api import InputError

# a refinement whose estimate is off by more than this fraction of the finer period is
# flagged as unreliable (a correct one is off by the phase noise times the period ratio)
RESIDUAL_LIMIT = 1.0 / 3.0


@dataclass
class Level:
    """A wrapped phase map: projector coordinate x = offset + period (k + frac), frac in [0, 1)."""

    period: float
    offset: float
    frac: np.ndarray
    name: str = ""


def beat(a: Level, b: Level) -> Level:
    """Heterodyne beat of two levels of different periods (a synthetic longer wavelength)."""
    if a.period > b.period:
        a, b = b, a
    if abs(b.period - a.period) < 1e-9 * b.period:
        raise InputError(f"phase levels {a.name} and {b.name} have the same period {a.period} px; "
                         "heterodyne unwrapping needs different periods")
    t = a.period * b.period / (b.period - a.period)
    offset = t * (a.offset / a.period - b.offset / b.period)
    f = a.frac - b.frac
    np.add(f, np.float32(1.0), out=f, where=f < 0)
    return Level(t, offset, f, f"beat({a.name},{b.name})")


def heterodyne_levels(levels: list[Level]) -> list[Level]:
    """All beat levels of the multi-frequency cascade (beats of neighbours, recursively)."""
    if len(levels) < 2:
        return []
    ordered = sorted(levels, key=lambda lv: lv.period)
    beats = [beat(ordered[i], ordered[i + 1]) for i in range(len(ordered) - 1)]
    return beats + heterodyne_levels(beats)


def refine(x_est: np.ndarray, level: Level, out: np.ndarray | None = None):
    """Unwrap ``level`` with the estimate x_est (px): returns (x, residual in periods)."""
    t = np.subtract(x_est, np.float32(level.offset), dtype=np.float32)
    t *= np.float32(1.0 / level.period)
    t -= level.frac
    k = np.rint(t)
    t -= k  # residual: estimate error in periods, |r| <= 1/2
    k += level.frac
    k *= np.float32(level.period)
    k += np.float32(level.offset)
    if out is not None:
        out[...] = k
        return out, t
    return k, t


def correct_boundaries(x: np.ndarray, period: float, valid: np.ndarray, code_period: float,
                       code_offset: float, passes: int = 4) -> int:
    """Fix +-1-fringe order errors next to code boundaries in place; returns how many.

    A pixel is corrected by j periods when it differs from the 5x5 median of x by j
    periods (|j| >= 1, within a quarter period), it lies within a quarter code stripe of
    a code boundary, and most of its 5x5 neighbourhood is valid. A strip of wrong order
    wider than two pixels is eaten from its edges, one pass at a time (up to ``passes``).
    """
    import cv2

    # outside the image counts as its mirror, so edge pixels are corrected too
    share = cv2.boxFilter(valid.astype(np.float32), -1, (5, 5), normalize=True)
    trusted = valid & (share > 0.6)
    total = 0
    for _ in range(passes):
        # medianBlur replicates the border, which would let a wrong edge row vote for itself
        padded = cv2.copyMakeBorder(np.ascontiguousarray(x, dtype=np.float32), 2, 2, 2, 2, cv2.BORDER_REFLECT_101)
        med = cv2.medianBlur(padded, 5)[2:-2, 2:-2]
        d = np.subtract(x, med, dtype=np.float32)
        d *= np.float32(1.0 / period)
        j = np.rint(d)
        cand = (j != 0) & (np.abs(d - j) < 0.25) & trusted
        if not cand.any():
            break
        pos = (med - np.float32(code_offset)) * np.float32(1.0 / code_period)
        pos -= np.floor(pos)
        cand &= np.abs(pos - 0.5) > 0.25
        n = int(np.count_nonzero(cand))
        if n == 0:
            break
        x[cand] -= j[cand] * np.float32(period)
        total += n
    return total


def unwrap(levels: list[Level], span: float, code: np.ndarray | None = None, code_period: float = 0.0,
           code_offset: float = 0.0, valid: np.ndarray | None = None, correction: str = "auto",
           direction: str = ""):
    """Absolute projector coordinate from wrapped levels (and a code estimate).

    levels : the direction's phase groups as Levels (any number, any periods).
    span   : projector width or height, px.
    code   : optional (H, W) float32 coordinate estimate from a code, px (stripe centres),
             of stripe width ``code_period`` and origin ``code_offset``.
    valid  : (H, W) bool, pixels worth decoding (for the boundary correction's neighbourhood).
    correction : "auto" | "median" | "none" (boundary correction when the code is coarser
             than half the finest phase period; "median" forces it after the code step).
    Returns x (H, W) float32 px, unreliable (H, W) bool and a list of the steps taken.
    """
    if not levels:
        raise InputError(f"{direction or 'this'} direction: no phase group to unwrap")
    finest = min(levels, key=lambda lv: lv.period)
    shape = finest.frac.shape
    if code is not None:
        # beats finer than the code stripes cannot be unwrapped by it and add nothing
        todo = levels + [b for b in heterodyne_levels(levels) if b.period > code_period]
        x, err, steps = code, 0.5 * code_period, [f"code ({code_period:g} px stripes)"]
    else:
        chain = levels + heterodyne_levels(levels)
        absolute = [lv for lv in chain if lv.period >= span * (1 - 1e-9)]
        if not absolute:
            longest = max(lv.period for lv in chain)
            raise InputError(f"{direction or 'these'} fringes: no code, and the longest (beat) period "
                             f"{longest:.4g} px is shorter than the projector span {span} px; cannot unwrap")
        top = min(absolute, key=lambda lv: lv.period)
        todo = [top] + [lv for lv in chain if lv.period < top.period]
        x, err, steps = np.full(shape, np.float32(span / 2.0)), span / 2.0, []
    todo.sort(key=lambda lv: -lv.period)
    if code is not None and todo[0].period < code_period * (1 - 1e-9):
        raise InputError(f"{direction or 'these'} fringes: the code's {code_period:g} px stripes are wider than "
                         f"the longest (beat) period {todo[0].period:.4g} px; the code cannot fix the fringe order")
    unreliable = np.zeros(shape, bool)
    for i, lv in enumerate(todo):
        safe = lv.period > 2.0 * err * (1 + 1e-6)
        x, r = refine(x, lv)
        note = f"{lv.name or 'level'} ({lv.period:.4g} px)"
        if i > 0:
            unreliable |= np.abs(r) > RESIDUAL_LIMIT
        if code is not None and i == 0 and (correction == "median" or (correction == "auto" and not safe)):
            n = correct_boundaries(x, lv.period, valid if valid is not None else np.ones(shape, bool),
                                   code_period, code_offset)
            note += f", {n} boundary pixels corrected"
        steps.append(note)
        err = lv.period / 8.0
    return x, unreliable, steps
