"""The part-3 cases of the bad-input family tests/helpers/badcases/studies_part3.py that
exit 0 do so with a warning naming their problem (issue 26). The harness accepts any
warning from a command that exits 0, and those plans lack their sphere measurements, so
their verdict is incomplete and warns whatever the ball plate does: here each case's own
warning is looked for, so a case whose refusal went missing fails."""

from __future__ import annotations

import json

import pytest

from helpers import badinputs as bi
from helpers.badcases import studies_part3
from helpers.cli import main_run

#: the baseline's warnings: the missing sphere measurements, the small plate in the volume
BASELINE = ("incomplete:", "below 0.3 L0")
EXIT_0 = (
    "lengths-x10",
    "lengths-x1.5",
    "lengths-other-plate",
    "sphere-diameter-x10",
    "volume-small",
    "cloud-one-sphere",
    "cloud-five-points",
    "cloud-junk",
    "cloud-missing",
    "cloud-nan",
)
CASES = {c.id: c for c in studies_part3.cases()}


@pytest.mark.slow
@pytest.mark.parametrize("cid", EXIT_0)
def test_a_part3_case_that_exits_0_names_its_problem_in_a_warning(cid, tmp_path, capfd, monkeypatch):
    case = CASES[f"sp-part3-{cid}"]
    bi._materialise(case, tmp_path)
    monkeypatch.chdir(tmp_path)
    rc, out, err = main_run(capfd, *case.argv)
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["verdict"] != "pass"
    own = [w for w in doc["warnings"] if not any(b in w for b in BASELINE)]
    assert any(n.lower() in w.lower() for w in own for n in case.names), (case.names, own)


def test_the_family_is_large_enough_and_its_ids_are_its_own():
    study = [i for i in CASES if i.startswith("sp-study-")]
    part3 = [i for i in CASES if i.startswith("sp-part3-")]
    assert len(study) >= 70 and len(part3) >= 30 and len(CASES) == len(study) + len(part3)
    assert {f"sp-part3-{c}" for c in EXIT_0} <= set(part3)
