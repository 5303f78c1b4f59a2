"""``camcmm fuse csi`` given files of the wrong kind (issue 26): a height map as the
cloud was ``TypeError: object of type 'method' has no len()`` (the unit check measured
a HeightMap as if it were a cloud); now one line naming the file and what it is."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import HeightMap, unit_decision, write
from camcmm.host import default_host
from helpers.cli import refused
from helpers.fusion_synthetic import csi_map, photo_cloud


@pytest.fixture
def files(tmp_path):
    hm, _ = csi_map(shape=(60, 80))
    write(hm, tmp_path / "m.x3p")
    write(photo_cloud(spacing=0.3)[0], tmp_path / "c.ply")
    return tmp_path


def test_height_map_as_cloud_is_one_line_naming_it(capsys, files):
    line = refused(capsys, ["fuse", "csi", "--cloud", files / "m.x3p", "--csi", files / "m.x3p"], "m.x3p")
    assert "input 'cloud' needs a point cloud; this is a height map" in line


def test_height_map_as_cloud_through_the_host(files):
    with pytest.raises(Exception, match="this is a height map") as err:
        default_host().run_task("csi-fusion", {"cloud": str(files / "m.x3p"), "csi": [str(files / "m.x3p")]}, {})
    assert type(err.value).__name__ == "InputError"


def test_cloud_as_height_map_is_one_line_naming_it(capsys, files):
    argv = ["fuse", "csi", "--cloud", files / "c.ply", "--csi", files / "c.ply"]
    refused(capsys, argv, "c.ply: this is a point cloud, not a height map")


def test_unit_decision_measures_a_height_map_by_its_size():
    """The span of a height map is its width, length and height range (mm), so a map in
    metres is 'known' and none of its numbers is taken from a bound method."""
    z = np.zeros((4, 5))
    z[1, 2], z[3, 4] = 0.002, np.nan
    hm = HeightMap(z, 0.5, 0.25, source_unit="m")
    d = unit_decision(hm, "m")
    assert d.status == "known"
    assert d.to_json()["span"] == pytest.approx([2.5e-3, 1e-3, 2e-6])  # in the map's unit, m
