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
NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def _wrap(d: np.ndarray) -> np.ndarray:
    d -= np.rint(d)
    return d


def footprint(frac: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Change of the phase across one camera pixel, periods: the larger wrapped
    difference to the left/right neighbour plus the larger to the upper/lower one
    (0.5 per axis where no valid neighbour tells). (H, W) float32."""
    g = np.zeros(frac.shape, np.float32)
    for axis in (0, 1):
        d = np.abs(_wrap(np.diff(frac, axis=axis)))
        pair = valid[1:] & valid[:-1] if axis == 0 else valid[:, 1:] & valid[:, :-1]
        d[~pair] = -1.0
        best = np.full(frac.shape, -1.0, np.float32)
        lo = (slice(1, None), slice(None)) if axis == 0 else (slice(None), slice(1, None))
        hi = (slice(None, -1), slice(None)) if axis == 0 else (slice(None), slice(None, -1))
        np.maximum(best[lo], d, out=best[lo])
        np.maximum(best[hi], d, out=best[hi])
        best[best < 0] = 0.5
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


def resolve(x: np.ndarray, frac: np.ndarray, period: float, valid: np.ndarray, doubt: np.ndarray,
            alt: np.ndarray, passes: int = 256):
    """Settle doubtful pixels from their sure neighbours (in place on x, px).

    alt : (H, W) int8, the other order the code allows (+1 or -1).
    Returns (number corrected, (H, W) bool of the doubtful pixels dropped).
    """
    source = valid & ~doubt
    todo = np.flatnonzero(valid & doubt)
    dropped = np.zeros(x.shape, bool)
    corrected = 0
    altf = alt.ravel()
    xf = x.reshape(-1)
    for _ in range(passes):
        if not todo.size:
            break
        count, _, jmin, jmax = _votes(todo, x, frac, period, source, x.shape)
        agree = jmin == jmax
        allowed = (jmin == 0) | (jmin == altf[todo])
        settle = (count >= 2) & agree & allowed
        conflict = (count >= 1) & ~(agree & allowed)
        fix = todo[settle & (jmin != 0)]
        xf[fix] += altf[fix].astype(np.float32) * np.float32(period)
        corrected += fix.size
        dropped.ravel()[todo[conflict]] = True
        source.ravel()[todo[settle]] = True
        if not settle.any():
            break
        todo = todo[~settle & ~conflict]
    dropped.ravel()[todo] = True
    return corrected, dropped


def settle(x: np.ndarray, frac: np.ndarray, period: float, offset: float, flip: np.ndarray, valid: np.ndarray,
           doubt: np.ndarray, alt: np.ndarray, smooth: np.ndarray):
    """Settle the doubtful pixels band by band (in place on x, px); see the module docstring.

    flip : (H, W) float32, the phase (periods, [0, 1)) at which each pixel's code
           rounding flips: ((x_code - offset) / period + 1/2) mod 1.
    A band (the doubtful pixels linked by 4-neighbour steps within CONTINUITY) lies
    around one flip point, so its true coordinates all have the same index K of the
    nearest point of phase ``flip``. Each Itoh-consistent link from a sure 8-neighbour
    votes for a K; a band whose votes (at least two) all agree takes that K, and each of
    its pixels moves to its candidate of that K (its code's order or ``alt``; pixels
    whose move the code does not allow are dropped). Bands whose votes disagree, and all
    bands when the pixels have different flip phases (a code not of the fringe
    period), are settled pixel by pixel (:func:`resolve`).
    smooth : (H, W) bool, pixels whose phase changes by less than CONTINUITY to every
           side (:func:`footprint`); only these link, vote or are settled.
    Returns (number corrected, (H, W) bool of the pixels dropped).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    dropped = doubt & ~smooth  # no continuity to judge by (an outline, a depth step)
    doubt = doubt & smooth
    valid = valid & smooth
    idx = np.flatnonzero(doubt)
    if not idx.size:
        return 0, dropped
    ff, xf, phi = frac.ravel(), x.reshape(-1), flip.ravel()
    spread = _wrap(phi[idx] - phi[idx[0]])
    if np.abs(spread).max() > 1e-3:
        n, more = resolve(x, frac, period, valid, doubt, alt)
        return n, dropped | more
    h, w = x.shape
    node = np.full(h * w, -1, np.int64)
    node[idx] = np.arange(idx.size)
    rows, cols = [], []
    for step, a, b in ((1, doubt[:, :-1], doubt[:, 1:]), (w, doubt[:-1], doubt[1:])):
        pair = a & b
        if step == 1:
            pair &= np.abs(_wrap(np.diff(frac, axis=1))) < CONTINUITY
            first = np.flatnonzero(np.pad(pair, ((0, 0), (0, 1))))
        else:
            pair &= np.abs(_wrap(np.diff(frac, axis=0))) < CONTINUITY
            first = np.flatnonzero(np.pad(pair, ((0, 1), (0, 0))))
        rows.append(node[first])
        cols.append(node[first + step])
    r = np.concatenate(rows)
    c = np.concatenate(cols)
    graph = coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(idx.size, idx.size))
    n_bands, band = connected_components(graph, directed=False)
    del graph, r, c, rows, cols
    inv = np.float32(1.0 / period)
    off = np.float32(offset)
    k_own = np.rint((xf[idx] - off) * inv - phi[idx]).astype(np.int64)
    # votes: (band, K) of every link from a sure neighbour
    row, col = np.divmod(idx, w)
    sure = (valid & ~doubt).ravel()
    vb, vk = [], []
    for dy, dx in NEIGHBOURS:
        inb = (row + dy >= 0) & (row + dy < h) & (col + dx >= 0) & (col + dx < w)
        n = np.where(inb, idx + dy * w + dx, idx)
        wd = _wrap(np.subtract(ff[idx], ff[n], dtype=np.float32))
        ok = inb & sure[n] & (np.abs(wd) < CONTINUITY)
        implied = xf[n[ok]] + wd[ok] * np.float32(period)
        vb.append(band[ok])
        vk.append(np.rint((implied - off) * inv - phi[idx[ok]]).astype(np.int64))
    vb, vk = np.concatenate(vb), np.concatenate(vk)
    k_band = np.full(n_bands, np.iinfo(np.int64).min, np.int64)
    if vb.size:
        lo = int(vk.min())
        span = int(vk.max()) - lo + 1
        key, count = np.unique(vb * span + (vk - lo), return_counts=True)
        kb, kk = np.divmod(key, span)
        total = np.bincount(kb, weights=count, minlength=n_bands)
        # the leading K of each band: sort by (band, count) and take each band's last
        order = np.lexsort((count, kb))
        last = order[np.r_[kb[order][1:] != kb[order][:-1], True]]
        lead_b, lead_n = kb[last], count[last]
        clear = (lead_n >= 2) & (lead_n == total[lead_b])
        k_band[lead_b[clear]] = kk[last][clear] + lo
    target = k_band[band]
    unclear = target == np.iinfo(np.int64).min
    j = target - k_own
    a_ = alt.ravel()[idx]
    ok = ~unclear & ((j == 0) | (j == a_))
    fix = ok & (j != 0)
    xf[idx[fix]] += j[fix].astype(np.float32) * np.float32(period)
    dropped.ravel()[idx[~ok & ~unclear]] = True
    n = int(np.count_nonzero(fix))
    if unclear.any():
        # a band that reaches two flip points (through a gap in the sure pixels) or
        # none: its pixels one by one, from whatever sure or settled pixels touch them
        rest = np.zeros(x.shape, bool)
        rest.ravel()[idx[unclear]] = True
        more, lost = resolve(x, frac, period, valid & ~dropped, rest, alt)
        n += more
        dropped |= lost
    return n, dropped


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
