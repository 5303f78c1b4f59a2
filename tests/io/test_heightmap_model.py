"""The height map of the data model (issue 17): checks at construction, the valid mask,
points in mm and the physical size; the pyvista surface hides invalid points."""

import numpy as np
import pytest

from camcmm.errors import InputError
from camcmm.model import HeightMap


def _map(**kw):
    h = np.arange(12.0).reshape(3, 4)
    h[1, 2] = np.nan
    return HeightMap(h, kw.pop("dx", 0.1), kw.pop("dy", 0.2), name="m.x3p", **kw)


def test_points_follow_the_contract():
    m = _map(origin=(1.0, 2.0))
    assert m.shape == (3, 4)
    assert m.n_valid == 11 and not m.valid[1, 2]
    p = m.points()
    assert p.shape == (11, 3) and p.dtype == np.float64
    # row i = 2, column j = 3 holds 11 -> x = 1 + 3 * 0.1, y = 2 + 2 * 0.2
    np.testing.assert_allclose(p[-1], [1.3, 2.4, 11.0])
    assert not np.isnan(p).any()
    np.testing.assert_allclose(m.size_mm, (0.4, 0.6))
    x, y = m.xy()
    np.testing.assert_allclose(x, [1.0, 1.1, 1.2, 1.3])
    np.testing.assert_allclose(y, [2.0, 2.2, 2.4])


@pytest.mark.parametrize(
    "kw, message",
    [
        ({"dx": 0.0}, r"m.x3p: lateral step dx = 0 mm must be positive and finite"),
        ({"dy": float("nan")}, r"m.x3p: lateral step dy = nan mm must be positive and finite"),
        ({"dx": "a"}, r"m.x3p: lateral step dx 'a' is not a number"),
        ({"intensity": np.zeros((4, 3))}, r"m.x3p: intensity has shape \(4, 3\), heights \(3, 4\)"),
        ({"origin": (0.0, np.inf)}, r"m.x3p: origin must be two finite numbers"),
    ],
)
def test_bad_values_are_refused_naming_them(kw, message):
    with pytest.raises(InputError, match=message):
        _map(**kw)


def test_bad_grids_are_refused():
    with pytest.raises(InputError, match=r"hm: heights must be a non-empty \(ny, nx\) grid, got shape \(5,\)"):
        HeightMap(np.zeros(5), 1.0, 1.0, name="hm")
    with pytest.raises(InputError, match=r"shape \(0, 3\)"):
        HeightMap(np.zeros((0, 3)), 1.0, 1.0)
    h = np.zeros((2, 3))
    h[1, 0] = -np.inf
    with pytest.raises(InputError, match=r"1 heights are infinite \(first at row 1, column 0\)"):
        HeightMap(h, 1.0, 1.0)


@pytest.mark.slow
def test_the_surface_hides_invalid_points():
    pytest.importorskip("pyvista")
    full = HeightMap(np.arange(12.0).reshape(3, 4), 0.1, 0.2).to_pyvista()
    assert full.n_points == 12 and full.n_cells == 6
    # point k of the grid is row k // 4, column k % 4
    np.testing.assert_allclose(full.points[6], [0.2, 0.2, 6.0])
    np.testing.assert_allclose(full.point_data["height"], np.arange(12.0))
    holed = _map().to_pyvista()
    # the NaN at (1, 2) removes the 4 cells around it; no NaN is left to draw
    assert holed.n_cells == 2
    assert not np.isnan(holed.point_data["height"]).any()


def test_a_result_holds_a_summary_of_a_map_not_its_heights():
    from camcmm.jsonable import to_jsonable

    assert to_jsonable({"map": _map()}) == {
        "map": {"kind": "heightmap", "name": "m.x3p", "grid": [4, 3], "steps_mm": [0.1, 0.2], "n_valid": 11}
    }
