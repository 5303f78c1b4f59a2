"""The shortcuts of the VDI/VDE 2634 evaluation (issue 29) against the plain numpy they
replace: the point-to-sphere assignment, the extent check's span, and the one-BLAS-thread
block around the evaluation pool."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm_plugins.vdi2634 import measure, segment, threads


def _spheres(centres, radius, band):
    return [{"center": c, "radius": radius, "form": {"max": band, "min": -band}} for c in centres]


def test_assign_is_the_nearest_sphere_within_its_band():
    rng = np.random.default_rng(0)
    centres = [[0.0, 0, 0], [30.0, 0, 0], [15.0, 20, 0]]
    u = rng.normal(size=(3000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    pts = np.vstack([np.asarray(c) + (10 + rng.normal(0, 0.05, (1000, 1))) * u[:1000] for c in centres])
    pts = np.vstack([pts, rng.uniform(-20, 50, (500, 3)), [[15.0, 0, 0]]])  # clutter, a point in no band
    sph = _spheres(centres, 10.0, 0.1)
    got = segment.assign(pts, sph)
    # reference: the plain (k, N) distance table and argmin
    d = np.abs(np.linalg.norm(pts[None] - np.asarray(centres)[:, None], axis=2) - 10.0)
    d[d > 1.5 * 0.1] = np.inf
    best, hit = np.argmin(d, axis=0), np.isfinite(d.min(axis=0))
    for k in range(3):
        np.testing.assert_array_equal(got[k], np.flatnonzero(hit & (best == k)))
    assert sum(len(g) for g in got) >= 2990


def test_span_is_numpys_ptp():
    pts = np.random.default_rng(1).normal(size=(5000, 3)) * [1, 100, 1e-3] + [1e4, 0, -5]
    assert measure._span(pts) == np.ptp(pts, axis=0).tolist()


def test_single_blas_thread_sets_and_restores():
    import scipy.linalg  # noqa: F401  (loads SciPy's OpenBLAS too)

    libs = threads._openblas()
    if not libs:
        pytest.skip("no OpenBLAS loaded in this process (not Linux, or another BLAS)")
    before = [get() for _, get in libs]
    with threads.single_blas_thread():
        assert [get() for _, get in libs] == [1] * len(libs)
    assert [get() for _, get in libs] == before
    with threads.single_blas_thread(active=False):
        assert [get() for _, get in libs] == before
