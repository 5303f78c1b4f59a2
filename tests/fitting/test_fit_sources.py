"""Where the fitted points come from: a mesh is fitted by its vertices (with a warning),
errors name the file, and a fit through as few points as the element needs warns."""

from __future__ import annotations

import argparse

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from camcmm.api import GeometryError, Image, InputError, PointCloud, TriangleMesh, write
from camcmm.host import PluginHost
from camcmm_plugins.fitting import cli
from camcmm_plugins.fitting.api import fit

CENTER = np.array([1000.0, 2000.0, -500.0])
NO_REDUNDANCY = "no redundancy"


def _run(argv):
    p = argparse.ArgumentParser()
    cli.configure(p)
    return cli.run(p.parse_args(argv))


def _icosahedron(radius: float) -> TriangleMesh:
    """12 vertices exactly on the sphere (CENTER, radius) mm, 20 faces."""
    g = (1 + 5**0.5) / 2
    v = np.array([[0, s1, s2 * g] for s1 in (-1, 1) for s2 in (-1, 1)], dtype=float)
    v = np.vstack([v, np.roll(v, 1, axis=1), np.roll(v, 2, axis=1)])
    v *= radius / np.linalg.norm(v[0])
    return TriangleMesh(CENTER + v, ConvexHull(v).simplices, name="ico.stl")


def _minimal(element: str) -> np.ndarray:
    """Exactly as many points as ``element`` needs, on it by construction (mm)."""
    t = np.array([0.3, 2.1, 4.4, 1.2, 5.5])
    if element == "line":
        return CENTER + np.outer([0.0, 7.0], [0.6, 0.8, 0.0])
    if element == "plane":
        return CENTER + np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0]])
    if element == "circle":
        return CENTER + 5 * np.column_stack([np.cos(t[:3]), np.sin(t[:3]), np.zeros(3)])
    if element == "sphere":
        return _icosahedron(10.0).vertices[[0, 3, 5, 9]]
    return CENTER + np.column_stack([5 * np.cos(t), 5 * np.sin(t), [0.0, 3, 8, -4, 11]])


@pytest.mark.parametrize("element", ["line", "plane", "circle", "sphere", "cylinder"])
def test_a_fit_through_the_fewest_points_warns(element):
    pts = _minimal(element)
    res = fit(element, pts)
    assert any(NO_REDUNDANCY in w for w in res.warnings), res.warnings
    assert res.form["rms"] < 1e-6  # it does interpolate them: the warning is the only sign


def test_one_point_more_does_not_warn_of_redundancy():
    sphere = _icosahedron(10.0).vertices
    assert not any(NO_REDUNDANCY in w for w in fit("sphere", sphere[:5]).warnings)
    assert not any(NO_REDUNDANCY in w for w in fit("line", CENTER + np.outer([0.0, 3.0, 7.0], [1, 0, 0])).warnings)


def test_the_cli_fits_a_mesh_file_by_its_vertices_with_a_warning(tmp_path):
    mesh = _icosahedron(10.0)
    path = tmp_path / "ico.stl"
    write(mesh, path)
    out = _run(["sphere", str(path)])
    assert out["n_points"] == 12
    # STL keeps float32 coordinates: 2000 mm off the origin they are rounded to ~1e-4 mm
    assert out["radius"] == pytest.approx(10.0, abs=3e-4)
    assert np.allclose(out["center"], CENTER, atol=3e-4)
    assert any("ico.stl" in w and "triangle mesh" in w and "12 vertices" in w for w in out["warnings"])


def test_the_plugin_fits_a_mesh_by_its_vertices_with_a_warning(tmp_path):
    host = PluginHost()
    run = host.run("fit.sphere", {"cloud": _icosahedron(10.0)})
    assert run.outputs["radius"] == pytest.approx(10.0, abs=1e-9)
    assert any("ico.stl" in w and "12 vertices" in w for w in run.warnings), run.warnings
    path = tmp_path / "ico.stl"
    write(_icosahedron(10.0), path)
    run = host.run("fit.sphere", {"cloud": str(path)})  # a path, read by the host
    assert run.outputs["radius"] == pytest.approx(10.0, abs=3e-4)  # float32 in the STL
    assert any("ico.stl" in w for w in run.warnings)


def test_the_plugin_refuses_an_image_naming_it():
    # the host refuses it by the port's declared kind before the plugin runs
    with pytest.raises(InputError, match=r"^i\.png: fit\.plane input 'cloud' needs a point cloud or a triangle mesh"):
        PluginHost().run("fit.plane", {"cloud": Image(np.zeros((4, 4), np.uint8), name="i.png")})


@pytest.mark.parametrize("element", ["line", "plane", "circle", "sphere", "cylinder"])
def test_cli_errors_name_the_file(tmp_path, element):
    same = tmp_path / "same.xyz"
    np.savetxt(same, np.tile([1.0, 2.0, 3.0], (50, 1)))
    with pytest.raises(GeometryError) as exc:
        _run([element, str(same)])
    assert str(exc.value) == f"{same}: {element} fit: all 50 points coincide"
    if element != "line":
        line = tmp_path / "line.xyz"
        np.savetxt(line, np.column_stack([np.linspace(0, 10, 50), np.zeros(50), np.zeros(50)]))
        with pytest.raises(GeometryError, match="collinear") as exc:
            _run([element, str(line)])
        assert str(exc.value).startswith(f"{line}: {element} fit: ")


def test_plugin_errors_leave_the_naming_to_the_caller():
    """vdi2634 puts the file (and what it expected there) in front itself: no name twice."""
    with pytest.raises(GeometryError) as exc:
        PluginHost().run("fit.sphere", {"cloud": PointCloud(np.tile([1.0, 2.0, 3.0], (50, 1)), name="scan.ply")})
    assert str(exc.value) == "sphere fit: all 50 points coincide"
