"""The chordal error of a tessellated sphere (inspection plugin, chordal.py): the largest
facet sagitta from the circumradius formula against a dense sampling of every facet, and
None where the vertices do not lie on one sphere."""

from __future__ import annotations

import numpy as np

from camcmm.api import TriangleMesh
from camcmm.demo import _icosphere
from camcmm_plugins.inspection.chordal import chordal_error
from helpers.shapes import box_mesh


def sampled_sagitta(mesh: TriangleMesh, c: np.ndarray, R: float, k: int = 40) -> float:
    """max over a barycentric grid of k² points per facet of R - |x - c|."""
    i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
    keep = i + j <= k
    b = np.column_stack([i[keep], j[keep], k - i[keep] - j[keep]]) / k
    tri = mesh.vertices[mesh.faces]
    pts = np.einsum("bc,tcx->tbx", b, tri)
    return float((R - np.linalg.norm(pts - c, axis=2)).max())


def test_the_icospheres_chordal_error_is_its_largest_facet_sagitta():
    for sub, radius in ((1, 10.0), (4, 10.0), (2, 3.5)):
        mesh = _icosphere(radius, sub)
        mesh = TriangleMesh(mesh.vertices + [5.0, -2.0, 40.0], mesh.faces)  # off the origin
        chord = chordal_error(mesh)
        assert chord is not None and chord["surface"] == "sphere"
        np.testing.assert_allclose(chord["centre"], [5.0, -2.0, 40.0], atol=1e-9)
        sampled = sampled_sagitta(mesh, np.asarray(chord["centre"]), chord["radius"])
        assert sampled <= chord["error"] + 1e-12 and chord["error"] - sampled < 0.01 * chord["error"], (sub, sampled)
    assert abs(chordal_error(_icosphere(10.0, 4))["error"] - 0.011379) < 1e-6  # the demo's nominal


def test_a_mesh_off_any_sphere_has_no_known_chordal_error():
    v, f = box_mesh([0, 0, 0], [60, 40, 20])
    assert chordal_error(TriangleMesh(v, f)) is None
    bumpy = _icosphere(10.0, 2)
    V = bumpy.vertices.copy()
    V[0] *= 1.001  # one vertex 10 µm off the sphere
    assert chordal_error(TriangleMesh(V, bumpy.faces)) is None
