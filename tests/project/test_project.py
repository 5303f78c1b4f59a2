"""The project store: opening, schema migrations, files, measurements, results, state."""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
import sys
import threading
import types
from pathlib import Path

import numpy as np
import pytest

from camcmm.errors import InputError, ProjectError
from camcmm.host import RunResult
from camcmm.model import Artefact, Certificate, PointCloud
from camcmm.project import DB_NAME, MIGRATIONS, SCHEMA_VERSION, Project, schema
from camcmm.project.jsonutil import dumps

RUN = {
    "plugin": "fit.sphere",
    "version": "1.2.0",
    "params": {"max_iter": 50},
    "input_hashes": {"cloud": "ab" * 32},
    "outputs": {"radius": 10.01},
    "started": "2024-01-01T00:00:00.000+00:00",
    "finished": "2024-01-01T00:00:01.000+00:00",
    "warnings": ["few points"],
}


def sha(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.fixture
def proj(tmp_path):
    p = Project.create(tmp_path / "proj", name="Test project")
    yield p
    p.close()


@pytest.fixture
def src(tmp_path):
    f = tmp_path / "cloud.PLY"
    f.write_bytes(b"ply\nformat ascii 1.0\nend_header\n1 2 3\n")
    return f


def raw(project_dir: Path) -> sqlite3.Connection:
    return sqlite3.connect(project_dir / DB_NAME)


# -- create / open -------------------------------------------------------------------------
def test_create_open_roundtrip(tmp_path):
    root = tmp_path / "a" / "b"
    with Project.create(root, name="Ball plate 2024") as p:
        assert p.path == root and p.name == "Ball plate 2024" and p.schema_version == SCHEMA_VERSION == 3
        assert (root / DB_NAME).is_file() and (root / "data").is_dir()
        p.set_state("wizard", {"step": 3})
    with Project.open(root) as p:
        assert p.name == "Ball plate 2024" and p.get_state("wizard") == {"step": 3}
        assert p._conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        assert p._conn.execute("PRAGMA synchronous").fetchone()[0] == 2  # FULL
    with Project.open(root / DB_NAME) as p:  # the database file itself is accepted too
        assert p.path == root
    assert Project.open_or_create(root).name == "Ball plate 2024"
    with Project.open_or_create(tmp_path / "new") as p:
        assert p.name == "new"  # default name: the folder's


def test_closed_project_raises(proj):
    proj.close()
    proj.close()  # idempotent
    with pytest.raises(ProjectError, match="closed"):
        proj.measurements()


def test_create_in_empty_existing_folder(tmp_path):
    (tmp_path / "empty").mkdir()
    Project.create(tmp_path / "empty").close()


def test_create_refuses_non_project_folder(tmp_path):
    d = tmp_path / "photos"
    d.mkdir()
    (d / "img001.png").write_bytes(b"x")
    with pytest.raises(ProjectError, match="not empty") as e:
        Project.create(d)
    assert str(d) in str(e.value)
    assert not (d / DB_NAME).exists()
    with pytest.raises(ProjectError):
        Project.open_or_create(d)
    (tmp_path / "file").write_text("x")
    with pytest.raises(ProjectError, match="is a file"):
        Project.create(tmp_path / "file")


def test_create_refuses_existing_project(proj):
    with pytest.raises(ProjectError, match="already a camcmm project"):
        Project.create(proj.path)


def test_create_retries_after_interrupted_create(tmp_path):
    root = tmp_path / "p"
    (root / "data" / ".tmp").mkdir(parents=True)
    (root / f".{DB_NAME}.999.1.tmp").write_bytes(b"half")  # what a crash in create leaves
    Project.create(root).close()


def test_open_errors(tmp_path):
    with pytest.raises(ProjectError, match="no such project folder"):
        Project.open(tmp_path / "nope")
    (tmp_path / "plain").mkdir()
    with pytest.raises(ProjectError, match="not a camcmm project"):
        Project.open(tmp_path / "plain")
    (tmp_path / "f.txt").write_text("x")
    with pytest.raises(ProjectError, match="is a file"):
        Project.open(tmp_path / "f.txt")


def test_open_corrupt_database(tmp_path):
    root = tmp_path / "bad"
    root.mkdir()
    (root / DB_NAME).write_bytes(np.random.default_rng(1).bytes(8192))
    with pytest.raises(ProjectError) as e:
        Project.open(root)
    msg = str(e.value)
    assert "corrupt database" in msg and str(root / DB_NAME) in msg and "\n" not in msg


def test_open_damaged_page(proj):
    for i in range(50):
        proj.set_state(f"k{i}", "x" * 500)
    proj.close()
    db = proj.path / DB_NAME
    data = bytearray(db.read_bytes())
    assert len(data) > 3 * 4096
    data[4096 + 8 : 4096 + 400] = b"\xff" * 392  # scribble over the second page
    db.write_bytes(bytes(data))
    with pytest.raises(ProjectError, match="corrupt database .*project.sqlite"):
        Project.open(proj.path)


def test_open_foreign_sqlite_and_empty_file(tmp_path):
    root = tmp_path / "other"
    root.mkdir()
    c = sqlite3.connect(root / DB_NAME)
    c.execute("CREATE TABLE photos (id INTEGER)")
    c.commit()
    c.close()
    with pytest.raises(ProjectError, match="not a camcmm project.*no camcmm meta table"):
        Project.open(root)
    (root / DB_NAME).write_bytes(b"")
    with pytest.raises(ProjectError, match="empty database"):
        Project.open(root)


def test_newer_schema_is_refused(proj):
    proj.close()
    c = raw(proj.path)
    c.execute("UPDATE meta SET value = '7' WHERE key = 'schema_version'")
    c.commit()
    c.close()
    with pytest.raises(ProjectError) as e:
        Project.open(proj.path)
    assert f"was written by camcmm schema 7; this version reads up to {SCHEMA_VERSION}" in str(e.value)


# -- schema migrations -------------------------------------------------------------------
def make_v1_project(root: Path) -> str:
    """A project as camcmm schema 1 wrote it, from the frozen DDL."""
    root.mkdir()
    (root / "data" / "ab").mkdir(parents=True)
    blob = b"v1 cloud"
    h = hashlib.sha256(blob).hexdigest()
    (root / "data" / h[:2]).mkdir(exist_ok=True)
    (root / "data" / h[:2] / f"{h}.xyz").write_bytes(blob)
    c = sqlite3.connect(root / DB_NAME)
    c.executescript(MIGRATIONS[0])
    c.executemany(
        "INSERT INTO meta VALUES (?, ?)",
        [("schema_version", "1"), ("name", "old one"), ("created", "2023-05-01T00:00:00+00:00")],
    )
    c.execute("INSERT INTO files VALUES (?, '.xyz', ?, 'old.xyz', '2023')", (h, len(blob)))
    c.execute("INSERT INTO measurements(name, kind, hash, created) VALUES ('m', 'pointcloud', ?, '2023')", (h,))
    c.execute(
        "INSERT INTO results(plugin, version, params, input_hashes, outputs, created) "
        "VALUES ('fit.plane', '0.9', '{\"k\": 1}', '{}', '{\"flatness\": 0.01}', '2023')"
    )
    c.execute("INSERT INTO result_measurements VALUES (1, 1)")
    c.commit()
    c.close()
    return h


def test_v1_project_is_migrated(tmp_path):
    root = tmp_path / "v1"
    h = make_v1_project(root)
    c = raw(root)
    assert "label" not in [r[1] for r in c.execute("PRAGMA table_info(results)")]
    c.close()
    with Project.open(root) as p:
        assert p.schema_version == SCHEMA_VERSION and p.name == "old one"
        (old,) = p.results()
        assert old["plugin"] == "fit.plane" and old["label"] == "" and old["params"] == {"k": 1}
        assert old["measurement_ids"] == [1]
        assert p.measurement(1)["hash"] == h and p.file_path(h).read_bytes() == b"v1 cloud"
        rid = p.add_result(RUN, [1], label="after migration")
        assert p.result(rid)["label"] == "after migration"
        assert p.verify() == []
    c = raw(root)
    assert c.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone() == (str(SCHEMA_VERSION),)
    c.close()
    backup = root / f"{DB_NAME}.schema1.bak"  # what the old camcmm can still read
    b = sqlite3.connect(backup)
    assert b.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone() == ("1",)
    assert b.execute("SELECT count(*) FROM results").fetchone() == (1,)
    b.close()
    with Project.open(root) as p:  # opening again: nothing left to migrate
        assert len(p.results()) == 2


def test_failed_migration_leaves_previous_version(tmp_path, monkeypatch):
    root = tmp_path / "v1"
    make_v1_project(root)

    def broken(conn):
        conn.execute("ALTER TABLE results ADD COLUMN label TEXT NOT NULL DEFAULT ''")
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(schema, "MIGRATIONS", [MIGRATIONS[0], broken])
    with pytest.raises(ProjectError, match="from schema 1 to 2 failed.*disk on fire.*left at schema 1"):
        Project.open(root)
    c = raw(root)
    assert c.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone() == ("1",)
    assert "label" not in [r[1] for r in c.execute("PRAGMA table_info(results)")]  # DDL rolled back
    c.close()
    monkeypatch.undo()
    with Project.open(root) as p:
        assert p.schema_version == SCHEMA_VERSION


def test_fresh_schema_equals_migrated_schema(tmp_path):
    """Creating at the newest version and migrating an old project give the same tables."""
    make_v1_project(tmp_path / "old")
    Project.open(tmp_path / "old").close()
    Project.create(tmp_path / "new").close()

    def columns(root):
        c = raw(root)
        tables = [r[0] for r in c.execute("SELECT name FROM sqlite_master WHERE type='table' ORDER BY name")]
        out = {t: [tuple(r)[1:] for r in c.execute(f"PRAGMA table_info({t})")] for t in tables}
        c.close()
        return out

    assert columns(tmp_path / "old") == columns(tmp_path / "new")


def test_statement_splitter():
    assert schema.statements("CREATE TABLE a (x TEXT DEFAULT ';');\n-- note\nCREATE TABLE b (y);\n") == [
        "CREATE TABLE a (x TEXT DEFAULT ';');",
        "-- note\nCREATE TABLE b (y);",
    ]
    with pytest.raises(ValueError):
        schema.statements("CREATE TABLE a (x)")


# -- data files ----------------------------------------------------------------------------
def test_add_file_content_addressed(proj, src, tmp_path):
    h = proj.add_file(src)
    assert h == sha(src)
    path = proj.file_path(h)
    assert path == proj.path / "data" / h[:2] / f"{h}.ply"  # extension kept, lower-cased
    assert path.read_bytes() == src.read_bytes()
    assert proj.add_file(src) == h  # idempotent
    copy = tmp_path / "same.xyz"
    copy.write_bytes(src.read_bytes())
    assert proj.add_file(copy) == h and proj.file_path(h) == path  # same bytes: first name kept
    assert len(proj.files()) == 1 and proj.files()[0]["original_name"] == "cloud.PLY"
    assert list((proj.path / "data" / ".tmp").iterdir()) == []  # no temp files left behind
    noext = tmp_path / "README"
    noext.write_text("hi")
    assert proj.file_path(proj.add_file(noext)).name == sha(noext)


def test_add_file_bad_input(proj, tmp_path):
    with pytest.raises(InputError, match="no such file: .*missing.ply"):
        proj.add_file(tmp_path / "missing.ply")
    with pytest.raises(InputError, match="is not a file"):
        proj.add_file(tmp_path)
    with pytest.raises(ProjectError, match="not in project"):
        proj.file_path("0" * 64)
    with pytest.raises(ProjectError, match="not a file hash"):
        proj.file_path("../../etc/passwd")


def test_file_missing_on_disk_is_reported(proj, src):
    h = proj.add_file(src)
    proj.file_path(h).unlink()
    with pytest.raises(ProjectError, match="missing"):
        proj.file_path(h)
    assert any("missing data file" in p for p in proj.verify())
    assert proj.add_file(src) == h and proj.verify() == []  # adding it again repairs it


# -- measurements ----------------------------------------------------------------------------
def test_measurements(proj, src):
    h = proj.add_file(src)
    sid = proj.add_system("ATOS-like stereo", {"measuring_volume": [500, 400, 300], "calibration": h})
    proj.add_artefact(Artefact("S1", "sphere", nominal={"diameter": 25.0}))
    mid = proj.add_measurement(
        "sphere pos 1",
        h,
        system_id=sid,
        artefact_id="S1",
        meta={"exposure_ms": np.float32(12.5), "temp": np.nan, "n": np.int64(3)},
    )
    (m,) = proj.measurements()
    assert m == proj.measurement(mid)
    assert m["id"] == mid and m["name"] == "sphere pos 1" and m["kind"] == "pointcloud" and m["hash"] == h
    assert Path(m["path"]) == proj.file_path(h) and m["created"].endswith("+00:00")
    assert m["meta"] == {"exposure_ms": 12.5, "temp": None, "n": 3}
    assert m["system_id"] == sid and m["artefact_id"] == "S1" and m["removed"] is None
    mesh = proj.add_measurement("nominal", h, kind="mesh")
    assert [x["id"] for x in proj.measurements()] == [mid, mesh]


def test_add_measurement_bad_references(proj, src):
    with pytest.raises(ProjectError, match="not in the project; add it with add_file"):
        proj.add_measurement("m", "a" * 64)
    with pytest.raises(ProjectError, match="not a file hash"):
        proj.add_measurement("m", "abc")
    h = proj.add_file(src)
    with pytest.raises(ProjectError, match="no measuring system with id 42"):
        proj.add_measurement("m", h, system_id=42)
    with pytest.raises(ProjectError, match="no artefact"):
        proj.add_measurement("m", h, artefact_id="nope")
    with pytest.raises(ProjectError, match="name"):
        proj.add_measurement("", h)
    with pytest.raises(ProjectError, match="no measurement with id 9"):
        proj.measurement(9)
    assert proj.measurements() == []


def test_remove_measurement_keeps_results(proj, src):
    h = proj.add_file(src)
    mid = proj.add_measurement("m", h)
    keep = proj.add_measurement("k", h)
    rid = proj.add_result(RUN, [mid], {"cloud": h})
    proj.remove_measurement(mid)
    proj.remove_measurement(mid)  # idempotent
    assert [m["id"] for m in proj.measurements()] == [keep]
    assert [m["id"] for m in proj.measurements(include_removed=True)] == [mid, keep]
    assert proj.measurement(mid)["removed"] is not None
    r = proj.result(rid)
    assert r["measurement_ids"] == [mid] and r["input_hashes"] == RUN["input_hashes"]
    assert proj.file_path(h).is_file()
    assert proj.add_measurement("new", h) > keep  # ids are never reused
    with pytest.raises(ProjectError, match="no measurement with id 99"):
        proj.remove_measurement(99)


# -- results -------------------------------------------------------------------------------
def test_results_from_runresult_and_dict(proj, src):
    h = proj.add_file(src)
    mid = proj.add_measurement("m", h)
    run = RunResult(
        "fit.sphere",
        "1.2.0",
        {"tol": np.float64(1e-6), "robust": np.bool_(True)},
        {"cloud": h},
        {
            "center": np.array([1.0, 2.0, 3.0]),
            "radius": np.float32(5.5),
            "rms": float("nan"),
            "cloud": PointCloud(np.zeros((4, 3)), name="c"),
        },
        "2024-01-01T00:00:00.000+00:00",
        "2024-01-01T00:00:02.000+00:00",
        ["few points"],
    )
    r1 = proj.add_result(run, [mid], {"residuals": h}, label="first")
    r2 = proj.add_result(dict(RUN, plugin="fit.plane"))
    r = proj.result(r1)
    assert r == proj.results()[0]
    assert r["plugin"] == "fit.sphere" and r["version"] == "1.2.0"
    assert r["params"] == {"tol": 1e-6, "robust": True} and r["input_hashes"] == {"cloud": h}
    assert r["outputs"] == {
        "center": [1.0, 2.0, 3.0],
        "radius": 5.5,
        "rms": None,
        "cloud": {"kind": "pointcloud", "name": "c", "n_points": 4},
    }
    assert r["started"] == run.started and r["finished"] == run.finished and r["warnings"] == ["few points"]
    assert r["measurement_ids"] == [mid] and r["files"] == {"residuals": h} and r["label"] == "first"
    assert [x["id"] for x in proj.results()] == [r1, r2]
    assert [x["id"] for x in proj.results("fit.plane")] == [r2]
    assert proj.results("nothing") == []
    assert proj.result(r2)["files"] == {} and proj.result(r2)["label"] == ""


def test_add_result_is_one_transaction(proj, src):
    h = proj.add_file(src)
    mid = proj.add_measurement("m", h)
    with pytest.raises(ProjectError, match="output file 'plot'.*not in the project"):
        proj.add_result(RUN, [mid], {"ok": h, "plot": "c" * 64})
    with pytest.raises(ProjectError, match="no measurement with id 5"):
        proj.add_result(RUN, [mid, 5])
    assert proj.results() == []
    c = raw(proj.path)
    assert c.execute("SELECT count(*) FROM result_measurements").fetchone() == (0,)
    assert c.execute("SELECT count(*) FROM sqlite_sequence WHERE name='results'").fetchone() == (0,)
    c.close()


def test_add_result_bad_run(proj):
    with pytest.raises(ProjectError, match="version"):
        proj.add_result({"plugin": "x"})
    with pytest.raises(ProjectError, match="RunResult"):
        proj.add_result(42)
    with pytest.raises(ProjectError, match=r"cannot store fit.x outputs\['f'\] of type builtin_function"):
        proj.add_result({"plugin": "fit.x", "version": "1", "outputs": {"f": print}})
    assert proj.results() == []


def test_json_columns():
    assert json.loads(
        dumps(
            {
                "a": np.float64("nan"),
                "b": [np.int32(2), float("inf")],
                3: (1, 2),
                "c": np.array([[1, 2]], dtype=np.uint8),
                "p": Path("/x"),
            }
        )
    ) == {"a": None, "b": [2, None], "3": [1, 2], "c": [[1, 2]], "p": "/x"}


# -- systems, artefacts, state ---------------------------------------------------------------
def test_systems(proj):
    a = proj.add_system("rig A", {"measuring_volume": {"x": 500}})
    b = proj.add_system("rig B")
    assert [s["name"] for s in proj.systems()] == ["rig A", "rig B"]
    assert proj.system(a)["meta"] == {"measuring_volume": {"x": 500}} and proj.system(b)["meta"] == {}
    proj.update_system(b, meta={"calibration": "f" * 64})
    assert proj.system(b)["meta"] == {"calibration": "f" * 64} and proj.system(b)["name"] == "rig B"
    with pytest.raises(ProjectError, match="no measuring system with id 7"):
        proj.update_system(7, name="x")


def test_artefacts_upsert(proj):
    ball = Artefact(
        "BB-1", "ballbar", "Ball bar 1", {"length": 800.0}, {"length": Certificate(800.0123, 0.0015, 2.0)}, "cal. 2024"
    )
    proj.add_artefact(ball)
    proj.add_artefact({"id": "S-25", "kind": "sphere", "nominal": {"diameter": 25.0}})
    ball.notes = "recalibrated"
    ball.certificates["length"] = Certificate(800.0119, 0.0012)
    proj.add_artefact(ball)
    arts = proj.artefacts()
    assert [a.id for a in arts] == ["BB-1", "S-25"]
    assert arts[0].notes == "recalibrated" and arts[0].certificates["length"].value == 800.0119
    assert arts[0].certificates["length"].expanded_uncertainty == 0.0012
    assert proj.artefact("S-25").nominal == {"diameter": 25.0}
    with pytest.raises(ProjectError, match="no artefact"):
        proj.artefact("X")


def test_state(proj):
    assert proj.get_state("wizard") is None and proj.get_state("wizard", {"step": 0}) == {"step": 0}
    proj.set_state("wizard", {"step": 2, "picked": np.array([1, 2])})
    proj.set_state("wizard", {"step": 3})
    proj.set_state("nothing", None)
    assert proj.get_state("wizard") == {"step": 3} and proj.get_state("nothing", 5) is None


# -- objects via camcmm.io ---------------------------------------------------------------------
@pytest.fixture
def fake_io(monkeypatch):
    """A stand-in for camcmm.io (written elsewhere) that stores xyz text."""
    mod = types.ModuleType("camcmm.io")

    def write(obj, path):
        assert Path(path).suffix == ".ply"
        np.savetxt(path, obj.points)

    def read(path):
        return PointCloud(np.loadtxt(path, ndmin=2), name=Path(path).name)

    mod.write, mod.read = write, read
    monkeypatch.setitem(sys.modules, "camcmm.io", mod)
    return mod


def test_add_object_and_load_measurement(proj, fake_io):
    cloud = PointCloud(np.arange(12.0).reshape(4, 3), name="scan")
    h = proj.add_object(cloud, "scan")
    assert proj.file_path(h).suffix == ".ply" and proj.files()[0]["original_name"] == "scan.ply"
    mid = proj.add_measurement("scan 1", h)
    back = proj.load_measurement(mid)
    assert isinstance(back, PointCloud) and back.name == "scan 1"
    np.testing.assert_array_equal(back.points, cloud.points)
    assert proj.add_object(cloud, "again") == h
    assert list((proj.path / "data" / ".tmp").iterdir()) == []


def test_add_object_write_failure_leaves_nothing(proj, fake_io):
    def broken(obj, path):
        Path(path).write_text("half")
        raise OSError("disk full")

    fake_io.write = broken
    with pytest.raises(ProjectError, match="cannot write 'scan'.*disk full"):
        proj.add_object(PointCloud(np.zeros((1, 3))), "scan")
    assert proj.files() == [] and list((proj.path / "data" / ".tmp").iterdir()) == []


def test_add_object_with_real_io(proj):
    io = pytest.importorskip("camcmm.io")
    if not hasattr(io, "write") or not hasattr(io, "read"):
        pytest.skip("camcmm.io has no read/write yet")
    cloud = PointCloud(np.random.default_rng(0).normal(size=(50, 3)), name="scan")
    mid = proj.add_measurement("scan", proj.add_object(cloud, "scan"))
    np.testing.assert_allclose(proj.load_measurement(mid).points, cloud.points, atol=1e-6)


# -- threads ---------------------------------------------------------------------------------
def test_worker_threads(proj, tmp_path):
    n_threads, per_thread = 8, 15
    errors, ids = [], []
    barrier = threading.Barrier(n_threads)

    def work(t):
        try:
            barrier.wait()
            for i in range(per_thread):
                f = tmp_path / f"t{t}-{i}.bin"
                f.write_bytes(f"{t}-{i}".encode() * 100)
                h = proj.add_file(f)
                mid = proj.add_measurement(f"t{t}-{i}", h)
                rid = proj.add_result(dict(RUN, params={"t": t, "i": i}), [mid], {"data": h})
                proj.set_state(f"thread{t}", i)
                assert proj.result(rid)["files"]["data"] == h
                proj.results()
                ids.append((rid, h))
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(t,)) for t in range(n_threads)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert errors == []
    assert len(ids) == n_threads * per_thread == len(proj.results()) == len({r for r, _ in ids})
    for rid, h in ids:
        assert sha(proj.file_path(proj.result(rid)["files"]["data"])) == h
    assert [proj.get_state(f"thread{t}") for t in range(n_threads)] == [per_thread - 1] * n_threads
    assert proj.verify() == []


def test_two_handles_on_one_project(proj, src):
    """The CLI and the GUI may have the same project open."""
    other = Project.open(proj.path)
    try:
        h = other.add_file(src)
        mid = other.add_measurement("from the CLI", h)
        assert proj.measurement(mid)["name"] == "from the CLI"
        rid = proj.add_result(RUN, [mid])
        assert other.result(rid)["measurement_ids"] == [mid]
    finally:
        other.close()


def test_old_leftovers_are_swept(tmp_path):
    root = tmp_path / "p"
    Project.create(root).close()
    old_tmp = root / "data" / ".tmp" / "123-abc"
    old_db = root / f".{DB_NAME}.123.4.tmp"
    young = root / "data" / ".tmp" / f"{os.getpid()}-def"  # a running writer's: kept
    young.parent.mkdir()
    for f in (old_tmp, old_db, young):
        f.write_bytes(b"x")
    day_ago = os.path.getmtime(young) - 86400 * 2
    os.utime(old_tmp, (day_ago, day_ago))
    os.utime(old_db, (day_ago, day_ago))
    Project.open(root).close()
    assert not old_tmp.exists() and not old_db.exists() and young.exists()


def test_migration_breaking_a_foreign_key_is_rolled_back(tmp_path, monkeypatch):
    root = tmp_path / "v1"
    make_v1_project(root)
    monkeypatch.setattr(schema, "MIGRATIONS", [MIGRATIONS[0], "DELETE FROM files;"])
    with pytest.raises(ProjectError, match="broke a foreign key"):
        Project.open(root)
    monkeypatch.undo()
    with Project.open(root) as p:
        assert p.verify() == [] and len(p.files()) == 1
