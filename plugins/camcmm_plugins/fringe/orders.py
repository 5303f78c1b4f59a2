"""Fringe orders a code cannot fix on its own: which pixels are doubtful, their order from
their neighbours' phase continuity, and a last continuity check of every decoded pixel.

    footprint(frac, valid)                         -> (H, W) float32, periods per camera pixel
    doubtful(r, g, period, code_half)              -> (H, W) bool
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


def _bands(members: np.ndarray, mask: np.ndarray, ff, phi, kmap, shape, same_k: bool):
    """Connected components of the pixels ``members`` (flat, sorted; ``mask`` the same
    as an image): 4-neighbours linked when their phases differ by less than CONTINUITY,
    their flip phases agree and (``same_k``) the code puts them at the same flip point."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    h, w = shape
    node = np.full(h * w, -1, np.int64)
    node[members] = np.arange(members.size)
    rows, cols = [], []
    for step in (1, w):
        first = members[(members % w < w - 1) if step == 1 else (members < (h - 1) * w)]
        first = first[mask.ravel()[first + step]]
        second = first + step
        keep = (np.abs(_wrap(ff[first] - ff[second])) < CONTINUITY) & \
            (np.abs(_wrap(phi[first] - phi[second])) < 1e-3)
        if same_k:
            keep &= kmap[first] == kmap[second]
        rows.append(node[first[keep]])
        cols.append(node[second[keep]])
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
    inv, off = np.float32(1.0 / period), np.float32(offset)
    vb, vk = [], []
    touched = np.zeros(p.size, bool)
    edge = np.zeros(p.size, bool)
    for dy, dx in NEIGHBOURS:
        inb = (row + dy >= 0) & (row + dy < h) & (col + dx >= 0) & (col + dx < w)
        n = np.where(inb, p + dy * w + dx, p)
        wd = _wrap(np.subtract(ff[p], ff[n], dtype=np.float32))
        ok = inb & source[n] & (np.abs(wd) < CONTINUITY)
        implied = xf[n[ok]] + wd[ok] * np.float32(period)
        vb.append(group[ok])
        vk.append(np.rint((implied - off) * inv - phi[p[ok]]).astype(np.int64))
        if labels is not None:
            touched |= ok
            edge |= inb & (labels[n] != group + 1)
    vb, vk = np.concatenate(vb), np.concatenate(vk)
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
    dropped = doubt & ~smooth  # no continuity to judge by (an outline, a depth step)
    doubt = doubt & smooth
    idx = np.flatnonzero(doubt)
    if not idx.size:
        return 0, dropped
    shape = x.shape
    ff, xf, phi, af = frac.ravel(), x.reshape(-1), flip.ravel(), alt.ravel()
    kmap = np.zeros(x.size, np.int64)
    kmap[idx] = np.rint((xf[idx] - np.float32(offset)) * np.float32(1.0 / period) - phi[idx]).astype(np.int64)
    source = (valid & ~doubt & smooth).ravel().copy()
    corrected = 0

    def apply(p, k):
        """Move pixels p to their candidate of flip index k; returns the pixels kept."""
        nonlocal corrected
        j = k - kmap[p]
        ok = (j == 0) | (j == af[p])
        fix = p[ok & (j != 0)]
        xf[fix] += j[ok & (j != 0)].astype(np.float32) * np.float32(period)
        corrected += fix.size
        dropped.ravel()[p[~ok]] = True
        source[p[ok]] = True

    # 1. whole bands, voted by their sure neighbours
    import cv2

    if np.abs(_wrap(phi[idx] - phi[idx[0]])).max() < 1e-3:
        # one flip phase (a code of the fringe period): two smooth 4-neighbours always
        # link (their phases differ by less than either's footprint < CONTINUITY)
        n_bands, labels = cv2.connectedComponents(doubt.view(np.uint8), connectivity=4, ltype=cv2.CV_32S)
        band = labels.ravel()[idx].astype(np.int64) - 1
        n_bands -= 1
        del labels
    else:
        n_bands, band = _bands(idx, doubt, ff, phi, kmap, shape, same_k=False)

    # only a band's rim can have a sure neighbour
    near = cv2.dilate(source.reshape(shape).view(np.uint8), np.ones((3, 3), np.uint8)).ravel()[idx] > 0
    k_band, clear = _leading(idx[near], band[near], n_bands, source, xf, ff, phi, period, offset, shape)
    del near
    done = clear[band]
    apply(idx[done], k_band[band[done]])
    # 2. the rest (a band reaching two flip points through a depth step, or none):
    #    its parts the code puts at one flip point, in rounds from sure and settled pixels
    rest = idx[~done]
    if rest.size:
        mask = np.zeros(shape, bool)
        mask.ravel()[rest] = True
        n_parts, part = _bands(rest, mask, ff, phi, kmap, shape, same_k=True)
        labels = np.zeros(x.size, np.int64)
        labels[rest] = part + 1
        todo = np.arange(rest.size)
        for _ in range(rounds):
            if not todo.size:
                break
            k_part, clear = _leading(rest[todo], part[todo], n_parts, source, xf, ff, phi, period, offset, shape,
                                     labels)
            if not clear.any():
                break
            now = clear[part[todo]]
            sel = todo[now]
            apply(rest[sel], k_part[part[sel]])
            todo = todo[~now]
        dropped.ravel()[rest[todo]] = True
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
