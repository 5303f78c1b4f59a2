"""Cloud edits on a temporary project: a box crop of a grid whose count is known (4 x 4 x 4
of a 10 x 10 x 10 grid), its provenance read back from the project, a chain of edits,
undo down to the import and redo, refusals in one line."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.errors import CamcmmError, InputError
from camcmm.host import default_host
from camcmm.model import PointCloud
from camcmm.project import Project
from camcmm.tasks.cloudedit import HISTORY_KEY, CloudEdits, provenance
from camcmm.tasks.items import ProjectItems

GRID = np.stack(np.meshgrid(*[np.arange(10.0)] * 3, indexing="ij"), -1).reshape(-1, 3)


@pytest.fixture
def project(tmp_path):
    p = Project.create(tmp_path / "proj")
    ids = np.arange(len(GRID), dtype=float)
    cloud = PointCloud(GRID, fields={"id": ids, "deviation": 1e-3 * ids}, field_units={"id": "", "deviation": "mm"})
    h = p.add_object(cloud, "grid.ply")
    p.add_measurement("grid.ply", h, "pointcloud", meta={"summary": "grid", "display_units": {"deviation": "µm"}})
    yield p
    p.close()


def listed(project) -> list[str]:
    return [m["name"] for m in project.measurements()]


def test_a_box_crop_is_a_new_item_with_its_provenance(project):
    items = ProjectItems(project)
    edits = CloudEdits(default_host(), items, project)
    edit = edits.apply("1", "crop.box", {"min": "2, 2, 2", "max": "5 5 5"})
    assert (edit.n_kept, edit.n_removed) == (64, 936) and edit.parent == "1"
    assert edit.name == "grid.ply · cropped (box)" and listed(project) == ["grid.ply", edit.name]
    # the stored item: its own file, read back from the project, the points inside the box
    # with their fields; made_by and the parent's display units like any derived item
    m = project.measurement(int(edit.item))
    back = project.load_measurement(m["id"])
    ids = back.fields["id"].astype(int)
    np.testing.assert_array_equal(back.points, GRID[ids])
    assert back.n_points == 64 and np.all((back.points >= 2) & (back.points <= 5))
    assert m["meta"]["made_by"].startswith("crop.box ") and m["meta"]["display_units"] == {"deviation": "µm"}
    # provenance: plugin, checked params, the parent item
    prov = provenance(project, edit.item)
    assert prov is not None and prov["plugin"] == "crop.box" and prov["parents"] == ["1"]
    assert prov["params"]["min"] == [2.0, 2.0, 2.0] and prov["params"]["max"] == [5.0, 5.0, 5.0]
    assert project.result(prov["result_id"])["outputs"]["n_kept"] == 64
    assert provenance(project, "1") is None  # an import


def test_edits_chain_undo_to_the_import_and_redo(project):
    edits = CloudEdits(default_host(), ProjectItems(project), project)
    a = edits.apply("1", "crop.plane", {"point": "4.5, 4.5, 0", "normal": "1, 1, 0"})
    b = edits.apply(a.item, "crop.box", {"min": "0,0,0", "max": "9,9,4"})
    assert (a.n_kept, b.n_kept) == (550, 275) and b.parent == a.item
    assert b.name == "grid.ply · cropped (plane) · cropped (box)"
    # a new session (the history is the project's): undo the newest, then the one before
    again = CloudEdits(default_host(), ProjectItems(project), project)
    assert again.can_undo() and not again.can_redo()
    u = again.undo()
    assert u is not None and u.item == b.item and u.parent == a.item
    assert listed(project) == ["grid.ply", a.name]
    # soft: the item is still in the project, marked removed
    gone = {str(m["id"]): m for m in project.measurements(include_removed=True)}
    assert gone[b.item]["removed"] and not gone[a.item]["removed"]
    assert again.undo().item == a.item and listed(project) == ["grid.ply"]
    assert again.undo() is None and not again.can_undo()
    assert again.redo().item == a.item and listed(project) == ["grid.ply", a.name]
    # a new edit clears what could be redone
    c = again.apply("1", "cloud.denoise", {})
    assert not again.can_redo() and c.name == "grid.ply · outliers removed"
    # the counts are the plugin's own on the same cloud (the grid's corners and edges lie
    # farther from their neighbours than the rest: statistical outliers by construction)
    direct = default_host().run("cloud.denoise", {"cloud": project.load_measurement(1)}, {}).outputs
    assert (c.n_kept, c.n_removed) == (direct["cloud"].n_points, direct["n_removed"]) and c.n_removed > 0
    assert project.get_state(HISTORY_KEY)["undone"] == []


def test_an_item_deleted_meanwhile_is_passed_over(project):
    edits = CloudEdits(default_host(), ProjectItems(project), project)
    a = edits.apply("1", "crop.box", {"min": "0,0,0", "max": "9,9,4"})
    b = edits.apply("1", "crop.box", {"min": "0,0,0", "max": "9,9,2"})
    assert b.name == "grid.ply · cropped (box) (2)"  # never two items of one name
    project.delete_measurement(int(b.item))
    assert edits.undo().item == a.item and listed(project) == ["grid.ply"]


def test_refusals_are_one_line(project):
    edits = CloudEdits(default_host(), ProjectItems(project), project)
    with pytest.raises(InputError, match="'fit.sphere' is not one of"):
        edits.apply("1", "fit.sphere", {})
    with pytest.raises(InputError, match="no item '9'"):
        edits.apply("9", "crop.box", {})
    with pytest.raises(CamcmmError, match="'max'"):
        edits.apply("1", "crop.box", {"min": "0,0,0", "max": "1,x,1"})
    with pytest.raises(CamcmmError, match="keeps none"):
        edits.apply("1", "crop.box", {"min": "20,20,20", "max": "30,30,30"})
    assert listed(project) == ["grid.ply"] and not edits.can_undo()
