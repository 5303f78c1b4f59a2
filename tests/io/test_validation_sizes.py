"""Sizes and counts read from files are refused in one line before the work starts.

Each case goes through its CLI command in this process: exit code non-zero, exactly one
line on stderr naming the value, no traceback, no internal error. None of them
allocates what it asks for: the estimate refuses first (a projector of 200000² px would
be 37 GB per pattern, a 3000³ grid 27e9 points), and the cases that do write check that
nothing was written.
"""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from camcmm import limits
from camcmm.api import ParameterError
from camcmm.cli.main import main
from helpers.cli import refused

ROOT = Path(__file__).resolve().parents[2]


# ---------------------------------------------------------------- the helper itself
def test_check_budget_names_the_value_and_the_limit(monkeypatch):
    monkeypatch.setenv("CAMCMM_MAX_MEMORY_MB", "1024")
    assert limits.memory_limit() == 1024 << 20
    limits.check_budget("small", 1023 << 20)  # below: silent
    with pytest.raises(ParameterError) as e:
        limits.check_budget("seq.yaml: projector 200000 x 200000 px", 200000.0**2)
    assert str(e.value) == (
        "seq.yaml: projector 200000 x 200000 px needs ~40 GB of memory; the limit is 1.07 GB (CAMCMM_MAX_MEMORY_MB)"
    )
    with pytest.raises(ParameterError, match="the limit is 10 B$"):
        limits.check_budget("x", 11, limit=10)


def test_default_memory_limit_is_at_most_8_gib(monkeypatch):
    monkeypatch.delenv("CAMCMM_MAX_MEMORY_MB", raising=False)
    assert 0 < limits.memory_limit() <= 8 << 30


@pytest.mark.parametrize("value", ["abc", "0", "-5", "nan"])
def test_a_bad_memory_setting_is_one_line(monkeypatch, value):
    monkeypatch.setenv("CAMCMM_MAX_MEMORY_MB", value)
    with pytest.raises(ParameterError, match="CAMCMM_MAX_MEMORY_MB"):
        limits.memory_limit()


def test_check_disk_and_count(tmp_path, monkeypatch):
    monkeypatch.delenv("CAMCMM_MAX_DISK_MB", raising=False)
    limits.check_disk("a frame", 1000, tmp_path / "not" / "yet")  # its parent is asked
    with pytest.raises(ParameterError, match=r"needs ~1[ \d]* PB on disk; only .* free"):
        limits.check_disk("everything", 1e21, tmp_path)
    monkeypatch.setenv("CAMCMM_MAX_DISK_MB", "1")
    with pytest.raises(ParameterError, match="CAMCMM_MAX_DISK_MB"):
        limits.check_disk("frames", 2 << 20, tmp_path)
    limits.check_count("n", 5, 5)
    with pytest.raises(ParameterError, match="^frames = 10000000 is more than the limit of 4096$"):
        limits.check_count("frames", 10_000_000, 4096)


# ---------------------------------------------------------------- fringe sequences
def _seq(tmp_path, projector=(64, 32), frames=("white",)) -> Path:
    p = tmp_path / "seq.yaml"
    p.write_text(yaml.safe_dump({"projector": {"width": projector[0], "height": projector[1]}, "frames": list(frames)}))
    return p


@pytest.mark.parametrize(
    "projector,frames,needle",
    [
        ((200000, 200000), ["white"], "seq.yaml: projector.width = 200000 is more than the limit of 16384"),
        ((64, 10**9), ["white"], "seq.yaml: projector.height = 1000000000"),
        ((64, 32), [{"type": "ignore", "count": 10_000_000}], "seq.yaml: frames[0]: count = 10000000"),
        (
            (64, 32),
            [{"type": "phase", "direction": "vertical", "steps": 10**12, "period": 16}],
            "seq.yaml: frames[0]: steps = 1000000000000",
        ),
        ((64, 32), ["white"] * 4000 + [{"type": "black", "count": 100}], "frames[4000]: count = 100"),
    ],
)
def test_fringe_patterns_refuses_sizes_before_writing(tmp_path, capsys, projector, frames, needle):
    out = tmp_path / "out"
    refused(capsys, ["fringe", "patterns", _seq(tmp_path, projector, frames), "--out", out], needle)
    assert not out.exists()  # not one PNG written


def test_fringe_one_pattern_over_the_memory_limit(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("CAMCMM_MAX_MEMORY_MB", "1")
    refused(
        capsys,
        ["fringe", "patterns", _seq(tmp_path, (1024, 1024)), "--out", tmp_path / "out"],
        "seq.yaml: projector 1024 x 1024 px needs ~8.39 MB of memory; the limit is 1.05 MB",
    )


def test_fringe_all_patterns_over_the_memory_limit(tmp_path, monkeypatch):
    from camcmm_plugins.fringe.patterns import generate_patterns

    monkeypatch.setenv("CAMCMM_MAX_MEMORY_MB", "100")  # one frame of 8 MB passes, 4000 frames not
    seq = _seq(tmp_path, (1024, 1024), [{"type": "ignore", "count": 4000}])
    with pytest.raises(ParameterError, match=r"seq.yaml: 4000 frames of 1024 x 1024 px \(uint8\) needs ~4.19 GB"):
        generate_patterns(seq)
    assert generate_patterns(_seq(tmp_path, (16, 8), ["white", "black"])).shape == (2, 8, 16)


def test_fringe_export_over_the_disk_limit(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("CAMCMM_MAX_DISK_MB", "0.001")
    out = tmp_path / "out"
    refused(
        capsys,
        ["fringe", "patterns", _seq(tmp_path, (64, 32), ["white", "black"]), "--out", out],
        "seq.yaml: 2 PNG frames needs ~8.19 kB on disk; the limit is 1.05 kB (CAMCMM_MAX_DISK_MB)",
    )
    assert not out.exists()


# ---------------------------------------------------------------- Monte Carlo
@pytest.fixture
def mc_file(tmp_path):
    base = yaml.safe_load((ROOT / "resources" / "uncertainty" / "stereo_system.yaml").read_text())
    path = tmp_path / "mc.yaml"

    def make(**changes):
        doc = copy.deepcopy(base)
        for key, value in changes.items():
            if key.startswith("camera1_"):
                doc["cameras"][0][key[len("camera1_") :]] = value
            elif key.startswith("grid_"):
                doc["grid"][key[len("grid_") :]] = value
            else:
                doc[key] = value
        path.write_text(yaml.safe_dump(doc))
        return path

    return make


@pytest.mark.parametrize(
    "changes,args,needle",
    [
        # the command line through the plugin's declaration, the file against the same limits
        (
            {},
            ["--iterations", str(10**12)],
            "--iterations: parameter 'iterations' = 1000000000000 is above its maximum",
        ),
        ({"iterations": 10**12}, [], "mc.yaml: iterations = 1000000000000 must lie in 2 .. 100000000"),
        ({}, ["--seed", "-1"], "--seed: parameter 'seed' = -1 is below its minimum 0"),
        ({"seed": -1}, ["--iterations", "10"], "mc.yaml: seed = -1 must lie in 0 .. 4294967295"),
        ({"seed": 1.5}, ["--iterations", "10"], "mc.yaml: seed = 1.5 is not a whole number"),
        (
            {"grid_n": [3000, 3000, 3000]},
            ["--iterations", "10"],
            "mc.yaml: grid.n [3000, 3000, 3000] makes 27000000000 points; the limit is 1000000",
        ),
        ({"camera1_image_size": [0, 0]}, ["--iterations", "10"], "mc.yaml: camera 1: image_size [0, 0]"),
        ({"camera1_pixel_pitch": 0}, ["--iterations", "10"], "mc.yaml: camera 1: pixel_pitch = 0"),
        ({"chunk": 10**9}, ["--iterations", "10"], "mc.yaml: chunk = 1000000000 must lie in 1 .. 100000000"),
        (
            {"iterations": 10**8},
            [],
            "mc.yaml: Monte Carlo of 100000000 iterations x 1000 grid points (chunk 250) needs ~",
        ),
        ({"spatial": {"n": 10**9}, "studies": ["spatial"]}, ["--iterations", "10"], "mc.yaml: spatial.n = 1000000000"),
        # wrong types and magnitudes
        ({"grid": "abc"}, ["--iterations", "10"], "mc.yaml: grid: expected a mapping, got 'abc'"),
        ({"dof": 3}, ["--iterations", "10"], "mc.yaml: dof: expected a mapping"),
        ({"grid_size": [60, "abc", 40]}, ["--iterations", "10"], "mc.yaml: grid.size: expected 3 finite numbers"),
        ({"grid_size": [60, 0, 40]}, ["--iterations", "10"], "puts several points at one place"),
        (
            {"stereo": {"baseline": "abc"}},
            ["--iterations", "10"],
            "mc.yaml: stereo.baseline: expected 1 finite numbers",
        ),
        (
            {"stereo": {"R": [[1, 0, 0], [0, 1, 0], [0, 0, 2]], "T": [-200, 0, 0]}},
            ["--iterations", "10"],
            "mc.yaml: stereo.R is not a rotation matrix",
        ),
        ({"camera1_k": 0.1}, ["--iterations", "10"], "mc.yaml: camera 1: intrinsics must be numbers"),
        (
            {"uncertainties": {"radial_distortion": [0, 1e308, 0]}},
            ["--iterations", "10"],
            "mc.yaml: the model gives non-finite errors for radial_distortion",
        ),
    ],
)
def test_montecarlo_refuses_before_any_trial(mc_file, capsys, changes, args, needle):
    refused(capsys, ["uncertainty", "montecarlo", mc_file(**changes), *args], needle)


def test_montecarlo_memory_estimate(mc_file, capsys, monkeypatch):
    # 1000 points x 250 trials x 400 B = 100 MB for one chunk
    monkeypatch.setenv("CAMCMM_MAX_MEMORY_MB", "50")
    refused(
        capsys,
        ["uncertainty", "montecarlo", mc_file(), "--iterations", "1000"],
        "mc.yaml: Monte Carlo of 1000 iterations x 1000 grid points (chunk 250) needs ~",
    )
    monkeypatch.setenv("CAMCMM_MAX_MEMORY_MB", "200")  # the same study fits in 200 MB
    assert main(["uncertainty", "montecarlo", str(mc_file(grid_n=[3, 3, 3])), "--iterations", "20"]) == 0


# ---------------------------------------------------------------- MemoryError at the boundary
def test_a_memory_error_is_one_line(tmp_path, capsys, monkeypatch):
    from camcmm_plugins.fringe import sequence

    def boom(source):  # what numpy raises when an allocation fails
        raise MemoryError("Unable to allocate 37.3 GiB for an array with shape (200000, 200000)")

    monkeypatch.setattr(sequence, "load_sequence", boom)
    line = refused(capsys, ["fringe", "patterns", _seq(tmp_path), "--out", tmp_path / "o"], "out of memory")
    assert "37.3 GiB" in line
