"""fusion.csi with the real Zygo/Wyko/Sensofar files as the CSI side (issue 17): the
'photogrammetry' cloud is the map's own points, every second one, scaled by 1.03,
rotated 20° about z and tilted 5°, coloured by the grey image both sides share (the
intensity, or the shaded heights); the CSI map is the central 60 % of the file. The
pipeline must recover the scale and the pose and put the map's points back where they
belong; and the CLI writes nothing on bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from camcmm.api import PointCloud, default_host, read, write
from helpers.fusion_synthetic import FILES, POSE, SCALE, affine, make_case  # noqa: E402

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("name", list(FILES))
def test_real_map_fused_onto_a_cloud_made_from_it(shared_data, name):
    path = shared_data / "csi_height_maps_surfalize" / name
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    cloud, crop = make_case(path, FILES[name])
    o = (
        default_host()
        .run("fusion.csi", {"cloud": cloud, "csi": [crop]}, {"sigma_px": 1.0, "grey": FILES[name]})
        .outputs
    )
    r = o["result"]
    mp = r["maps"][0]
    assert abs(r["photogrammetry_scale"]["value"] / SCALE - 1) < 1e-3
    c = np.array(r["plane"]["point"])
    truth = affine(POSE[:3, :3], (POSE[:3, 3] - c) / SCALE + c)
    err = np.array(mp["transform"]) @ np.linalg.inv(truth)
    ro = POSE[:3, :3].T @ err[:3, :3] @ POSE[:3, :3]
    assert abs(np.degrees(np.arctan2(ro[1, 0], ro[0, 0]))) < 0.05
    assert abs(np.degrees(ro[2, 1])) < 0.01 and abs(np.degrees(ro[0, 2])) < 0.01
    src = o["fused"].fields["source"]
    expect = crop.points() @ truth[:3, :3].T + truth[:3, 3]
    # the map's own points, put back: within 1 µm (its lateral step is 0.3-1.9 µm)
    assert np.abs(o["fused"].points[src == 1] - expect).max() < 0.001
    assert mp["n_inliers_similarity"] >= 8 and mp["icp"]["converged"]


def test_cli_fuses_real_files_and_writes_nothing_on_bad_input(shared_data, tmp_path, capsys):
    from camcmm.cli.main import main

    path = shared_data / "csi_height_maps_surfalize" / "test_2.opd"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    cloud, _ = make_case(path, "auto")
    write(cloud, tmp_path / "photo.ply")
    out, rep = tmp_path / "fused.ply", tmp_path / "report"
    args = ["fuse", "csi", "--cloud", str(tmp_path / "photo.ply"), "--csi", str(path), "--sigma-px", "1"]
    proj = tmp_path / "proj"
    assert main([*args, "--out", str(out), "--report", str(rep), "--project", str(proj), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc) >= {"maps", "photogrammetry_scale", "n_points_fused", "warnings"}
    assert abs(doc["photogrammetry_scale"]["value"] / SCALE - 1) < 1e-3
    fused = read(out)
    assert fused.n_points == doc["n_points_fused"] and set(np.unique(fused.fields["source"])) == {1}
    assert (rep / "report.html").is_file() and (rep / "report.pdf").is_file()
    from camcmm.project import Project

    with Project.open(proj) as project:  # the run recorded with its provenance and the fused cloud
        stored = project.result(doc["result_id"])
        assert stored["plugin"] == "fusion.csi" and "fused" in stored["files"]
    # the same cloud against a map of another file: nothing in common -> exit 2, one line naming the map
    other = shared_data / "csi_height_maps_surfalize" / "test_1.plu"
    out2 = tmp_path / "bad.ply"
    bad = ["fuse", "csi", "--cloud", str(tmp_path / "photo.ply"), "--csi", str(other), "--out", str(out2)]
    assert main([*bad, "--report", str(tmp_path / "rep2"), "--project", str(tmp_path / "proj2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "test_1.plu" in err[0]
    assert not out2.exists() and not (tmp_path / "rep2").exists() and not (tmp_path / "proj2").exists()


def test_cloud_without_colours_matches_by_curvature(shared_data):
    """A cloud without colours and a map without intensity: both drawn by their heights'
    curvature, which a turn or a tilt does not change."""
    path = shared_data / "csi_height_maps_surfalize" / "test_2.opd"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    cloud, crop = make_case(path, "auto")
    bare = PointCloud(cloud.points, name="bare.ply")
    r = default_host().run("fusion.csi", {"cloud": bare, "csi": [crop]}, {"sigma_px": 1.0}).outputs["result"]
    assert abs(r["photogrammetry_scale"]["value"] / SCALE - 1) < 1e-3
