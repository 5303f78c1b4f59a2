"""``camcmm photogrammetry reconstruct``: its options are the declared parameters of the
plugin that provides ``photogrammetry`` (issue 25); the old flags keep their names and
shapes (``--dense`` / ``--sparse-only``), and a bad value is one line naming the option
before any image is read."""

from __future__ import annotations

import pytest

from camcmm.api import declared_values
from camcmm.cli.main import main
from camcmm.cli.parser import Parser
from camcmm.host import default_host
from camcmm_plugins.photogrammetry import cli
from helpers.cli import refused


def _parse(*argv: str):
    p = Parser(prog="camcmm photogrammetry")
    cli.configure(p)
    args = p.parse_args(["reconstruct", "a.png", "b.png", "c.png", *argv])
    return args, declared_values(args, default_host().provider("photogrammetry").parameters)


def test_help_lists_every_declared_parameter(capsys):
    params = default_host().provider("photogrammetry").parameters
    with pytest.raises(SystemExit) as stop:
        main(["photogrammetry", "reconstruct", "--help"])
    assert stop.value.code == 0
    flags = set(capsys.readouterr().out.split())
    assert not [p.name for p in params if "--" + p.name.replace("_", "-") not in flags]
    assert {"--calibration", "--sparse-only", "--out", "--project", "--json"} <= flags


def test_old_flags_parse_to_the_declared_values():
    args, values = _parse(
        *("--scale", "bar:100", "--max-image-size", "800", "--matching", "sequential"),
        *("--camera-model", "OPENCV", "--scheduler", "tcp://h:8786", "--dense-max-image-size", "0"),
        *("--turntable-angles", "step:15", "--turntable-window", "45", "--calibration", "cal.yaml"),
        *("--out", "c.ply", "--project", "p"),
    )
    assert values == {
        "scale": "bar:100",
        "max_image_size": 800,
        "matching": "sequential",
        "camera_model": "OPENCV",
        "scheduler": "tcp://h:8786",
        "dense_max_image_size": 0,
        "turntable_angles": "step:15",
        "turntable_window": 45.0,
    }
    assert args.images == ["a.png", "b.png", "c.png"] and args.calibration == "cal.yaml"
    assert args.out == "c.ply" and args.project == "p"


def test_dense_and_sparse_only_are_one_value():
    assert _parse()[1] == {}  # not given: the declared default (dense) is the plugin's
    assert _parse("--dense")[1] == {"dense": True}
    assert _parse("--sparse-only")[1] == {"dense": False}
    with pytest.raises(SystemExit):  # not both
        _parse("--dense", "--sparse-only")


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["--max-image-size", "10"], "--max-image-size: parameter 'max_image_size' = 10 is below its minimum 64"),
        (["--turntable-window", "nan"], "--turntable-window: parameter 'turntable_window': nan is not finite"),
        (["--camera-model", "FISHEYE"], "--camera-model: parameter 'camera_model': 'FISHEYE' is not a valid choice"),
    ],
)
def test_a_bad_value_is_one_line_naming_the_option(capsys, tmp_path, argv, needle):
    refused(capsys, ["photogrammetry", "reconstruct", tmp_path / "none", *argv], needle)
