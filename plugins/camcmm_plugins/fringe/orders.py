"""Fringe orders a code cannot fix on its own: which pixels are doubtful, their order from
their neighbours' phase continuity, and a last continuity check of every decoded pixel.

    footprint(frac, valid)                         -> (H, W) float32, periods per camera pixel
    doubtful(r, g, period, code_half)              -> (H, W) bool
    unmixed(modulation)                            -> (H, W) bool
    local_checks(frac, valid, period, r, code_half, modulation) -> (doubt, smooth), row blocks
    settle(x, frac, period, offset, flip, valid, doubt, alt, smooth) -> (corrected, dropped)
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
flips, so all its true coordinates have the same index K of the nearest such point.
Every link from a sure 8-neighbour votes for a K; a band with at least two votes, AGREE
(90 %) of them for one K, takes it, and each of its pixels moves to its candidate of
that K (its code's order or ``alt``). A band without such a vote (it reaches two flip
points through a depth step whose jump mimics continuity) is split into the parts the
code puts at one flip point; these are decided the same way in rounds, sure and
already settled pixels voting, a part only once sources touch COVER (20 %) of its edge
pixels (a thin strip of misread code is not decided by the few votes at one end).
Pixels whose move the code does not allow, that no clear vote reaches, or that are not
smooth, are dropped.

Continuity check (any unwrapping): a pixel whose continuity is broken to at least as
many valid 8-neighbours as it holds to is dropped, unless none holds to it and at least
three agree on one correction (then it is corrected). On clean data it finds nothing;
it catches what a misread bit leaves. Every step is vectorised over the pixels
concerned (flat indices, eight neighbour offsets; bands by scipy's connected components).
The per-pixel maps over the whole image (footprint, doubtful, smooth, unmixed, broken
continuity) are computed in row blocks of BLOCK_PIXELS that stay in the cache, with
the same float32 operations as whole-image arrays would take (identical results):
with a complementary code, where nothing is doubtful, they are all the checks cost.
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
#: share of a band part's edge pixels that must touch a source before it is decided
COVER = 0.2
#: see :func:`unmixed`: a blend of phases 0.23 periods apart keeps 75 % of the modulation
MIXED_SHARE = 0.75
#: pixels per block of the full-image passes (1 MB of float32: stays in the cache)
BLOCK_PIXELS = 1 << 18
NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def _wrap(d: np.ndarray) -> np.ndarray:
    """d - rint(d) in place: a phase difference wrapped into [-1/2, 1/2] periods."""
    d -= np.rint(d)
    return d


def row_blocks(h: int, w: int):
    """Row ranges [a, b) of about BLOCK_PIXELS pixels each."""
    n = max(1, BLOCK_PIXELS // max(w, 1))
    return [(a, min(a + n, h)) for a in range(0, h, n)]


def _footprint_rows(frac: np.ndarray, valid: np.ndarray, a: int, b: int) -> np.ndarray:
    """:func:`footprint` of rows a..b-1 (reads one row more on either side)."""
    h, w = frac.shape
    n = b - a
    g = np.zeros((n, w), np.float32)
    best = np.empty((n, w), np.float32)
    # axis 0: the differences of rows e0..e1-1, pair j = rows (e0 + j, e0 + j + 1)
    e0, e1 = max(a - 1, 0), min(b + 1, h)
    # all pixels valid (most blocks): no pair to mask, and with two rows / columns or
    # more every pixel has a pair, so no "none tells" either
    every = bool(valid[e0:e1].all())
    d = _wrap(np.subtract(frac[e0 + 1 : e1], frac[e0 : e1 - 1]))
    np.abs(d, out=d)
    if not every:
        pair = valid[e0 + 1 : e1] & valid[e0 : e1 - 1]
        np.invert(pair, out=pair)
        np.copyto(d, np.float32(-1.0), where=pair)
    best.fill(-1.0)
    lo, hi = max(a, 1), min(b, h - 1)  # rows with a pair above / below
    np.maximum(best[lo - a :], d[lo - 1 - e0 : b - 1 - e0], out=best[lo - a :])
    np.maximum(best[: hi - a], d[a - e0 : hi - e0], out=best[: hi - a])
    if not every or h < 2:
        np.copyto(best, np.float32(0.5), where=best < 0)
    g += best
    # axis 1
    f, v = frac[a:b], valid[a:b]
    d = _wrap(np.subtract(f[:, 1:], f[:, :-1]))
    np.abs(d, out=d)
    if not every:
        pair = v[:, 1:] & v[:, :-1]
        np.invert(pair, out=pair)
        np.copyto(d, np.float32(-1.0), where=pair)
    best.fill(-1.0)
    np.maximum(best[:, 1:], d, out=best[:, 1:])
    np.maximum(best[:, :-1], d, out=best[:, :-1])
    if not every or w < 2:
        np.copyto(best, np.float32(0.5), where=best < 0)
    g += best
    return g


def footprint(frac: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Change of the phase across one camera pixel, periods: the larger wrapped
    difference to the left/right neighbour plus the larger to the upper/lower one
    (0.5 per axis where no valid neighbour tells). (H, W) float32."""
    g = np.empty(frac.shape, np.float32)
    for a, b in row_blocks(*frac.shape):
        g[a:b] = _footprint_rows(frac, valid, a, b)
    return g


def unmixed(modulation: np.ndarray, a: int = 0, b: int | None = None) -> np.ndarray:
    """Pixels (of rows a..b-1) whose modulation is at least MIXED_SHARE of the largest
    in their 3 x 3 neighbourhood. A pixel on a depth step averages two phases, and its
    modulation drops (by cos(pi d) for phases d periods apart); such a pixel's phase
    lies between its neighbours' and would vouch for a wrong order across the step."""
    import cv2

    h = modulation.shape[0]
    b = h if b is None else b
    e0, e1 = max(a - 1, 0), min(b + 1, h)
    top = cv2.dilate(modulation[e0:e1], np.ones((3, 3), np.uint8))[a - e0 : b - e0]
    np.multiply(top, np.float32(MIXED_SHARE), out=top)
    return modulation[a:b] >= top


def local_checks(
    frac: np.ndarray,
    valid: np.ndarray,
    period: float,
    r: np.ndarray | None = None,
    code_half: float = 0.0,
    modulation: np.ndarray | None = None,
):
    """The per-pixel maps of the order checks in one pass of cache-sized row blocks
    (no full-image float temporaries): ``doubt`` = valid & :func:`doubtful` (None
    without r) and ``smooth`` = footprint < CONTINUITY, and with ``modulation`` also
    :func:`unmixed`. Returns (doubt, smooth), (H, W) bool."""
    shape = frac.shape
    doubt = None if r is None else np.empty(shape, bool)
    smooth = np.empty(shape, bool)
    for a, b in row_blocks(*shape):
        g = _footprint_rows(frac, valid, a, b)
        if doubt is not None and r is not None:  # both or neither
            doubtful(r[a:b], g, period, code_half, out=doubt[a:b])
            doubt[a:b] &= valid[a:b]
        np.less(g, CONTINUITY, out=smooth[a:b])
        if modulation is not None:
            smooth[a:b] &= unmixed(modulation, a, b)
    return doubt, smooth


def doubtful(r: np.ndarray, g: np.ndarray, period: float, code_half: float, out=None) -> np.ndarray:
    """Pixels whose order the code does not settle: |r| >= 1 - (code_half + m) / period
    with m = max(MARGIN period, FOOTPRINT_SHARE g period + EDGE_PX) (module docstring);
    r, g (H, W) in periods."""
    m = np.maximum(np.float32(MARGIN), np.float32(FOOTPRINT_SHARE) * g + np.float32(EDGE_PX / period))
    m += np.float32(code_half / period - 1.0)
    np.negative(m, out=m)
    return np.greater_equal(np.abs(r), m, out=out)


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


def _bands(members: np.ndarray, mask: np.ndarray, ff, phi, kmem, shape):
    """Connected components of the pixels ``members`` (flat, sorted; ``mask`` the same
    as an image): 4-neighbours linked when their phases differ by less than CONTINUITY,
    their flip phases agree and (``kmem`` given: the members' flip-point indices) the
    code puts them at the same flip point."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    h, w = shape
    node = np.full(h * w, -1, np.int32 if members.size < 2**31 else np.int64)
    node[members] = np.arange(members.size)
    rows, cols = [], []
    for step in (1, w):
        first = members[(members % w < w - 1) if step == 1 else (members < (h - 1) * w)]
        first = first[mask.ravel()[first + step]]
        second = first + step
        keep = (np.abs(_wrap(ff[first] - ff[second])) < CONTINUITY) & (np.abs(_wrap(phi[first] - phi[second])) < 1e-3)
        n1, n2 = node[first], node[second]
        if kmem is not None:
            keep &= kmem[n1] == kmem[n2]
        rows.append(n1[keep])
        cols.append(n2[keep])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(members.size, members.size))
    return connected_components(graph, directed=False)


def _leading(p, group, n_groups, source, xf, ff, phi, period, offset, shape, labels=None):
    """Votes of the source 8-neighbours of pixels p (flat) for the flip-point index K of
    their group: (K per group, bool per group: at least two votes and AGREE of them).
    With ``labels`` (each pixel's group + 1 as a flat image, 0 outside), a group also
    needs sources along COVER of its edge pixels (its pixels with a neighbour outside
    it): a long strip is not decided by the few votes at one of its ends."""
    h, w = shape
    row, col = np.divmod(p, w)
    inside = {(-1, 0): row > 0, (1, 0): row < h - 1, (0, -1): col > 0, (0, 1): col < w - 1}
    del row, col
    fp, php = ff[p], phi[p]
    inv, off = np.float32(1.0 / period), np.float32(offset)
    vb, vk = [], []
    touched = np.zeros(p.size, bool)
    edge = np.zeros(p.size, bool)
    for dy, dx in NEIGHBOURS:
        if dy and dx:
            inb = inside[dy, 0] & inside[0, dx]
        else:
            inb = inside[dy, dx]
        n = np.where(inb, p + dy * w + dx, p)
        wd = _wrap(np.subtract(fp, ff[n], dtype=np.float32))
        ok = inb & source[n] & (np.abs(wd) < CONTINUITY)
        implied = xf[n[ok]] + wd[ok] * np.float32(period)
        vb.append(group[ok])
        vk.append(np.rint((implied - off) * inv - php[ok]).astype(np.int64))
        if labels is not None:
            touched |= ok
            edge |= inb & (labels[n] != group + 1)
    vb, vk = np.concatenate(vb).astype(np.int64, copy=False), np.concatenate(vk)
    k_group = np.zeros(n_groups, np.int64)
    clear = np.zeros(n_groups, bool)
    if not vb.size:
        return k_group, clear
    lo = int(vk.min())
    span = int(vk.max()) - lo + 1
    key, count = np.unique(vb * span + (vk - lo), return_counts=True)
    kb, kk = np.divmod(key, span)
    total = np.bincount(kb, weights=count, minlength=n_groups)
    order = np.lexsort((count, kb))
    last = order[np.r_[kb[order][1:] != kb[order][:-1], True]]
    lead_b, lead_n = kb[last], count[last]
    good = (lead_n >= 2) & (lead_n >= AGREE * total[lead_b])
    if labels is not None:
        n_touched = np.bincount(group[touched], minlength=n_groups)
        n_edge = np.bincount(group[edge], minlength=n_groups)
        good &= n_touched[lead_b] >= COVER * n_edge[lead_b]
    k_group[lead_b[good]] = kk[last][good] + lo
    clear[lead_b[good]] = True
    return k_group, clear


def settle(
    x: np.ndarray,
    frac: np.ndarray,
    period: float,
    offset: float,
    flip: np.ndarray,
    valid: np.ndarray,
    doubt: np.ndarray,
    alt: np.ndarray,
    smooth: np.ndarray,
    rounds: int = 32,
):
    """Settle the doubtful pixels band by band (in place on x, px); see the module docstring.

    flip   : (H, W) float32, the phase (periods, [0, 1)) at which each pixel's code
             rounding flips: ((x_code - offset) / period + 1/2) mod 1.
    alt    : (H, W) int8, the other order the code allows (+1 or -1).
    smooth : (H, W) bool, pixels whose phase changes by less than CONTINUITY to every
             side and that mix no surfaces; only these link, vote or are settled.
    Returns (number corrected, (H, W) bool of the pixels dropped).
    """
    dropped = doubt & ~smooth  # no continuity to judge by (an outline, a depth step)
    doubt = doubt & smooth
    idx = np.flatnonzero(doubt)
    if not idx.size:
        return 0, dropped
    shape = x.shape
    ff, xf, phi, af = frac.ravel(), x.reshape(-1), flip.ravel(), alt.ravel()
    # each doubtful pixel's flip-point index, aligned with idx
    ph = phi[idx]
    kc = xf[idx]
    kc -= np.float32(offset)
    kc *= np.float32(1.0 / period)
    kc -= ph
    kc = np.rint(kc, out=kc).astype(np.int32)
    source = (valid & ~doubt & smooth).ravel()
    corrected = 0

    def apply(p, k, kp):
        """Move pixels p (flip indices kp) to their candidate of flip index k; returns
        which of them are kept."""
        nonlocal corrected
        j = k - kp
        ok = (j == 0) | (j == af[p])
        moved = ok & (j != 0)
        fix = p[moved]
        xf[fix] += j[moved].astype(np.float32) * np.float32(period)
        corrected += fix.size
        dropped.ravel()[p[~ok]] = True
        return ok

    # 1. whole bands, voted by their sure neighbours
    import cv2

    ph -= ph[0]
    if np.abs(_wrap(ph), out=ph).max() < 1e-3:
        # one flip phase (a code of the fringe period): two smooth 4-neighbours always
        # link (their phases differ by less than either's footprint < CONTINUITY)
        n_bands, labels = cv2.connectedComponents(doubt.view(np.uint8), connectivity=4, ltype=cv2.CV_32S)
        band = labels.ravel()[idx]
        band -= 1
        n_bands -= 1
        del labels
    else:
        n_bands, band = _bands(idx, doubt, ff, phi, None, shape)
    del ph

    # only a band's rim can have a sure neighbour
    near = cv2.dilate(source.reshape(shape).view(np.uint8), np.ones((3, 3), np.uint8)).ravel()[idx] > 0
    k_band, clear = _leading(idx[near], band[near], n_bands, source, xf, ff, phi, period, offset, shape)
    del near
    done = clear[band]
    # over all doubtful pixels at once (most bands are decided): j = the move to the
    # band's flip point, allowed when 0 or the code's other order
    j = k_band.astype(np.int32)[band]
    j -= kc
    ok = j == 0
    ok |= j == af[idx]
    ok &= done
    fix = idx[ok & (j != 0)]
    xf[fix] += j[ok & (j != 0)].astype(np.float32) * np.float32(period)
    corrected += fix.size
    del fix, j
    ok ^= done  # decided, but not allowed
    dropped.ravel()[idx[ok]] = True
    # 2. the rest (a band reaching two flip points through a depth step, or none):
    #    its parts the code puts at one flip point, in rounds from sure and settled pixels
    rest = idx[~done]
    if rest.size:
        # sources now: the sure ones and the doubtful pixels just settled
        source = (valid & smooth).ravel()
        source[rest] = False
        source[idx[ok]] = False
        del ok
        k_rest = kc[~done]
        mask = np.zeros(shape, bool)
        mask.ravel()[rest] = True
        n_parts, part = _bands(rest, mask, ff, phi, k_rest, shape)
        labels = np.zeros(x.size, np.int32 if n_parts < 2**31 - 1 else np.int64)
        labels[rest] = part + 1
        todo = np.arange(rest.size)
        for _ in range(rounds):
            if not todo.size:
                break
            k_part, clear = _leading(
                rest[todo], part[todo], n_parts, source, xf, ff, phi, period, offset, shape, labels
            )
            if not clear.any():
                break
            now = clear[part[todo]]
            sel = todo[now]
            ok = apply(rest[sel], k_part[part[sel]], k_rest[sel])
            source[rest[sel[ok]]] = True
            todo = todo[~now]
        dropped.ravel()[rest[todo]] = True
    return corrected, dropped


def _mark_broken(x, frac, valid, axis, inv, broken):
    """broken |= pixels of a valid pair along ``axis`` whose phases are continuous
    (|wrapped difference| < CONTINUITY) but whose coordinates differ by another order."""
    wd = _wrap(np.diff(frac, axis=axis))
    d = np.diff(x, axis=axis)
    d *= inv
    d -= wd
    bad = (np.abs(wd) < CONTINUITY) & (np.abs(d) > 0.5)
    if not valid.all():
        bad &= valid[1:] & valid[:-1] if axis == 0 else valid[:, 1:] & valid[:, :-1]
    if axis == 0:
        broken[1:] |= bad
        broken[:-1] |= bad
    else:
        broken[:, 1:] |= bad
        broken[:, :-1] |= bad


def check_continuity(x: np.ndarray, frac: np.ndarray, period: float, valid: np.ndarray):
    """The last continuity check (module docstring), in place on x (px).

    Returns (number corrected, (H, W) bool of the pixels dropped).
    """
    inv = np.float32(1.0 / period)
    h, w = x.shape
    broken = np.zeros(x.shape, bool)
    with np.errstate(invalid="ignore"):
        for a, b in row_blocks(h, w):
            # pairs along a row, then pairs of rows (i, i + 1), i in a..b-1
            hi = min(b + 1, h)
            if not valid[a:hi].any():
                continue
            _mark_broken(x[a:b], frac[a:b], valid[a:b], 1, inv, broken[a:b])
            if hi - a > 1:
                _mark_broken(x[a:hi], frac[a:hi], valid[a:hi], 0, inv, broken[a:hi])
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
