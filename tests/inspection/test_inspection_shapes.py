"""Checks of the exact-by-construction test solids of helpers/shapes.py."""

from __future__ import annotations

import numpy as np

from helpers.shapes import Polycube, box_mesh, l_block


def test_box_mesh_is_closed_and_outward():
    V, F = box_mesh([0, 0, 0], [2, 3, 4], 3)
    tri = V[F]
    cr = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.isclose(0.5 * np.linalg.norm(cr, axis=1).sum(), 2 * (6 + 8 + 12))
    # divergence theorem: signed volume of an outward surface is the box volume
    assert np.isclose(np.einsum("ij,ij->i", tri[:, 0], cr).sum() / 6, 24.0)


def test_polycube_mesh_matches_its_rectangles():
    pc = Polycube(l_block(), 10.0, 2)
    tri = pc.vertices[pc.faces]
    cr = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.isclose(0.5 * np.linalg.norm(cr, axis=1).sum(), pc.area)
    assert np.isclose(np.einsum("ij,ij->i", tri[:, 0], cr).sum() / 6, l_block().sum() * 1000.0)
    # the exact sdf: a cell centre is inside by half a cell or more, a far point outside
    c = (np.argwhere(l_block())[0] + 0.5) * 10.0
    assert pc.sdf(c[None])[0] <= -5.0 + 1e-12
    assert np.isclose(pc.sdf(np.array([[-3.0, 5.0, 5.0]]))[0], 3.0)
