"""fusion.csi on exact-by-construction data (issue 17, thesis ch. 6.1): a coin-like relief
sampled as a coloured photogrammetry cloud 2 % too large and as a CSI map with a known
rotation, shift and tilt; the pipeline must recover them."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import HeightMap, InputError, default_host
from helpers.fusion_synthetic import affine, csi_map, photo_cloud  # noqa: E402

# One xdist work unit: the tests share the synthetic height maps and their fusion (module
# fixtures), built once per run instead of once per worker (under --dist loadgroup an ungrouped
# test is scheduled alone).
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("fusion-synthetic")]


@pytest.fixture(scope="module")
def data():
    cloud, s, m = photo_cloud()
    hm, a = csi_map()
    return cloud, s, m, hm, a


@pytest.fixture(scope="module")
def fused(data):
    cloud, *_, hm, _a = data
    return default_host().run("fusion.csi", {"cloud": cloud, "csi": [hm]}, {}).outputs


def test_recovers_scale_rotation_shift_tilt(data, fused):
    cloud, s, m, hm, a = data
    r = fused["result"]
    mp = r["maps"][0]
    assert set(mp) >= {"file", "n_matches", "n_inliers", "transform2d", "icp", "difference", "material_ratio"}
    assert mp["n_inliers_similarity"] >= 8 and mp["n_inliers_fundamental"] >= 8
    assert abs(r["photogrammetry_scale"]["value"] / s - 1) < 1e-3  # 0.1 %
    c = np.array(r["plane"]["point"])
    # the truth: map -> object (a) -> cloud (s M) -> fused frame (scaled by 1/s about c)
    truth = affine(m[:3, :3] @ a[:3, :3], (s * (m[:3, :3] @ a[:3, 3]) + m[:3, 3] - c) / s + c)
    err = np.array(mp["transform"]) @ np.linalg.inv(truth)
    ro = m[:3, :3].T @ err[:3, :3] @ m[:3, :3]  # the error rotation in the object's axes
    assert abs(np.degrees(np.arctan2(ro[1, 0], ro[0, 0]))) < 0.05
    assert abs(np.degrees(ro[2, 1])) < 0.01 and abs(np.degrees(ro[0, 2])) < 0.01
    centre = truth @ np.r_[hm.points().mean(axis=0), 1.0]
    shift = (err @ centre - centre)[:3]
    in_plane = shift - (shift @ m[:3, 2]) * m[:3, 2]
    assert np.linalg.norm(in_plane) < 0.1 * r["pixel_mm"] / s  # 0.1 px of the cloud's image
    assert mp["icp"]["converged"]


def test_fused_cloud_equals_truth_under_the_map(data, fused):
    cloud, s, m, hm, a = data
    r, f = fused["result"], fused["fused"]
    src = f.fields["source"]
    c = np.array(r["plane"]["point"])
    truth = affine(m[:3, :3] @ a[:3, :3], (s * (m[:3, :3] @ a[:3, 3]) + m[:3, 3] - c) / s + c)
    expect = hm.points() @ truth[:3, :3].T + truth[:3, 3]
    # 0.1 % of scale over the 6 mm map and 0.01° of tilt: ~ 1 µm
    assert np.abs(f.points[src == 1] - expect).max() < 0.002
    # no photogrammetry point left under the map (away from its border by one cloud spacing)
    photo = f.points[src == 0]
    obj = ((photo - c) * s + c - m[:3, 3]) @ m[:3, :3]  # back to the object frame
    local = (obj - a[:3, 3]) @ a[:3, :3]
    w, h = hm.size_mm
    inside = (local[:, 0] > 0.03) & (local[:, 0] < w - 0.04) & (local[:, 1] > 0.03) & (local[:, 1] < h - 0.04)
    assert not inside.any()
    assert r["n_points_fused"] == f.n_points == int((src == 0).sum() + (src == 1).sum())
    d = r["maps"][0]["difference"]
    assert abs(d["mean"]) < 0.001 and d["p2_5"] < 0 < d["p97_5"]  # the µm texture the cloud cannot see
    assert r["maps"][0]["material_ratio"]["Sk"] is not None


def test_views_for_the_gui(fused):
    v = fused["views"]["maps"][0]
    assert np.asarray(v["photo_image"]).ndim == 2 and np.asarray(v["csi_image"]).ndim == 2
    assert len(v["matches"]["photo"]) == len(v["matches"]["csi"]) >= 8
    assert len(v["footprint"]) == 4 and sum(v["histogram"]["counts"]) > 0


def test_no_overlap_is_refused_naming_the_map(data):
    cloud, *_ = data
    hm, _ = csi_map(centre=(30.0, 30.0), shape=(240, 320), step=0.016, name="far_away.dat")
    with pytest.raises(InputError, match="far_away.dat"):
        default_host().run("fusion.csi", {"cloud": cloud, "csi": [hm]}, {})


def test_wrong_unit_is_refused_naming_the_map(data):
    cloud, *_ = data
    hm, _ = csi_map(shape=(240, 320), step=0.016)
    wrong = HeightMap(hm.heights * 1000, hm.dx * 1000, hm.dy * 1000, intensity=hm.intensity, name="in_um.dat")
    with pytest.raises(InputError, match="in_um.dat.*unit"):
        default_host().run("fusion.csi", {"cloud": cloud, "csi": [wrong]}, {})


def test_two_maps_one_mean_scale_thesis_rejection_and_datum(data):
    cloud, s, m, _hm, _a = data
    maps = [
        csi_map(theta_deg=-40.0, centre=(-2.0, 1.5), shape=(240, 320), step=0.016, name="left")[0],
        csi_map(theta_deg=70.0, tilt_deg=(-0.1, 0.25), centre=(2.0, 2.0), shape=(240, 320), step=0.016, name="right")[
            0
        ],
    ]
    # the datum: the coin's base plane seen from its relief's side (so only that side is tried)
    datum = {"point": m[:3, 3].tolist(), "normal": m[:3, 2].tolist()}
    o = (
        default_host()
        .run("fusion.csi", {"cloud": cloud, "csi": maps, "datum": datum}, {"reject": "fundamental"})
        .outputs
    )
    r = o["result"]
    assert [mp["file"] for mp in r["maps"]] == ["left", "right"]
    sc = r["photogrammetry_scale"]
    assert abs(sc["value"] / s - 1) < 1e-3 and sc["std"] is not None and sc["std"] < 1e-3
    assert all(mp["n_inliers"] <= mp["n_inliers_fundamental"] for mp in r["maps"])
    assert set(np.unique(o["fused"].fields["source"])) == {0, 1, 2}
