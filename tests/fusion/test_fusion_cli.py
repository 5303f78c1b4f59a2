"""``camcmm fuse csi``: its options are the declared parameters of the plugin that provides
``csi-fusion`` (issue 25), the old flags keep their meaning, a bad value is one line naming
the option before any file is read, and the new options reach the plugin."""

from __future__ import annotations

import json

import pytest

from camcmm.api import declared_values, write
from camcmm.cli.main import main
from camcmm.cli.parser import Parser
from camcmm.host import default_host
from camcmm_plugins.fusion import cli
from helpers.cli import refused
from helpers.fusion_synthetic import csi_map, photo_cloud


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def test_help_lists_every_declared_parameter(capsys):
    params = default_host().provider("csi-fusion").parameters
    with pytest.raises(SystemExit) as stop:
        main(["fuse", "csi", "--help"])
    assert stop.value.code == 0
    flags = set(capsys.readouterr().out.split())
    assert not [p.name for p in params if _flag(p.name) not in flags]
    assert {"--cloud", "--csi", "--datum", "--out", "--report", "--project", "--json"} <= flags


def test_old_and_new_flags_parse_to_the_declared_values():
    p = Parser(prog="camcmm fuse")
    cli.configure(p)
    argv = ["csi", "--cloud", "a.ply", "--csi", "m1.x3p", "--csi", "m2.x3p", "--datum", "d.json"]
    argv += ["--sigma-px", "2", "--reject", "fundamental", "--grid", "256", "--seed", "4"]  # the flags of before
    argv += ["--grey", "shaded", "--ransac-px", "2.5", "--min-inliers", "12", "--ratio", "0.7"]
    argv += ["--icp-iterations", "20", "--icp-max-distance", "0.1", "--icp-points", "5000", "--max-points", "9000"]
    args = p.parse_args(argv)
    assert args.csi == ["m1.x3p", "m2.x3p"] and args.datum == "d.json"
    assert declared_values(args, default_host().provider("csi-fusion").parameters) == {
        "sigma_px": 2.0,
        "reject": "fundamental",
        "grid": 256,
        "seed": 4,
        "grey": "shaded",
        "ransac_px": 2.5,
        "min_inliers": 12,
        "ratio": 0.7,
        "icp_iterations": 20,
        "icp_max_distance": 0.1,
        "icp_points": 5000,
        "max_points": 9000,
    }


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["--ratio", "2"], "--ratio: parameter 'ratio' = 2.0 is above its maximum 1"),
        (["--sigma-px", "nan"], "--sigma-px: parameter 'sigma_px': nan is not finite"),
        (["--min-inliers", "2"], "--min-inliers: parameter 'min_inliers' = 2 is below its minimum 3"),
        (["--grey", "colour"], "--grey: parameter 'grey': 'colour' is not a valid choice"),
    ],
)
def test_a_bad_value_is_one_line_naming_the_option(capsys, tmp_path, argv, needle):
    refused(capsys, ["fuse", "csi", "--cloud", tmp_path / "none.ply", "--csi", tmp_path / "none.x3p", *argv], needle)


@pytest.mark.slow
def test_new_options_reach_the_plugin(tmp_path, capsys):
    cloud, *_ = photo_cloud()
    hm, _ = csi_map()
    write(cloud, tmp_path / "photo.ply")
    write(hm, tmp_path / "map.x3p")
    argv = ["fuse", "csi", "--cloud", str(tmp_path / "photo.ply"), "--csi", str(tmp_path / "map.x3p")]
    assert main([*argv, "--icp-iterations", "30", "--ratio", "0.75", "--min-inliers", "10", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    plugin = doc["plugin"]
    assert plugin["id"] == "fusion.csi" and set(plugin["input_hashes"]) == {"cloud", "csi"}
    assert plugin["params"]["icp_iterations"] == 30 and plugin["params"]["ratio"] == 0.75
    assert plugin["params"]["min_inliers"] == 10 and plugin["params"]["sigma_px"] == 6.0  # the declared default
    assert doc["maps"][0]["icp"]["iterations"] <= 30 and doc["maps"][0]["n_inliers"] >= 10
