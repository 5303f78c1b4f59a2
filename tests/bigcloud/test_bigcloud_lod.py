"""The big-cloud store and its level of detail (camcmm.bigcloud, issue 29).

References: the store built out of core in chunks is compared with the index built in
memory from the same points as camcmm.io.read reads them (same order, same selection);
the view selection with a brute-force projection written here independently of
camcmm.bigcloud.lod (eye frame, tan of the half angle); uniformity with the expected
share of every cell, and a naive prefix that the same check must reject."""

from __future__ import annotations

import math

import numpy as np
import pytest

from camcmm.bigcloud import LodIndex, build_store, read_meta
from camcmm.errors import InputError
from camcmm.hashing import file_hash
from camcmm.io import read

CP = 200  # points per cell: small cells for a small cloud


def _surface(n: int, seed: int = 0) -> np.ndarray:
    """A wavy surface over 100 x 100 mm, float32-representable coordinates."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-50, 50, (n, 2))
    z = 3 * np.sin(xy[:, 0] / 9) * np.cos(xy[:, 1] / 13)
    return np.column_stack([xy, z]).astype(np.float32).astype(float)


def _ply(path, p: np.ndarray, intensity: np.ndarray) -> None:
    """Binary PLY: float x y z, float intensity, uchar red (as scanners write them)."""
    rec = np.empty(len(p), [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("intensity", "<f4"), ("red", "u1")])
    rec["x"], rec["y"], rec["z"], rec["intensity"], rec["red"] = p[:, 0], p[:, 1], p[:, 2], intensity, 7
    head = (
        "ply\nformat binary_little_endian 1.0\ncomment unit mm\n"
        f"element vertex {len(p)}\nproperty float x\nproperty float y\nproperty float z\n"
        "property float intensity\nproperty uchar red\nend_header\n"
    )
    path.write_bytes(head.encode() + rec.tobytes())


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    d = tmp_path_factory.mktemp("bigcloud")
    p = _surface(20_000)
    inten = np.arange(len(p), dtype=np.float32)
    _ply(d / "c.ply", p, inten)
    meta = build_store(d / "c.ply", d / "store", chunk=3000, cell_points=CP)  # 7 chunks, ~4 buckets
    return d, p, inten, meta


def _cam(eye, focal, up=(0, 1, 0), angle=30.0):
    return {"position": list(eye), "focal_point": list(focal), "view_up": list(up), "view_angle": angle}


def _brute_in_view(p, cam, viewport):
    """In front of the camera and inside the four side planes: the eye frame by hand."""
    eye, focal, up = (np.asarray(cam[k], float) for k in ("position", "focal_point", "view_up"))
    f = (focal - eye) / np.linalg.norm(focal - eye)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    rel = p - eye
    z, x, y = rel @ f, rel @ s, rel @ u
    t = math.tan(math.radians(cam["view_angle"]) / 2)
    aspect = viewport[0] / viewport[1]
    return (z > 0) & (np.abs(y) <= z * t) & (np.abs(x) <= z * t * aspect)


def test_store_out_of_core_equals_the_index_in_memory(built):
    d, p, inten, meta = built
    cloud = read(d / "c.ply")
    assert np.array_equal(cloud.points, p)
    mem = LodIndex.from_points(cloud.points, fields={"intensity": inten}, cell_points=CP)
    disk = LodIndex.open(d / "store")
    rows = np.arange(disk.n)
    assert disk.n == mem.n == len(p) == meta["n"]
    assert np.array_equal(disk.points(rows), mem.points(rows))  # same order, bit for bit
    assert np.array_equal(disk.source_index(rows), mem.source_index(rows))
    assert np.array_equal(disk.points(rows), p[disk.source_index(rows)])  # a permutation of the file
    assert np.array_equal(disk.fields(rows)["intensity"], inten[disk.source_index(rows)])
    assert disk.field_names == ["intensity", "red"]
    cam = _cam((10, -40, 120), (5, 5, 0))
    a, ia = disk.select(cam, (640, 480), 3000)
    b, ib = mem.select(cam, (640, 480), 3000)
    assert np.array_equal(a, b) and np.array_equal(ia, ib) and 0 < len(ia) <= 3000
    assert np.array_equal(disk.uniform(999), mem.uniform(999))
    # metadata: counts, bounds, provenance
    assert meta["bounds"] == [p.min(axis=0).tolist(), p.max(axis=0).tolist()]
    assert meta["source"]["sha256"] == file_hash(d / "c.ply") and meta["unit"] == "mm"
    assert read_meta(d / "store")["n_cells"] == len(disk.cell_count) > 4
    assert meta["fields"] == {"intensity": "<f4", "red": "|u1"}


def test_text_and_npy_sources_give_the_same_store(built, tmp_path):
    _, p, _, _ = built
    q = p[:3000]
    np.save(tmp_path / "c.npy", q.astype(np.float32))
    rows = "".join(f"{a!r} {b!r} {c!r}\n" for a, b, c in (q / 10).tolist())
    (tmp_path / "c.xyz").write_text("# unit cm\nx y z\n" + rows)
    build_store(tmp_path / "c.npy", tmp_path / "a", chunk=700)
    build_store(tmp_path / "c.xyz", tmp_path / "b", chunk=700)
    a, b = LodIndex.open(tmp_path / "a"), LodIndex.open(tmp_path / "b")
    rows = np.arange(a.n)
    assert np.array_equal(a.points(rows), LodIndex.from_points(q).points(rows))
    assert np.allclose(b.points(rows), a.points(rows), rtol=0, atol=1e-12)  # cm x 10, rounded once
    assert read_meta(tmp_path / "b")["source"]["unit"] == "cm"
    assert read_meta(tmp_path / "a")["warnings"] == []  # 100 mm, no unit: plausible as mm
    np.save(tmp_path / "m.npy", q / 1000)  # the same part in metres, no unit said
    assert "no unit" in build_store(tmp_path / "m.npy", tmp_path / "m")["warnings"][0]
    assert build_store(tmp_path / "m.npy", tmp_path / "m2", unit="m")["warnings"] == []


def test_uniform_prefix_is_spatially_uniform(built):
    _, p, _, _ = built
    idx = LodIndex.from_points(p, cell_points=CP)
    k = 4000
    rows = idx.uniform_index(k)
    assert len(rows) == k and len(np.unique(rows)) == k
    share = idx.cell_count * (k / idx.n)
    cell_of = np.searchsorted(idx.cell_start, rows, side="right") - 1
    got = np.bincount(cell_of, minlength=len(share))
    assert np.all(np.abs(got - share) < 1)  # every cell its share, to the point
    # any prefix of the interleaved order too
    m = 1000
    got_m = np.bincount(cell_of[:m], minlength=len(share))
    assert np.all(np.abs(got_m - share * m / k) <= 2)

    # independently of the cells: a 5 x 5 partition of the plane holds its share
    def spread(q):
        part = (np.clip((q[:, :2] + 50) // 20, 0, 4) @ [5, 1]).astype(int)
        return np.bincount(part, minlength=25)

    expected = spread(p) * (k / len(p))
    assert np.all(np.abs(spread(idx.points(rows)) - expected) <= 5 * np.sqrt(expected) + 2)
    # the same check rejects a naive prefix of the store (whole cells first)
    assert not np.all(np.abs(spread(idx.points(np.arange(k))) - expected) <= 5 * np.sqrt(expected) + 2)


@pytest.mark.parametrize(
    "cam",
    [
        _cam((0, 0, 150), (0, 0, 0)),
        _cam((30, -20, 25), (35, -15, 0), angle=40),
        _cam((-80, 10, 10), (0, 0, 0), up=(0, 0, 1), angle=25),
        _cam((0, 0, -30), (0, 0, 60), angle=60),  # from below, through the surface
    ],
)
def test_select_returns_only_and_all_points_in_the_frustum(built, cam):
    _, p, _, _ = built
    idx = LodIndex.from_points(p, cell_points=CP)
    vp = (800, 500)
    truth = _brute_in_view(p, cam, vp)
    # with a budget above n: exactly the points in view (no cell culled wrongly)
    pts, rows = idx.select(cam, vp, idx.n + 1)
    src = idx.source_index(rows)
    assert np.array_equal(np.sort(src), np.flatnonzero(truth))
    assert np.array_equal(pts, p[src])
    # with a small budget: at most the budget, and only points in view
    pts, rows = idx.select(cam, vp, 500)
    assert len(rows) <= 500 and _brute_in_view(pts, cam, vp).all()
    assert len(rows) >= min(250, truth.sum() // 2)  # the budget is used, not wasted on culled cells


def test_zoom_refines_the_zoomed_region(built):
    _, p, _, _ = built
    idx = LodIndex.from_points(p, cell_points=CP)
    vp, budget = (800, 600), 2000

    def in_region(q):
        return int(np.sum((np.abs(q[:, 0] - 20) < 4) & (np.abs(q[:, 1] - 20) < 4)))

    far, _ = idx.select(_cam((0, 0, 200), (0, 0, 0)), vp, budget)
    near, _ = idx.select(_cam((20, 20, 18), (20, 20, 0)), vp, budget)
    assert in_region(far) < 40
    assert in_region(near) > 4 * in_region(far)
    assert in_region(near) <= in_region(p)


def test_refusals(built, tmp_path):
    d, _, _, _ = built
    (tmp_path / "a.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n")
    with pytest.raises(InputError, match="ASCII PLY"):
        build_store(tmp_path / "a.ply", tmp_path / "s")
    with pytest.raises(InputError, match="not empty"):
        build_store(d / "c.ply", d / "store")
    with pytest.raises(InputError, match="no meta.json"):
        LodIndex.open(tmp_path)
    with pytest.raises(InputError, match="NaN"):
        LodIndex.from_points([[0, 0, np.nan]])


def test_a_failed_build_leaves_no_folder(built, tmp_path, monkeypatch):
    import camcmm.bigcloud.store as store

    def broken(*args):
        raise OSError("disk full")

    monkeypatch.setattr(store, "layout", broken)  # fails in the last pass, the folder half written
    with pytest.raises(OSError, match="disk full"):
        build_store(built[0] / "c.ply", tmp_path / "st", chunk=5000)
    assert not (tmp_path / "st").exists()
    (tmp_path / "empty").mkdir()  # a folder that was there stays, emptied
    with pytest.raises(OSError):
        build_store(built[0] / "c.ply", tmp_path / "empty", chunk=5000)
    assert (tmp_path / "empty").is_dir() and not any((tmp_path / "empty").iterdir())
