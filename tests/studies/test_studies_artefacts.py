"""The AM test artefacts of ch. 6.2 (virtuallab.am-artefact) and their materials: closed,
outward meshes whose volumes and class areas follow from their sizes by hand; the
textures differ as the thesis describes (issue 18)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from camcmm.api import InputError, default_host
from camcmm_plugins.virtuallab import am_artefacts, materials


def _closed_outward(V, F):
    e = np.sort(F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, cnt = np.unique(e, axis=0, return_counts=True)
    d = F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    consistent = np.unique(d[:, 0] * len(V) + d[:, 1]).size == len(d)
    t = V[F]
    vol = np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6
    return bool(np.all(cnt == 2)), consistent, float(vol)


def test_pyramid_and_recess_volumes_and_areas_follow_from_their_sizes():
    V, F, cls, _ = am_artefacts.build("am_pyramid", {"plate": [40, 4], "steps": [[30, 3], [20, 2]]})
    closed, consistent, vol = _closed_outward(V, F)
    assert closed and consistent
    assert vol == pytest.approx(40 * 40 * 4 + 30 * 30 * 3 + 20 * 20 * 2, rel=1e-9)
    a = am_artefacts.class_areas(V, F, cls)
    assert a["top"] == pytest.approx(1600, rel=1e-9)  # seen from above, the steps cover the plate
    assert a["side"] == pytest.approx(4 * 40 * 4 + 4 * 30 * 3 + 4 * 20 * 2, rel=1e-9)
    assert a["bottom"] == pytest.approx(1600, rel=1e-9)
    V, F, cls, _ = am_artefacts.build("am_recess", {"plate": [30, 8], "recess": [10, 5]})
    closed, consistent, vol = _closed_outward(V, F)
    assert closed and consistent and vol == pytest.approx(30 * 30 * 8 - 10 * 10 * 5, rel=1e-9)
    a = am_artefacts.class_areas(V, F, cls)
    assert a["side"] == pytest.approx(4 * 30 * 8 + 4 * 10 * 5, rel=1e-9)


def test_sphere_and_pillars_approach_their_analytic_volumes():
    R, h, t = 10.0, 6.0, 4.0
    V, F, cls, _ = am_artefacts.build("am_sphere", {"plate": [40, t], "diameter": 2 * R, "centre_height": h})
    closed, consistent, vol = _closed_outward(V, F)
    assert closed and consistent
    cap = math.pi * (R + h) ** 2 * (3 * R - (R + h)) / 3  # the spherical cap above the plate
    # an inscribed polyhedron of 64 x 24 facets: volume short by ~ (π/64)² / 2 ≈ 0.1 %
    assert vol == pytest.approx(40 * 40 * t + cap, rel=2e-3)
    assert am_artefacts.class_areas(V, F, cls)["curved"] == pytest.approx(2 * math.pi * R * (R + h), rel=3e-3)
    pil = [[8, 6], [6, 10], [4, 14], [3, 8]]
    V, F, cls, _ = am_artefacts.build("am_pillars", {"plate": [40, 4], "pillars": pil})
    closed, consistent, vol = _closed_outward(V, F)
    assert closed and consistent
    exact = 40 * 40 * 4 + sum(math.pi * (d / 2) ** 2 * hh for d, hh in pil)
    assert vol == pytest.approx(exact, rel=2e-2)  # 32-gons inscribed: -0.6 % of each pillar


def test_catalogue_plugin_and_bad_sizes():
    out = default_host().run("virtuallab.am-artefact", {}, {"artefact": "am_recess"}).outputs
    assert len(out["face_class"]) == out["mesh"].n_faces
    assert out["face_classes"] == ["top", "side", "curved", "bottom"]
    with pytest.raises(InputError, match="unknown size 'height'"):
        default_host().run("virtuallab.am-artefact", {"sizes": {"height": 3}}, {"artefact": "am_recess"})
    with pytest.raises(InputError, match="centre_height"):
        default_host().run("virtuallab.am-artefact", {"sizes": {"centre_height": 12}}, {"artefact": "am_sphere"})


def test_materials_texture_contrast_orders_as_the_thesis_describes():
    rng = np.random.default_rng(1)
    p = np.column_stack([rng.uniform(-20, 20, 20000), rng.uniform(-20, 20, 20000), np.full(20000, 4.0)])
    n = np.tile([0.0, 0.0, 1.0], (len(p), 1))
    s = {m: float(np.std(materials.get(m).texture(p, n))) for m in materials.NAMES}
    # nylon: little texture; ABS (tracks + deposits) and Ti (random) three times more
    assert s["nylon12"] < 0.06 and min(s["abs"], s["ti6al4v"]) > 0.1
    assert materials.get("nylon12").subsurface_mm > 0 and materials.get("ti6al4v").subsurface_mm == 0
    with pytest.raises(ValueError, match="material 'steel'"):
        materials.get("steel")
