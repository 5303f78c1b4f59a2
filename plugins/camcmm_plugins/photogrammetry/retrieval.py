"""Which image pairs to match: a series' neighbours found from its own SIFT features.

Exhaustive matching tries all n(n-1)/2 pairs; on a turntable ring or a walk around an object
an image shares features only with its neighbours (templeRing: views more than ~45 deg apart
rarely pass verification). The neighbours are found here without any order or angle given,
by image retrieval with visual words (Sivic & Zisserman 2003, "Video Google"; COLMAP's
vocabulary-tree matching, Schönberger et al. 2016, does the same with a pre-trained tree):

1. a vocabulary of ``words`` visual words: k-means (``cv2.kmeans``, k-means++ start, fixed
   seed) on up to ``sample`` descriptors of each image (fewer in a long series: at most
   :data:`MAX_POOL` in all);
2. each image a histogram of its descriptors' nearest words, weighted by the inverse document
   frequency idf_w = ln(n / n_w) (n_w images hold word w) and scaled to unit length;
3. the similarity of two images is the cosine of their vectors; each image is paired with
   its ``k`` most similar images (the pair kept whichever side chose it);
4. should those pairs leave the series in several groups, the most similar pair between two
   groups is added until one group remains (Kruskal, a maximum spanning forest over groups),
   so the mapper is never handed a series cut apart by the choice of pairs alone.

Measured on templeRing (47 views, 640x480): with k = 8 every view's chosen partners lie
within ~40 deg of it on the ring except a handful, and the pairs are 25-30 % of all pairs.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: visual words of the vocabulary (enough to tell views 10 deg apart on a 47-view ring)
DEFAULT_WORDS = 512
#: descriptors per image sampled for the vocabulary (k-means cost grows with their number)
DEFAULT_SAMPLE = 400
#: at most this many sampled in all (fewer per image in a long series): k-means on 300 views x
#: 400 took 18 s under load 5 — as long as matching their neighbours
MAX_POOL = 50_000


def word_vectors(
    descriptors: Sequence[np.ndarray], *, words: int = DEFAULT_WORDS, sample: int = DEFAULT_SAMPLE, seed: int = 0
) -> np.ndarray:
    """Unit tf-idf vectors (n, words') of the images' visual words (steps 1-2 above).

    ``descriptors``: per image an (m_i, d) array (SIFT: d = 128, any numeric type). Images
    without descriptors get a zero vector (similar to none). ``words'`` = min(words, number
    of sampled descriptors).
    """
    import cv2

    rng = np.random.default_rng(seed)
    arrays = [np.asarray(d, dtype=np.float32) for d in descriptors]
    desc = [a.reshape(len(a), -1) if a.size else np.zeros((0, 1), np.float32) for a in arrays]
    each = max(1, min(sample, MAX_POOL // max(1, len(desc))))
    picked = [d[rng.choice(len(d), min(len(d), each), replace=False)] for d in desc if len(d)]
    if not picked:
        return np.zeros((len(desc), 1))
    pool = np.concatenate(picked)
    k = int(min(words, len(pool)))
    cv2.setRNGSeed(int(seed))
    crit = (cv2.TERM_CRITERIA_MAX_ITER + cv2.TERM_CRITERIA_EPS, 8, 1e-3)
    labels = np.zeros((len(pool), 1), np.int32)  # unused as a start: KMEANS_PP_CENTERS picks its own
    _, _, found = cv2.kmeans(pool, k, labels, crit, 1, cv2.KMEANS_PP_CENTERS)
    centres = np.asarray(found, dtype=np.float32)
    c2 = (centres**2).sum(1)
    hist = np.zeros((len(desc), k))
    for i, d in enumerate(desc):
        if len(d):
            # nearest word by |d - c|^2 = |d|^2 - 2 d.c + |c|^2 (|d|^2 is the same for all c)
            hist[i] = np.bincount(np.argmin(c2[None, :] - 2.0 * d @ centres.T, axis=1), minlength=k)
    idf = np.log(len(desc) / np.maximum((hist > 0).sum(0), 1))
    v = hist * idf
    norm = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 0)


def _groups(n: int, pairs: set[tuple[int, int]]) -> np.ndarray:
    """Group label of each of n images linked by ``pairs`` (union-find)."""
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in pairs:
        parent[root(i)] = root(j)
    return np.array([root(i) for i in range(n)])


def neighbour_pairs(similarity: np.ndarray, k: int) -> list[tuple[int, int]]:
    """Pairs (i < j) of each image with its ``k`` most similar others, joined into one group
    by the most similar pairs between groups (steps 3-4 above). ``similarity``: (n, n),
    symmetric; ``k`` >= n - 1 gives every pair."""
    s = np.array(similarity, dtype=np.float64)
    n = len(s)
    if k >= n - 1:
        return [(i, j) for i in range(n) for j in range(i + 1, n)]
    np.fill_diagonal(s, -np.inf)
    chosen: set[tuple[int, int]] = set()
    for i in range(n):
        # a stable sort: ties (e.g. all-zero vectors) keep index order, repeatably
        for j in np.argsort(-s[i], kind="stable")[:k]:
            chosen.add((min(i, int(j)), max(i, int(j))))
    g = _groups(n, chosen)
    while len(set(g.tolist())) > 1:
        cross = np.where(g[:, None] != g[None, :], s, -np.inf)
        a, b = (int(x) for x in np.unravel_index(int(np.argmax(cross)), cross.shape))
        chosen.add((min(a, b), max(a, b)))
        g = _groups(n, chosen)
    return sorted(chosen)


def retrieval_pairs(descriptors: Sequence[np.ndarray], k: int, *, seed: int = 0) -> list[tuple[int, int]]:
    """The pairs to match of a series: each image with its ``k`` most alike (visual words),
    the series kept in one group. See the module docstring."""
    v = word_vectors(descriptors, seed=seed)
    return neighbour_pairs(v @ v.T, k)
