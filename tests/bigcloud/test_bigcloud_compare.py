"""The comparison of a big cloud with a nominal mesh in chunks on Dask (issue 29).

Reference: the same cloud read whole by camcmm.io.read, its signed distances by one
camcmm.meshdistance.MeshDistance in memory, and the inspection plugin's own statistics
(camcmm_plugins.inspection.stats.deviation_stats, numpy.histogram over the same edges,
material_ratio_curve). Count, min, max, percentiles and histogram must agree to the last
digit; mean and RMS equal math.fsum of the distances (so numpy's pairwise figures to
1e-12 relative). Dask runs in this process (LocalCluster, processes=False)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from camcmm.bigcloud import LodIndex, build_store
from camcmm.bigcloud.compare import compare_store
from camcmm.bigcloud.exact import ExactSum, Histogram, hazen
from camcmm.io import read, write
from camcmm.meshdistance import MeshDistance
from camcmm.model import PointCloud, TriangleMesh
from camcmm_plugins.inspection.material_ratio import material_ratio_curve
from camcmm_plugins.inspection.stats import deviation_stats
from helpers.cli import main_json, main_refused

distributed = pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def cluster():
    cl = distributed.LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None, silence_logs=40
    )
    yield cl
    cl.close()


def _box_mesh(a=20.0, n=6):
    """A closed box of 2a mm, each face split into n x n x 2 triangles (a CAD-like nominal)."""
    import open3d as o3d

    m = o3d.geometry.TriangleMesh.create_box(2 * a, 2 * a, 2 * a, create_uv_map=False)
    m = m.subdivide_midpoint(2).translate((-a, -a, -a))
    return TriangleMesh(np.asarray(m.vertices), np.asarray(m.triangles), name="box")


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    d = tmp_path_factory.mktemp("bigcompare")
    rng = np.random.default_rng(3)
    n = 100_000
    # points near the faces of the box: a face, an offset of a few hundredths of a mm
    face = rng.integers(0, 6, n)
    p = rng.uniform(-19.5, 19.5, (n, 3))
    axis, side = face % 3, np.where(face < 3, -1.0, 1.0)
    p[np.arange(n), axis] = side * (20 + rng.normal(0.0, 0.03, n))
    write(PointCloud(p.astype(np.float32).astype(float)), d / "cloud.ply")
    mesh = _box_mesh()
    write(mesh, d / "box.ply")
    build_store(d / "cloud.ply", d / "store", chunk=30_000)
    cloud = read(d / "cloud.ply")
    dev = MeshDistance((mesh.vertices, mesh.faces)).signed_distance(cloud.points)
    return d, mesh, cloud, dev


def test_dask_chunks_equal_the_statistics_in_memory(case, cluster):
    d, mesh, cloud, dev = case
    with distributed.Client(cluster) as client:
        r = compare_store(d / "store", (mesh.vertices, mesh.faces), scheduler=client, chunk=23_456, tolerance=0.04)
        r2 = compare_store(d / "store", d / "box.ply", scheduler=client, chunk=50_000, tolerance=0.04)
    s, ref = r["statistics"], deviation_stats(dev, tolerance=0.04)
    assert r["n_chunks"] == 5 and r["exact"]["percentiles"]
    exact = [k for k in ref if k not in ("mean", "std", "rms")]
    assert {k: s[k] for k in exact} == {k: ref[k] for k in exact}  # n, min, max, percentiles, share
    for k in ("mean", "std", "rms"):
        assert s[k] == pytest.approx(ref[k], rel=1e-12, abs=0)
    assert s["mean"] == math.fsum(dev) / len(dev)
    assert s["rms"] == math.sqrt(math.fsum(dev * dev) / len(dev))
    h = r["histogram"]
    assert h["bin_width"] == 0.001 and np.array_equal(np.histogram(dev, bins=h["edges"])[0], h["counts"])
    curve = material_ratio_curve(dev).resampled(101)
    assert np.array_equal(r["material_ratio"]["mr_percent"], curve["mr_percent"])
    span = dev.max() - dev.min()
    assert np.allclose(r["material_ratio"]["height"], curve["height"], rtol=0, atol=1e-12 * span)
    # another chunking and the nominal read from its file: the same digits
    assert r2["statistics"] == s and np.array_equal(r2["histogram"]["counts"], h["counts"])
    # the deviations became the store's field, in store order
    idx = LodIndex.open(d / "store")
    rows = np.arange(0, idx.n, 7)
    assert np.array_equal(idx.fields(rows)["deviation"], dev[idx.source_index(rows)])


def test_exact_sum_and_histogram_do_not_depend_on_the_chunks():
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.normal(0, 1e-3, 5000), rng.normal(0, 1e2, 50), [1e-310, 0.0, -2.5]])
    parts = np.array_split(rng.permutation(x), 13)
    a = ExactSum()
    for q in parts:
        a.merge(ExactSum().add(q))
    assert a.value() == math.fsum(x) != float(np.sum(x))  # numpy's sum is not exact here
    h = Histogram(0.1)
    for q in parts:
        h.merge(Histogram(0.1).add(q))
    edges, counts, _ = h.dense()
    assert np.array_equal(np.histogram(x, bins=edges)[0], counts)
    # a far outlier: bins stay sparse, the report merges them, the percentiles stay exact
    y = np.append(x, 4.0e9)
    far = Histogram(0.1).add(y)
    edges, counts, g = far.dense(100)
    assert g > 1e8 and len(counts) <= 100 and np.array_equal(np.histogram(y, bins=edges)[0], counts)
    pct = [0.5, 50.0, 99.5, 100.0]
    got, exact = hazen(far, len(y), pct, lambda: [y])
    assert exact and np.array_equal(got, np.percentile(y, pct, method="hazen"))
    # values on the edges land as numpy puts them: 0.3 is below the edge 3 x 0.1
    k = Histogram(0.1).bins(np.array([0.3, 0.1, 0.2, -0.1]))
    assert k.tolist() == [2, 1, 2, -1]


def test_exact_percentiles_through_sub_bins(monkeypatch):
    """Bins too full to collect are split in sub-bins first: still numpy's digits."""
    import camcmm.bigcloud.exact as ex

    rng = np.random.default_rng(1)
    d = np.concatenate([rng.normal(0, 0.05, 30_000), np.full(500, 0.0123)])  # with ties
    pct = [0.5, 2.5, 50, 97.5, 99.5, *np.linspace(0, 100, 101)]
    h = Histogram(0.001).add(d)
    monkeypatch.setattr(ex, "COLLECT", 100)
    got, exact = ex.hazen(h, len(d), pct, lambda: np.array_split(d, 3))
    assert exact and np.array_equal(got, np.percentile(d, pct, method="hazen"))
    monkeypatch.setattr(ex, "COLLECT", 10**9)  # collected directly, bins whole
    assert np.array_equal(ex.hazen(h, len(d), pct, lambda: [d])[0], got)
    # a limit below what the ranks' sub-bins hold: interpolated, and said so
    got, exact = ex.hazen(Histogram(1.0).add(d), len(d), pct, lambda: [d], limit=10)
    assert not exact and np.all(np.abs(got - np.percentile(d, pct, method="hazen")) < 1.0)


def test_cli_index_and_compare(case, cluster, tmp_path, capfd):
    d, mesh, cloud, dev = case
    small = tmp_path / "small.ply"
    write(PointCloud(cloud.points[:4000]), small)
    doc = main_json(capfd, "cloud", "index", small, "--out", tmp_path / "st", "--chunk", "1500", "--json")
    assert doc["n"] == 4000 and doc["source"]["format"] == "ply"
    doc = main_json(
        capfd, "cloud", "compare", tmp_path / "st", "--nominal", d / "box.ply",
        "--scheduler", cluster.scheduler_address, "--chunk", "1000", "--json",
    )  # fmt: skip
    ref = deviation_stats(dev[:4000])
    assert doc["statistics"]["p50"] == ref["p50"] and doc["statistics"]["max"] == ref["max"]
    assert doc["n_chunks"] == 4 and doc["scheduler"] == cluster.scheduler_address
    err = main_refused(capfd, "cloud", "compare", tmp_path / "st", "--nominal", small)
    assert "triangle mesh" in err
