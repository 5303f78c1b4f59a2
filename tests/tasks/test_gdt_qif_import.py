"""A QIF 3.0 file uploaded as a plan (the Compare page's Import plan): the task
:func:`camcmm.tasks.gdt.import_qif_upload` runs the provider of ``qif-import`` (camcmm's
``gdt.import-qif``) on the bytes and gives the plan ``camcmm gdt import-qif`` writes —
the reference is that command run in the same test on the same file (NIST CTC 01: 17
features, 3 datums, 11 of its 14 characteristics; skipped the 2 face sets, the 2 surface
profiles on them and the angle size)."""

from __future__ import annotations

import pytest
import yaml

from camcmm.contracts import check_outputs
from camcmm.errors import InputError, PluginError
from camcmm.host import PluginHost
from camcmm.project import Project
from camcmm.tasks import gdt
from helpers.cli import main_json
from helpers.paths import TEST_DATA

CTC01 = TEST_DATA / "qif3" / "nist_ctc_01_asme1_ap242.qif"


def test_a_qif_upload_gives_the_plan_of_the_import_command(tmp_path, capfd):
    project = Project.create(tmp_path / "proj")
    imported = gdt.import_qif_upload(PluginHost(), project, CTC01.read_bytes(), "CTC01.QIF")
    ref_out = tmp_path / "ref.yaml"
    ref = main_json(capfd, "gdt", "import-qif", CTC01, "--out", ref_out, "--json")

    plan, report = imported.plan, imported.report
    assert (report["features"], report["datums"], report["characteristics"]) == (17, 3, 11)
    assert (ref["features"], ref["datums"], ref["characteristics"]) == (17, 3, 11)
    assert report["skipped"] == ref["skipped"] and len(imported.skipped) == 5
    kinds = sorted(c["type"] for c in plan["characteristics"])
    assert kinds == ["diameter"] * 7 + ["flatness", "perpendicularity", "position", "position"]
    assert sorted(plan["datums"]) == ["A", "B", "C"] and plan["unit"] == "mm"
    # the same plan as the command's file, save the name the file was given
    written = yaml.safe_load(ref_out.read_text("utf-8"))
    assert plan["qif"]["file"] == "CTC01.QIF" and written["qif"]["file"] == CTC01.name
    assert {**plan, "qif": None} == {**written, "qif": None}
    assert gdt.check_plan(plan) is plan  # complete: a plan evaluate can run
    assert imported.warnings == ref["warnings"]
    msg = imported.message()
    assert msg.startswith("CTC01.QIF: imported 17 features, 11 characteristics; skipped 5: 2166: ")
    assert "OtherNonShape" in msg and msg.endswith(" …") and "\n" not in msg
    # nothing of the upload left in the project's folder
    assert not [p for p in project.path.iterdir() if p.name.startswith(".qif-import-")]


def test_a_file_that_is_not_qif_is_refused_in_one_line_naming_it(tmp_path):
    project = Project.create(tmp_path / "proj")
    with pytest.raises(InputError) as e:
        gdt.import_qif_upload(PluginHost(), project, b"features: {}\n", "drawing.qif")
    assert str(e.value) == "drawing.qif: not well-formed XML (syntax error, line 1)"
    with pytest.raises(InputError, match=r"^part\.qif: not a QIF 3\.0 document \(root element 'svg'"):
        gdt.import_qif_upload(PluginHost(), project, b"<svg/>", "../x/part.qif")  # only the name is used
    assert not [p for p in project.path.iterdir() if p.name.startswith(".qif-import-")]


def test_the_contract_of_qif_import_refuses_a_provider_without_the_skipped_list():
    check_outputs(gdt.QIF_TASK, "lab.qif", {"plan": {}, "report": {"skipped": []}})
    with pytest.raises(PluginError, match="lab.qif.*'report.skipped'"):
        check_outputs(gdt.QIF_TASK, "lab.qif", {"plan": {}, "report": {"features": 1}})
    assert PluginHost().provider(gdt.QIF_TASK).id == gdt.QIF_PLUGIN
