"""Absolute projector coordinates from wrapped phases: code-based (eq. 5.4) and
multi-frequency (heterodyne) unwrapping, with the order checks of :mod:`.orders`.

    Level(period, offset, frac)            a wrapped phase: x = offset + period (k + frac)
    beat(a, b)                             heterodyne beat of two levels
    refine(x_est, level)                   fringe order k = rint((x_est - offset)/period - frac)
    unwrap(levels, span, code=...)         coarse-to-fine unwrapping -> (x, unreliable, steps, stats)

Every step is the same rule: a coarse estimate x_est of the projector coordinate (from a
code word, or from a coarser level) fixes the order k of a finer wrapped phase (eq. 5.4,
``Phi = phi + 2 pi k``), which is correct while |x_est - x| < period / 2.

* A code word c gives x_est = the centre of its stripe, good to half a stripe plus how
  far the captured code boundary may be from the true one. A code as fine as half the
  fringe period (the complementary Gray code: one more bit) therefore unwraps without
  order errors. A code of the fringe period leaves the pixels next to its boundaries
  (= the phase wraps) doubtful: their order is settled from the phase continuity of
  their sure neighbours, or they are dropped and counted (:mod:`.orders`; the thesis's
  "search for 2 pi jumps with respect to neighbouring pixels").
* Heterodyne: two periods T1 < T2 beat with period T12 = T1 T2 / (T2 - T1), the beat
  phase being frac1 - frac2 (mod 1). Beats of beats continue until one period covers the
  span; then the levels are refined from the coarsest to the finest.
* Finally every decoded pixel's order is checked against its neighbours' (phase
  continuity); a pixel that breaks it with most of them is dropped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from camcmm.api import InputError

from .orders import check_continuity, local_checks, row_blocks, settle

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
        raise InputError(
            f"phase levels {a.name} and {b.name} have the same period {a.period} px; "
            "heterodyne unwrapping needs different periods"
        )
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


def unwrap(
    levels: list[Level],
    span: float,
    code: np.ndarray | None = None,
    code_period: float = 0.0,
    code_offset: float = 0.0,
    valid: np.ndarray | None = None,
    correction: str = "auto",
    direction: str = "",
    code_half: float | None = None,
    modulation: np.ndarray | None = None,
):
    """Absolute projector coordinate from wrapped levels (and a code estimate).

    levels : the direction's phase groups as Levels (any number, any periods).
    span   : projector width or height, px.
    code   : optional (H, W) float32 coordinate estimate from a code, px (stripe centres),
             of stripe width ``code_period`` and origin ``code_offset``; ``code_half``
             the largest half-width of a stripe, px (default code_period / 2).
    valid  : (H, W) bool, pixels worth decoding (the neighbours that may vouch for a pixel).
    modulation : (H, W) float32, I'' (grey levels); with it, pixels that mix two
             surfaces (:func:`.orders.unmixed`) do not vouch for a neighbour's order.
    correction : "auto" (settle the orders the code leaves doubtful from the neighbours'
             phase continuity, drop what stays doubtful, check the continuity of the
             result; :mod:`.orders`) or "none" (the plain coarse-to-fine rounding).
             "median" is the former name of "auto".
    Returns x (H, W) float32 px, unreliable (H, W) bool (order not trusted), a list of
    the steps taken and {"corrected": n, "dropped": n} pixel counts of the order checks.
    """
    if correction not in ("auto", "median", "none"):
        raise InputError(f"boundary_correction {correction!r}: use auto or none")
    if not levels:
        raise InputError(f"{direction or 'this'} direction: no phase group to unwrap")
    finest = min(levels, key=lambda lv: lv.period)
    shape = finest.frac.shape
    if valid is None:
        valid = np.ones(shape, bool)
    if code is not None:
        # beats finer than the code stripes cannot be unwrapped by it and add nothing
        todo = levels + [b for b in heterodyne_levels(levels) if b.period > code_period]
        half = 0.5 * code_period if code_half is None else code_half
        x, steps = code, [f"code ({code_period:g} px stripes)"]
    else:
        chain = levels + heterodyne_levels(levels)
        absolute = [lv for lv in chain if lv.period >= span * (1 - 1e-9)]
        if not absolute:
            longest = max(lv.period for lv in chain)
            raise InputError(
                f"{direction or 'these'} fringes: no code, and the longest (beat) period "
                f"{longest:.4g} px is shorter than the projector span {span} px; cannot unwrap"
            )
        top = min(absolute, key=lambda lv: lv.period)
        todo = [top] + [lv for lv in chain if lv.period < top.period]
        x, steps = np.full(shape, np.float32(span / 2.0)), []
    todo.sort(key=lambda lv: -lv.period)
    if code is not None and todo[0].period < code_period * (1 - 1e-9):
        raise InputError(
            f"{direction or 'these'} fringes: the code's {code_period:g} px stripes are wider than "
            f"the longest (beat) period {todo[0].period:.4g} px; the code cannot fix the fringe order"
        )
    unreliable = np.zeros(shape, bool)
    stats = {"corrected": 0, "dropped": 0}
    check = correction != "none"
    order_note = ""
    smooth = None
    for i, lv in enumerate(todo):
        x, r = refine(x, lv)
        note = f"{lv.name or 'level'} ({lv.period:.4g} px)"
        if i > 0:
            unreliable |= np.abs(r) > RESIDUAL_LIMIT
        elif code is not None and check:
            doubt, smooth = local_checks(lv.frac, valid, lv.period, r, half, modulation)
            if doubt.any():
                alt = np.where(r > 0, np.int8(1), np.int8(-1))
                # r is not needed any more: the flip phase takes its memory
                flip = np.subtract(code, np.float32(lv.offset), dtype=np.float32, out=r)
                del r
                flip *= np.float32(1.0 / lv.period)
                flip += np.float32(0.5)
                for a, b in row_blocks(*shape):
                    flip[a:b] -= np.floor(flip[a:b])
                n, dropped = settle(x, lv.frac, lv.period, lv.offset, flip, valid, doubt, alt, smooth)
                del flip, alt
                unreliable |= dropped
                nd = int(np.count_nonzero(dropped))
                stats["corrected"] += n
                stats["dropped"] += nd
                order_note = (
                    f"orders near code boundaries: {int(np.count_nonzero(doubt))} doubtful, {n} corrected, {nd} dropped"
                )
        steps.append(note)
        if order_note:
            steps.append(order_note)
            order_note = ""
    if check:
        if smooth is None or todo[0] is not finest:
            _, smooth = local_checks(finest.frac, valid, finest.period)
        n, dropped = check_continuity(x, finest.frac, finest.period, valid & ~unreliable & smooth)
        nd = int(np.count_nonzero(dropped))
        unreliable |= dropped
        stats["corrected"] += n
        stats["dropped"] += nd
        if n or nd:
            steps.append(f"continuity check: {n} orders corrected, {nd} pixels dropped")
    return x, unreliable, steps, stats
