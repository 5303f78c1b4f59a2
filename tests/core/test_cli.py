"""The command line as a user calls it: one JSON document with --json, one-line errors."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from camcmm import __version__
from camcmm.io import write
from camcmm.model import PointCloud
from helpers.cli import cli_json, run_camcmm


@pytest.fixture
def cloud_file(tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / "cloud.ply"
    write(PointCloud(rng.uniform(0, 10, (2000, 3)), name="cloud"), path)
    return path


def test_version():
    assert run_camcmm("--version").stdout.strip() == f"camcmm {__version__}"


def test_console_script_runs():
    """The installed ``camcmm`` entry point (the other tests run ``python -m camcmm``)."""
    exe = shutil.which("camcmm", path=str(Path(sys.executable).parent))
    if exe is None:
        pytest.skip("the camcmm entry point is not installed")
    proc = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == f"camcmm {__version__}", proc.stderr


@pytest.mark.slow
def test_plugins_json_lists_builtins_with_kind_version_status():
    doc = cli_json("plugins", "--json")
    by_id = {p["id"]: p for p in doc["plugins"]}
    for pid in ("cloud.downsample", "cloud.denoise", "cloud.normals"):
        assert by_id[pid]["kind"] == "algorithm" and by_id[pid]["status"] == "ok"
        assert by_id[pid]["version"] == __version__  # a plugin's version is its distribution's


@pytest.mark.slow
def test_run_a_plugin_with_declared_parameters(cloud_file, tmp_path):
    out = tmp_path / "down.ply"
    proc = run_camcmm(
        "run",
        "cloud.downsample",
        cloud_file,
        "--voxel-size",
        "2.5",
        "--out",
        out,
        "--project",
        tmp_path / "proj",
        "--json",
    )
    doc = json.loads(proc.stdout)
    assert doc["plugin"] == "cloud.downsample" and doc["params"] == {"voxel_size": 2.5}
    assert 0 < doc["outputs"]["n_points"] < 2000 and doc["result_id"] >= 1
    assert out.exists()
    info = cli_json("info", out, "--json")
    assert info["n_points"] == doc["outputs"]["n_points"]


@pytest.mark.slow
def test_errors_are_one_line_on_stderr_with_nonzero_exit(cloud_file, tmp_path):
    cases = [
        (["run", "cloud.downsample", cloud_file, "--voxel-size", "-1"], "voxel_size"),
        (["run", "cloud.nope", cloud_file], "no plugin with id 'cloud.nope'"),
        (["info", tmp_path / "missing.ply"], "missing.ply"),
        (["run", "cloud.downsample", cloud_file, "--voxl", "1"], "unrecognized arguments"),
    ]
    for args, text in cases:
        proc = run_camcmm(*args, ok=False)
        assert proc.returncode != 0 and proc.stdout == ""
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and text in lines[0], proc.stderr


def _main(capsys, *args):
    """``camcmm ARGS`` in this process: (exit code, stdout, stderr lines)."""
    from camcmm.cli.main import main

    try:
        rc = main([str(a) for a in args])
    except SystemExit as exc:  # --help
        rc = exc.code
    out, err = capsys.readouterr()
    return rc, out, [ln for ln in err.splitlines() if ln.strip()]


def test_run_a_missing_input_file_is_one_line_naming_it(tmp_path, capsys):
    rc, out, err = _main(capsys, "run", "cloud.downsample", tmp_path / "gone.ply", "--voxel-size", "1")
    assert rc == 2 and out == "" and len(err) == 1
    assert "gone.ply" in err[0] and "internal" not in err[0] and "Errno" not in err[0]


def test_run_gives_a_parameter_named_like_its_own_option_as_param_name(tmp_path, capsys):
    """fringe.patterns declares a parameter 'out' (a folder for PNGs); `camcmm run` keeps
    its own --out (write the cloud/mesh output) and takes the parameter as --param-out."""
    seq = tmp_path / "s.yaml"
    seq.write_text("projector: {width: 64, height: 32}\nbit_depth: 8\nframes: [white, black]\n")
    rc, out, err = _main(capsys, "run", "fringe.patterns", "--help")
    assert rc == 0 and "--param-out" in out and "camcmm run's own options" in out
    folder = tmp_path / "pngs"
    rc, out, err = _main(capsys, "run", "fringe.patterns", seq, "--param-out", folder, "--json")
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["params"]["out"] == str(folder)
    assert sorted(p.name for p in folder.iterdir()) == ["pat00.png", "pat01.png"]
    # run's own --out still means "write the first cloud/mesh": fringe.patterns has none
    rc, out, err = _main(capsys, "run", "fringe.patterns", seq, "--out", tmp_path / "x.ply")
    assert rc == 2 and len(err) == 1 and "--param-out" in err[0] and "x.ply" in err[0]
    assert not (tmp_path / "x.ply").exists()


@pytest.mark.slow
def test_demo_creates_a_project(tmp_path):
    doc = cli_json("demo", tmp_path / "demo", "--json")
    assert len(doc["measurements"]) >= 4
    again = cli_json("demo", tmp_path / "demo", "--json")
    assert again["measurements"] == doc["measurements"]  # re-opening does not duplicate


@pytest.mark.parametrize("ext", [".ply", ".pcd", ".xyz", ".txt", ".csv", ".e57", ".stl", ".obj"])
def test_info_json_reads_every_format(tmp_path, ext):
    from camcmm.model import TriangleMesh

    rng = np.random.default_rng(5)
    if ext in (".stl", ".obj"):
        obj = TriangleMesh(rng.uniform(-5, 5, (4, 3)), [[0, 1, 2], [0, 2, 3]])
    else:
        obj = PointCloud(rng.uniform(-5, 5, (300, 3)))
    path = tmp_path / f"thing{ext}"
    write(obj, path)
    doc = cli_json("info", path, "--json")
    assert doc["unit"] == "mm"
    if ext in (".stl", ".obj"):
        assert doc["kind"] == "mesh" and doc["n_faces"] == 2
        lo = obj.vertices.min(axis=0)
    else:
        assert doc["kind"] == "pointcloud" and doc["n_points"] == 300
        lo = obj.points.min(axis=0)
    # float32 formats (binary STL, PCD) keep ~7 significant digits
    assert doc["bbox"]["min"] == pytest.approx(lo.tolist(), abs=1e-5)
