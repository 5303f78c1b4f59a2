"""Numbers picked out of stored results, and ISO 15530-3 fed from a project."""

from __future__ import annotations

import pytest

from camcmm.errors import InputError
from camcmm.project import Project
from camcmm.project.select import project_values, select
from helpers.cli import main_json

DOC = {
    "parameters": {"PS": {"per_measurement": [{"value": 0.1}, {"value": None}, {"value": -0.2}]}},
    "lengths": [{"values": [1, 2]}, {"values": [3.5, 4.5, 5.5]}],
}


def test_paths_walk_keys_items_and_lists():
    assert select(DOC, "parameters.PS.per_measurement[].value") == [0.1, None, -0.2]
    assert select(DOC, "lengths[1].values[]") == [3.5, 4.5, 5.5]
    assert select(DOC, "lengths[].values[0]") == [1, 3.5]
    with pytest.raises(InputError, match="no key 'PX' after .parameters"):
        select(DOC, "parameters.PX.value")
    with pytest.raises(InputError, match="has 2 items, no \\[5\\]"):
        select(DOC, "lengths[5]")
    with pytest.raises(InputError, match="use dotted keys"):
        select(DOC, "lengths[x]")


def _project_with_result(tmp_path):
    with Project.create(tmp_path / "p") as p:
        run = {
            "plugin": "vdi2634-2",
            "version": "1",
            "params": {},
            "input_hashes": {},
            "outputs": {"diameters": [20.0031, 19.9987, 20.0012, 20.0004, 19.9995]},
            "started": "2026-01-01T00:00:00+00:00",
            "finished": "2026-01-01T00:00:01+00:00",
        }
        return tmp_path / "p", p.add_result(run)


def test_project_values_and_iso15530_3_from_a_project(tmp_path, capfd):
    project, rid = _project_with_result(tmp_path)
    values = project_values(project, rid, "diameters[]")
    assert values == [20.0031, 19.9987, 20.0012, 20.0004, 19.9995]
    spec = tmp_path / "iso.yaml"
    spec.write_text("measurand: sphere diameter\nunit: mm\ncalibrated_value: 20.001\nu_cal: 0.0005\nk: 2\n")
    # in-process (main_json: the CLI's main with capfd): only the output counts
    doc = main_json(
        capfd,
        "uncertainty",
        "iso15530-3",
        spec,
        "--project",
        project,
        "--result",
        rid,
        "--path",
        "diameters[]",
        "--json",
    )
    mean = sum(values) / 5
    assert doc["n"] == 5 and doc["mean"] == pytest.approx(mean, abs=1e-12)
    assert doc["bias"] == pytest.approx(mean - 20.001, abs=1e-12)


def test_project_values_errors_name_the_culprit(tmp_path):
    project, rid = _project_with_result(tmp_path)
    with pytest.raises(InputError, match="no result 99"):
        project_values(project, 99, "diameters[]")
    with pytest.raises(InputError, match="no key 'radius'"):
        project_values(project, rid, "radius")
