"""camcmm as a wheel: a non-editable install carries its resources and plugin manifests.

The wheel is built offline from a copy of the sources (no build isolation: setuptools and
wheel come from the test environment) and installed with ``pip install --no-deps --target``.
The installed copy is then imported by a Python started with ``-S``: no site-packages
``.pth`` file runs, so the checkout's editable camcmm stays hidden, and the dependencies are
reached by putting the environment's site-packages on ``PYTHONPATH`` after the install.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

# One xdist work unit: the tests share the wheel and its installed copy (module fixtures), built
# once per run instead of once per worker (under --dist loadgroup an ungrouped test is scheduled
# alone).
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("packaging")]

ROOT = Path(__file__).resolve().parents[2]
SOURCES = ["app", "plugins", "resources", "pyproject.toml", "setup.py", "README.md"]

# Run inside the installed copy: where camcmm, its resources and its plugins come from.
PROBE = """
import json
import yaml
import camcmm, camcmm_plugins
from camcmm.assets import resources_dir
from camcmm.host import PluginHost
res = resources_dir()
catalogue = yaml.safe_load((res / "artefacts.yaml").read_text())
builtins = {s.id: s.status for s in PluginHost().check() if s.distribution == "camcmm"}  # check: imports each
print(json.dumps({"camcmm": camcmm.__file__, "plugins": list(camcmm_plugins.__path__), "resources": str(res),
                  "catalogue": catalogue, "builtins": builtins}))
"""


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built from a copy of the checkout's sources (a copy, so no stale build/ of
    the shared tree leaks into it)."""
    src = tmp_path_factory.mktemp("src")
    for name in SOURCES:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        else:
            shutil.copy2(path, src / name)
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "--no-index",
            "-q",
            str(src),
            "-w",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    (built,) = out.glob("camcmm-*.whl")
    return built


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    """The wheel installed (without dependencies) into a folder of its own."""
    target = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "-q", "--target", str(target), str(wheel)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return target


def _declared_plugins() -> dict[str, str]:
    """Entry point name -> 'package:plugin.yaml' as pyproject.toml declares the built-ins."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return project["entry-points"]["camcmm.plugins"]


def test_wheel_holds_the_resources_and_every_builtin_manifest(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    shipped = {p.relative_to(ROOT / "resources").as_posix() for p in (ROOT / "resources").rglob("*") if p.is_file()}
    assert shipped and {f"camcmm/resources/{p}" for p in shipped} <= names
    for entry in _declared_plugins().values():
        package, manifest = entry.split(":")
        assert f"{package.replace('.', '/')}/{manifest}" in names, entry
    assert not any(n.startswith(("resources/", "app/", "plugins/")) for n in names), "a source folder as a package"


def test_installed_copy_opens_the_artefact_catalogue(installed, tmp_path):
    site = sysconfig.get_paths()["purelib"]
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env["PYTHONPATH"] = os.pathsep.join([str(installed), site])
    proc = subprocess.run(
        [sys.executable, "-S", "-c", PROBE], capture_output=True, text=True, timeout=300, cwd=tmp_path, env=env
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    found = json.loads(proc.stdout.strip().splitlines()[-1])
    assert Path(found["camcmm"]).is_relative_to(installed), found["camcmm"]
    assert [Path(p) for p in found["plugins"]] == [installed / "camcmm_plugins"]
    assert Path(found["resources"]) == installed / "camcmm" / "resources"
    assert isinstance(found["catalogue"], (list, dict)) and found["catalogue"], "the artefact catalogue is empty"
    # the same built-in plugins as the checkout's, every one usable
    from camcmm.host import PluginHost

    checkout = {s.id for s in PluginHost().all() if s.distribution == "camcmm"}
    assert set(found["builtins"]) == checkout
    assert {pid: status for pid, status in found["builtins"].items() if status != "ok"} == {}
