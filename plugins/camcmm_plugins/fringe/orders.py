"""Fringe orders a code cannot fix on its own: which pixels are doubtful, their order from
their neighbours' phase continuity, and a last continuity check of every decoded pixel.

    footprint(frac, valid)                         -> (H, W) float32, periods per camera pixel
    doubtful(r, g, period, code_half)              -> (H, W) bool
    settle(x, frac, period, offset, flip, valid, doubt, alt, smooth) -> (corrected, dropped)
    resolve(x, frac, period, valid, doubt, alt)    -> (corrected, dropped)   pixel by pixel
    check_continuity(x, frac, period, valid)       -> (corrected, dropped)

Why. A code word c of a stripe of half-width ``h`` px gives the coordinate to within
h + m, with m how far the captured code boundary can lie from the true one. The order
k of a phase of period P is then right where the residual r = (x_code - x) / P - (k -
k_code) of eq. 5.4's rounding satisfies ``|r| < 1 - (h + m) / P``: a wrong k would
mean an estimate error of at least ``1 - |r|`` periods, more than the code allows. A
code of half the fringe period (the complementary Gray code) leaves every pixel sure; a
code of the fringe period (h = P/2) leaves the pixels within m of a phase wrap
*doubtful*: there the code boundary and the wrap may disagree and k may be off by one,
towards ``alt = sign(r)``. That is no noise effect: the patterns' code edges lie
between projector pixels, a camera pixel straddling one takes either word, and a
noise-free capture still has one-period errors there.

m = max(P/4, half a camera pixel's footprint on the projector + 1 px). In the virtual
lab the captured boundary lies at most 0.3 px (0.08 footprints) from the true one; on
real captures with a non-linear projector (kimthyung) ~10 px of a 114 px period.

Phase continuity (Itoh's condition): two neighbouring pixels whose wrapped phases
differ by w (wrapped into [-1/2, 1/2) periods) are taken to differ by w in absolute
phase when |w| < CONTINUITY; their unwrapped coordinates then imply an order
correction j = -rint((x_p - x_n)/P - w) for p. Only *smooth* pixels link or vote:
their phase changes by less than CONTINUITY to every side, and (decode) they do not mix
two surfaces; an outline or a depth step gives no evidence.

Settling (:func:`settle`): the doubtful pixels, linked by 4-neighbour steps, form bands
along the code boundaries. A band lies around one point where the code's rounding
flips, so all its true coordinates have the same index K of the nearest such point:
every link from a sure 8-neighbour votes for a K, a band whose votes (at least two) all
agree takes that K, and each pixel moves to its candidate of that K. A band whose votes
disagree (it reaches two boundaries through a gap in the sure pixels) is settled pixel
by pixel (:func:`resolve`: at least two unanimous votes of sure or settled neighbours,
in passes). Pixels whose voters disagree, whose move the code does not allow, that no
vote reaches, or that are not smooth, are dropped.

Continuity check (any unwrapping): a pixel whose continuity is broken to at least as
many valid 8-neighbours as it holds to is dropped, unless none holds to it and at least
three agree on one correction (then it is corrected). On clean data it finds nothing;
it catches what a misread bit leaves. Every step is vectorised over the pixels
concerned (flat indices, eight neighbour offsets; bands by scipy's connected components).
"""

from __future__ import annotations

import numpy as np

#: |wrapped phase difference| (periods) below which two neighbours are taken to be on
#: one continuous surface (Itoh's condition |delta| < 1/2 with margin).
CONTINUITY = 1.0 / 3.0
#: how far a captured code boundary may lie from the true one: MARGIN periods, or where
#: more, this share of a camera pixel's footprint on the projector plus EDGE_PX px
MARGIN = 0.25
FOOTPRINT_SHARE = 0.5
EDGE_PX = 1.0
#: share of a band's votes its order needs (the rest: links across a depth step)
AGREE = 0.9
NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def _wrap(d: np.ndarray) -> np.ndarray:
    """d - rint(d) in place: a phase difference wrapped into [-1/2, 1/2] periods."""
    d -= np.rint(d)
    return d


def footprint(frac: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Change of the phase across one camera pixel, periods: the larger wrapped
    difference to the left/right neighbour plus the larger to the upper/lower one
    (0.5 per axis where no valid neighbour tells). (H, W) float32."""
    g = np.zeros(frac.shape, np.float32)
    for axis in (0, 1):
        d = _wrap(np.diff(frac, axis=axis))
        np.abs(d, out=d)
        pair = valid[1:] & valid[:-1] if axis == 0 else valid[:, 1:] & valid[:, :-1]
        np.invert(pair, out=pair)
        np.copyto(d, np.float32(-1.0), where=pair)
        best = np.full(frac.shape, -1.0, np.float32)
        lo = (slice(1, None), slice(None)) if axis == 0 else (slice(None), slice(1, None))
        hi = (slice(None, -1), slice(None)) if axis == 0 else (slice(None), slice(None, -1))
        np.maximum(best[lo], d, out=best[lo])
        np.maximum(best[hi], d, out=best[hi])
        np.copyto(best, np.float32(0.5), where=best < 0)
        g += best
    return g


def doubtful(r: np.ndarray, g: np.ndarray, period: float, code_half: float) -> np.ndarray:
    """Pixels whose order the code does not settle: |r| >= 1 - (code_half + m) / period
    with m = max(MARGIN period, FOOTPRINT_SHARE g period + EDGE_PX) (module docstring);
    r, g (H, W) in periods."""
    m = np.maximum(np.float32(MARGIN), np.float32(FOOTPRINT_SHARE) * g + np.float32(EDGE_PX / period))
    m += np.float32(code_half / period - 1.0)
    return np.abs(r) >= -m


def _votes(p, x, frac, period, source, shape):
    """For pixels p (flat): the number of source 8-neighbours that vote (within
    CONTINUITY), how many of them vote 0 (continuous with p as it is), and the smallest
    and largest order correction they imply (0 where none votes)."""
    h, w = shape
    row, col = np.divmod(p, w)
    xf, ff, sf = x.ravel(), frac.ravel(), source.ravel()
    xp, fp = xf[p], ff[p]
    count = np.zeros(p.size, np.int8)
    zero = np.zeros(p.size, np.int8)
    jmin = np.full(p.size, 127, np.int16)
    jmax = np.full(p.size, -127, np.int16)
    inv = np.float32(1.0 / period)
    for dy, dx in NEIGHBOURS:
        inb = (row + dy >= 0) & (row + dy < h) & (col + dx >= 0) & (col + dx < w)
        n = np.where(inb, p + dy * w + dx, p)
        wd = _wrap(np.subtract(fp, ff[n], dtype=np.float32))
        ok = inb & sf[n] & (np.abs(wd) < CONTINUITY)
        with np.errstate(invalid="ignore"):
            j = -np.rint((xp - xf[n]) * inv - wd)
        j = np.clip(np.nan_to_num(j), -100, 100).astype(np.int16)
        count += ok
        zero += ok & (j == 0)
        np.minimum(jmin, np.where(ok, j, 127), out=jmin)
        np.maximum(jmax, np.where(ok, j, -127), out=jmax)
    none = count == 0
    jmin[none] = 0
    jmax[none] = 0
    return count, zero, jmin, jmax


def settle(x: np.ndarray, frac: np.ndarray, period: float, offset: float, flip: np.ndarray, valid: np.ndarray,
           doubt: np.ndarray, alt: np.ndarray, smooth: np.ndarray, rounds: int = 32):
    """Settle the doubtful pixels band by band (in place on x, px); see the module docstring.

    flip   : (H, W) float32, the phase (periods, [0, 1)) at which each pixel's code
             rounding flips: ((x_code - offset) / period + 1/2) mod 1.
    alt    : (H, W) int8, the other order the code allows (+1 or -1).
    smooth : (H, W) bool, pixels whose phase changes by less than CONTINUITY to every
             side and that mix no surfaces; only these link, vote or are settled.
    Returns (number corrected, (H, W) bool of the pixels dropped).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    dropped = doubt & ~smooth  # no continuity to judge by (an outline, a depth step)
    doubt = doubt & smooth
    idx = np.flatnonzero(doubt)
    if not idx.size:
        return 0, dropped
    h, w = x.shape
    ff, xf, phi = frac.ravel(), x.reshape(-1), flip.ravel()
    inv, off = np.float32(1.0 / period), np.float32(offset)
    # K: index of the nearest flip point, as the code has it
    kmap = np.zeros(h * w, np.int64)
    kmap[idx] = np.rint((xf[idx] - off) * inv - phi[idx]).astype(np.int64)
    node = np.full(h * w, -1, np.int64)
    node[idx] = np.arange(idx.size)
    rows, cols = [], []
    for step in (1, w):
        first = idx[(idx % w < w - 1) if step == 1 else (idx < (h - 1) * w)]
        second = first + step
        keep = doubt.ravel()[second]
        first, second = first[keep], second[keep]
        wd = _wrap(ff[first] - ff[second])
        keep = (np.abs(wd) < CONTINUITY) & (kmap[first] == kmap[second]) & \
            (np.abs(_wrap(phi[first] - phi[second])) < 1e-3)
        rows.append(node[first[keep]])
        cols.append(node[second[keep]])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(idx.size, idx.size))
    n_bands, band = connected_components(graph, directed=False)
    del graph, r, c, rows, cols, node
    source = (valid & ~doubt & smooth).ravel().copy()
    pending = np.ones(n_bands, bool)
    a_ = alt.ravel()[idx]
    k_own = kmap[idx]
    del kmap
    corrected = 0
    row, col = np.divmod(idx, w)
    todo = np.arange(idx.size)
    for _ in range(rounds):
        if not todo.size:
            break
        vb, vk = [], []
        p = idx[todo]
        for dy, dx in NEIGHBOURS:
            inb = (row[todo] + dy >= 0) & (row[todo] + dy < h) & (col[todo] + dx >= 0) & (col[todo] + dx < w)
            n = np.where(inb, p + dy * w + dx, p)
            wd = _wrap(np.subtract(ff[p], ff[n], dtype=np.float32))
            ok = inb & source[n] & (np.abs(wd) < CONTINUITY)
            implied = xf[n[ok]] + wd[ok] * np.float32(period)
            vb.append(band[todo[ok]])
            vk.append(np.rint((implied - off) * inv - phi[p[ok]]).astype(np.int64))
        vb, vk = np.concatenate(vb), np.concatenate(vk)
        if not vb.size:
            break
        lo = int(vk.min())
        span = int(vk.max()) - lo + 1
        key, count = np.unique(vb * span + (vk - lo), return_counts=True)
        kb, kk = np.divmod(key, span)
        total = np.bincount(kb, weights=count, minlength=n_bands)
        order = np.lexsort((count, kb))
        last = order[np.r_[kb[order][1:] != kb[order][:-1], True]]
        lead_b, lead_n = kb[last], count[last]
        clear = (lead_n >= 2) & (lead_n >= AGREE * total[lead_b])
        if not clear.any():
            break
        k_band = np.zeros(n_bands, np.int64)
        k_band[lead_b[clear]] = kk[last][clear] + lo
        done = np.zeros(n_bands, bool)
        done[lead_b[clear]] = True
        pending &= ~done
        sel = todo[done[band[todo]]]
        j = k_band[band[sel]] - k_own[sel]
        ok = (j == 0) | (j == a_[sel])
        fix = sel[ok & (j != 0)]
        xf[idx[fix]] += (k_band[band[fix]] - k_own[fix]).astype(np.float32) * np.float32(period)
        corrected += fix.size
        dropped.ravel()[idx[sel[~ok]]] = True
        source[idx[sel[ok]]] = True
        todo = todo[~done[band[todo]]]
    dropped.ravel()[idx[todo]] = True
    return corrected, dropped


def check_continuity(x: np.ndarray, frac: np.ndarray, period: float, valid: np.ndarray):
    """The last continuity check (module docstring), in place on x (px).

    Returns (number corrected, (H, W) bool of the pixels dropped).
    """
    inv = np.float32(1.0 / period)
    broken = np.zeros(x.shape, bool)
    with np.errstate(invalid="ignore"):
        for axis in (0, 1):
            wd = _wrap(np.diff(frac, axis=axis))
            d = np.diff(x, axis=axis)
            d *= inv
            d -= wd
            pair = valid[1:] & valid[:-1] if axis == 0 else valid[:, 1:] & valid[:, :-1]
            bad = pair & (np.abs(wd) < CONTINUITY) & (np.abs(d) > 0.5)
            if axis == 0:
                broken[1:] |= bad
                broken[:-1] |= bad
            else:
                broken[:, 1:] |= bad
                broken[:, :-1] |= bad
    p = np.flatnonzero(broken)
    dropped = np.zeros(x.shape, bool)
    if not p.size:
        return 0, dropped
    count, hold, jmin, jmax = _votes(p, x, frac, period, valid, x.shape)
    against = count - hold
    fix = (hold == 0) & (count >= 3) & (jmin == jmax)
    drop = ~fix & (against > 0) & (against >= hold)
    x.reshape(-1)[p[fix]] += jmin[fix].astype(np.float32) * np.float32(period)
    dropped.ravel()[p[drop]] = True
    return int(np.count_nonzero(fix)), dropped
