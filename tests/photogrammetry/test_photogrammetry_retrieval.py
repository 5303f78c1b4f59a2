"""Ring matching's choice of pairs (photogrammetry.retrieval, issue 29): visual words find a
ring's neighbours from the descriptors alone, the pairs keep the series in one piece, and the
SfM options are refused in one line before any work."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import InputError
from camcmm_plugins.photogrammetry.retrieval import neighbour_pairs, retrieval_pairs, word_vectors
from camcmm_plugins.photogrammetry.sfm import reconstruct_sparse


def _ring_descriptors(n: int, seed: int = 0) -> list[np.ndarray]:
    """n images on a ring: 4n surface patches around it (each a random 128-d SIFT-like
    descriptor), image i sees the 12 patches nearest its place, each with small noise —
    so images share patches only with their neighbours, and share more the nearer they are."""
    rng = np.random.default_rng(seed)
    patches = rng.uniform(0, 120, size=(4 * n, 128))
    out = []
    for i in range(n):
        seen = [(4 * i + d) % (4 * n) for d in range(-6, 6)]
        d = np.repeat(patches[seen], 8, axis=0) + rng.normal(scale=2.0, size=(12 * 8, 128))
        out.append(np.clip(d, 0, 255).astype(np.uint8))
    return out


def test_visual_words_find_a_shuffled_rings_neighbours():
    n = 16
    desc = _ring_descriptors(n)
    order = np.random.default_rng(1).permutation(n)  # the input order says nothing
    pairs = retrieval_pairs([desc[j] for j in order], 2, seed=0)
    place = {k: int(order[k]) for k in range(n)}
    ring_gap = {min(abs(place[i] - place[j]), n - abs(place[i] - place[j])) for i, j in pairs}
    # each image's two most alike are its neighbours either side (gap 1); nothing farther
    assert ring_gap == {1}
    assert len(pairs) == n  # the ring's n edges, each chosen from both ends, listed once
    assert all(i < j for i, j in pairs)


def test_word_vectors_are_unit_tf_idf_and_repeatable():
    desc = _ring_descriptors(8)
    v = word_vectors(desc, words=32, seed=3)
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-12)
    np.testing.assert_array_equal(v, word_vectors(desc, words=32, seed=3))
    # an image without descriptors is similar to none
    v0 = word_vectors([*desc, np.zeros((0, 128), np.uint8)], words=32, seed=3)
    assert not v0[-1].any()


def test_pairs_join_groups_by_their_most_similar_pair():
    # two blocks of 4 images, alike within, barely alike across; 2 and 5 the closest across
    s = np.full((8, 8), 0.01)
    s[:4, :4] = s[4:, 4:] = 0.9
    s[2, 5] = s[5, 2] = 0.05
    pairs = neighbour_pairs(s, 1)
    assert (2, 5) in pairs
    assert all((i < 4) == (j < 4) for i, j in pairs if (i, j) != (2, 5))
    # k >= n - 1: every pair
    assert len(neighbour_pairs(s, 7)) == 28


@pytest.mark.parametrize(
    ("key", "value", "said"),
    [("matching", "random", "matching 'random'"), ("mapper", "glomap", "mapper 'glomap'"), ("overlap", 0, "overlap 0")],
)
def test_sfm_options_refused_in_one_line_before_any_work(key, value, said):
    ims = [np.full((48, 64), 128, np.uint8)] * 3
    with pytest.raises(InputError, match=said) as e:
        reconstruct_sparse(ims, ["a.png", "b.png", "c.png"], **{key: value})
    assert "\n" not in str(e.value)
