"""The Monte Carlo on a Dask distributed cluster (a LocalCluster with one worker, one
thread, light on a 2-core machine): the same seed gives IDENTICAL numbers locally and on
Dask, through the scheduler address as the CLI passes it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from camcmm_plugins.uncertainty import montecarlo as mc

distributed = pytest.importorskip("dask.distributed")
DATA = Path(__file__).parents[1] / "data" / "uncertainty"


@pytest.fixture(scope="module")
def cluster():
    cl = distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None, silence_logs=40
    )
    yield cl
    cl.close()


def _doc():
    doc = yaml.safe_load((DATA / "montecarlo_thesis.yaml").read_text())
    doc["grid"]["n"] = [4, 4, 4]
    doc["chunk"] = 40
    return doc


def test_dask_and_local_give_identical_results(cluster):
    local = mc.run_study(_doc(), iterations=230, seed=7, studies=["convergence", "joint"])
    remote = mc.run_study(
        _doc(), iterations=230, seed=7, studies=["convergence", "joint"], scheduler=cluster.scheduler_address
    )
    assert remote["executor"] == "dask" and local["executor"] == "local"
    assert remote["contributions"] == local["contributions"]
    assert remote["combined"] == local["combined"] and remote["expanded"] == local["expanded"]
    assert remote["combined_joint"] == local["combined_joint"]
    for f, c in local["studies"]["convergence"].items():
        assert np.array_equal(c["u"], remote["studies"]["convergence"][f]["u"])


def test_cli_with_scheduler(cluster, tmp_path, capsys):
    import json

    from camcmm.cli.main import main

    f = tmp_path / "mc.yaml"
    f.write_text(yaml.safe_dump(_doc()))
    assert (
        main(
            [
                "uncertainty",
                "montecarlo",
                str(f),
                "--iterations",
                "80",
                "--seed",
                "3",
                "--scheduler",
                cluster.scheduler_address,
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    local = mc.run_study(_doc(), iterations=80, seed=3)
    assert out["combined"] == local["combined"] and out["iterations"] == 80


@pytest.mark.slow
def test_unreachable_scheduler_is_a_clear_error():
    from camcmm.api import InputError

    with pytest.raises(InputError, match="Dask scheduler"):
        mc.run_study({**_doc(), "scheduler_timeout": 2}, iterations=10, scheduler="tcp://127.0.0.1:9")
