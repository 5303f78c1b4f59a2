"""A newcomer's fusion (issue 30): the sample pair fuses at the declared defaults, a blur
that leaves too few matches is refused naming the blur that gives enough, and a cloud without
colours is matched by relief against a map that has an intensity channel.

References: the sample is the synthetic coin, exact by construction
(plugins/camcmm_plugins/fusion/sample.py): the truth is its scale 1.02 and the poses it was
made with, written by ``camcmm fuse sample`` into coin_truth.json; the suggested blur is
checked by fusing at it.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from camcmm.api import InputError, PointCloud, default_host, write
from camcmm.cli.main import main
from camcmm_plugins.fusion.sample import SAMPLE_SHAPE, SAMPLE_STEP
from helpers.cli import main_json, main_refused
from helpers.fusion_synthetic import csi_map, photo_cloud, truth_in_fused_frame

pytestmark = pytest.mark.slow


def test_the_sample_pair_written_by_the_cli_fuses_at_the_defaults(tmp_path, capfd):
    doc = main_json(capfd, "fuse", "sample", tmp_path / "s", "--json")
    files = doc["sample"]
    assert doc["command"] == f"camcmm fuse csi --cloud {files['cloud']} --csi {files['csi']}"
    truth = json.loads((tmp_path / "s" / "coin_truth.json").read_text())
    r = main_json(capfd, "fuse", "csi", "--cloud", files["cloud"], "--csi", files["csi"], "--json")
    params = default_host().provider("csi-fusion").parameters
    assert r["plugin"]["params"] == {p.name: p.default for p in params}  # the declared defaults, none changed
    mp = r["maps"][0]
    assert mp["n_inliers"] >= 16 and mp["grey"] == "intensity" and r["warnings"] == []  # twice the 8 needed
    assert abs(r["photogrammetry_scale"]["value"] / truth["scale"] - 1) < 1e-3  # 0.1 % of 1.02
    m, a = np.array(truth["pose"]), np.array(truth["map_to_object"])
    expect = truth_in_fused_frame(m, a, truth["scale"], r["plane"]["point"])
    err = np.array(mp["transform"]) @ np.linalg.inv(expect)
    ro = m[:3, :3].T @ err[:3, :3] @ m[:3, :3]  # the error rotation in the coin's axes
    assert abs(np.degrees(np.arctan2(ro[1, 0], ro[0, 0]))) < 0.05
    assert abs(np.degrees(ro[2, 1])) < 0.01 and abs(np.degrees(ro[0, 2])) < 0.01
    # the map's centre lands within a tenth of the cloud's image pixel of where the construction put it
    hm, _ = csi_map(shape=SAMPLE_SHAPE, step=SAMPLE_STEP)
    c = expect @ np.r_[hm.points().mean(axis=0), 1.0]
    shift = (err @ c - c)[:3]
    assert np.linalg.norm(shift - (shift @ m[:3, 2]) * m[:3, 2]) < 0.1 * r["pixel_mm"] / truth["scale"]


def test_a_blur_with_too_few_matches_names_the_one_that_gives_enough():
    """A sparse cloud (0.1 mm apart): blur 6 px is 0.6 mm, which wipes out the 0.4-1.5 mm
    pattern; the refusal must name the blur in the form's words ("blur [px]", the manifest's
    label of sigma_px) and one that fuses."""
    cloud, s, _ = photo_cloud(spacing=0.1)
    hm, _ = csi_map(shape=(240, 320), step=0.016, name="sparse.x3p")
    host = default_host()
    with pytest.raises(InputError) as err:
        host.run("fusion.csi", {"cloud": cloud, "csi": [hm]}, {})
    line = str(err.value)
    assert "\n" not in line and "sigma_px" not in line and line.startswith("sparse.x3p: too few matches")
    found = re.search(
        r"at blur \[px\] = 6 .*; blur \[px\] = ([\d.]+) gives (\d+) consistent matches: set blur \[px\] to \1$", line
    )
    assert found, line
    blur, promised = float(found[1]), int(found[2])
    assert blur != 6 and promised >= 8
    r = host.run("fusion.csi", {"cloud": cloud, "csi": [hm]}, {"sigma_px": blur}).outputs["result"]
    assert r["maps"][0]["n_inliers_similarity"] == promised  # the count promised is the one the run gets
    assert abs(r["photogrammetry_scale"]["value"] / s - 1) < 5e-3


def test_no_blur_that_works_says_what_else_to_check():
    cloud, *_ = photo_cloud(spacing=0.1)
    rng = np.random.default_rng(3)
    hm, _ = csi_map(shape=(120, 160), step=0.016, name="foreign.x3p")
    hm.intensity = rng.random(hm.shape)  # a pattern the cloud does not have
    with pytest.raises(InputError, match=r"^foreign.x3p: .*no blur tried \(0, 1, 2, 4, 6, 8 px\) gives 8") as err:
        default_host().run("fusion.csi", {"cloud": cloud, "csi": [hm]}, {})
    assert "\n" not in str(err.value)


def test_a_colourless_cloud_is_matched_by_relief_against_a_map_with_intensity(tmp_path, capfd):
    """``camcmm fuse csi`` with a cloud without colours and a map with an intensity channel
    (a coin whose pattern is 30 µm of relief): auto draws both by relief and fuses; asking for
    the intensity is refused in one line naming the cloud and what to set."""
    cloud, s, _ = photo_cloud(spacing=0.03, colour=False, relief_mm=0.03)
    hm, _ = csi_map(shape=(240, 320), step=0.016, relief_mm=0.03)
    assert cloud.colors is None and hm.intensity is not None
    write(PointCloud(cloud.points, name="bare"), tmp_path / "bare.ply")
    write(hm, tmp_path / "map.x3p")
    argv = ["fuse", "csi", "--cloud", tmp_path / "bare.ply", "--csi", tmp_path / "map.x3p"]
    r = main_json(capfd, *argv, "--json")
    assert r["maps"][0]["grey"] == "shaded" and r["maps"][0]["n_inliers"] >= 8
    assert abs(r["photogrammetry_scale"]["value"] / s - 1) < 2e-3
    line = main_refused(capfd, *argv, "--grey", "intensity")
    assert "bare.ply: the cloud has no colours" in line and "set grey image of the map to shaded" in line


def test_the_cli_offers_the_plugins_grey_choices(capsys):
    """The options are the manifest's: --grey with its declared choices."""
    grey = next(p for p in default_host().provider("csi-fusion").parameters if p.name == "grey")
    with pytest.raises(SystemExit):
        main(["fuse", "csi", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--grey CHOICE" in text and f"(one of: {', '.join(grey.choices)})" in text
    assert grey.choices == ("auto", "intensity", "shaded")


@pytest.mark.parametrize(
    "asked,trials,blur",
    [
        (6.0, {0.0: 2, 1.0: 157, 2.0: 77, 4.0: 4, 8.0: 0}, 2),  # the real Zygo case: nearest 6 with a margin
        (6.0, {0.0: 17, 1.0: 20, 2.0: 9, 4.0: 0, 8.0: 0}, 1),  # 2 px has too thin a margin (9 of 8)
        (30.0, {0.0: 107, 1.0: 102, 2.0: 84, 4.0: 47, 8.0: 21}, 8),
        (6.0, {0.0: 9, 1.0: 12, 2.0: 3, 4.0: 0, 8.0: 0}, 1),  # none with a margin: the most
    ],
)
def test_the_blur_suggested_is_the_nearest_with_a_margin(asked, trials, blur):
    from camcmm_plugins.fusion.pipeline import too_few

    cloud, *_ = photo_cloud(spacing=0.5, half=2.0)
    line = too_few("m.x3p", 3, 0, 8, asked, trials, lambda k: {"sigma_px": "blur [px]"}.get(k, k), cloud, None, None)
    assert line.endswith(f"blur [px] = {blur} gives {trials[blur]} consistent matches: set blur [px] to {blur}")
    assert line.startswith(
        f"m.x3p: too few matches with the cloud at blur [px] = {asked:g} (3 SIFT matches, 0 consistent"
    )


def test_an_icp_that_does_not_converge_is_a_warning_in_words():
    host = default_host()
    pair = host.run("fusion.sample", {}, {}).outputs
    res = host.run("fusion.csi", {"cloud": pair["cloud"], "csi": [pair["csi"]]}, {"icp_iterations": 1})
    assert res.warnings == [
        "coin_csi.x3p: the 3-DOF ICP did not converge in 1 iterations (raise ICP iterations, or ICP farthest "
        "pair [mm] when the map starts far off)"
    ]
