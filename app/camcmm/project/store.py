"""The :class:`Project`: a folder with ``project.sqlite`` and content-addressed data.

Durability rules (design principle: nothing is lost; a crash at any point leaves every
completed result):

* Every ``add_*``/``set_*`` is exactly one SQLite transaction.
* A data file is written to a temp file, fsynced and renamed into place (see
  :mod:`.blobs`) *before* the transaction that inserts the row naming it commits.
  Hence a row never points to a missing or truncated file; a crash in between leaves
  at most an unreferenced file, which costs disk space and nothing else.
* WAL journal with ``synchronous=FULL``. With WAL, ``NORMAL`` is already safe against
  a killed *process* (the WAL is in the OS page cache), but a power cut or kernel
  panic may then roll back the last commits. A result the GUI has shown as saved must
  survive that too, and FULL costs only one fsync of the WAL per commit - small next
  to the fsync of the data file that goes with nearly every result.
* Rows are never deleted: measurements are soft-deleted, results are immutable
  (rename, hide, delete and restore: :mod:`.tidy`).

Threads: the GUI calls the store from worker threads. We keep ONE connection
(``check_same_thread=False``) guarded by a re-entrant lock rather than one connection
per thread: SQLite admits one writer at a time anyway, so per-thread connections buy
no write parallelism, but they would make our own threads wait on each other's
SQLITE_BUSY, and the connections of finished pool threads would leak. Statements here
touch metadata only and take microseconds; the slow work (copying and hashing data
files, writing clouds) runs outside the lock. Other *processes* (the CLI on the same
project) are handled by SQLite's file locking and the busy timeout.
"""

from __future__ import annotations

import importlib
import os
import re
import sqlite3
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import CamcmmError, InputError, ProjectError
from ..hashing import file_hash
from ..jsonable import utc_now
from . import schema
from .blobs import BlobStore, check_hash, fsync_dir, normalise_ext, orphaned
from .jsonutil import dumps, loads
from .tidy import TidyMixin, hidden_of

DB_NAME = "project.sqlite"
DATA_DIR = "data"
#: Temp databases of an interrupted create (``.project.sqlite.<pid>.<thread>.tmp`` and its
#: -wal/-shm) or migration backup (``.project.sqlite.<pid>.bak.tmp``).
_DB_TMP_PID = re.compile(rf"^\.{re.escape(DB_NAME)}\.(\d+)\.")
BUSY_TIMEOUT_S = 10.0  # another process (CLI, second GUI) may hold the write lock briefly


#: Now, UTC, ISO 8601 with milliseconds: the one clock, under the name callers know here.
utcnow = utc_now


def _connect(db: Path, create: bool = False) -> sqlite3.Connection:
    # A URI with mode=rw makes open() fail on a missing file instead of silently
    # creating an empty database. isolation_level=None: we issue BEGIN IMMEDIATE/COMMIT
    # ourselves (see Project._tx).
    uri = db.absolute().as_uri() + ("?mode=rwc" if create else "?mode=rw")
    conn = sqlite3.connect(uri, uri=True, timeout=BUSY_TIMEOUT_S, isolation_level=None, check_same_thread=False)
    conn.row_factory = sqlite3.Row
    return conn


def _set_pragmas(conn: sqlite3.Connection) -> None:
    conn.execute("PRAGMA journal_mode=WAL")  # persistent; may stay 'delete' on odd file systems
    conn.execute("PRAGMA synchronous=FULL")  # why FULL and not NORMAL: see the module docstring


def _enforce_foreign_keys(conn: sqlite3.Connection) -> None:
    # Switched on only after migrating: a migration that rebuilds a table (SQLite's
    # 12-step ALTER) must run with it off; schema.apply checks the keys itself instead.
    conn.execute("PRAGMA foreign_keys=ON")


def _only_leftovers(root: Path) -> bool:
    """True if ``root`` holds nothing but what an interrupted :meth:`Project.create`
    leaves (an empty ``data`` tree, a temp database), so create may be retried."""
    for p in root.iterdir():
        if p.name == DATA_DIR and p.is_dir():
            if any(f.is_file() for f in p.rglob("*")):
                return False
        elif not p.name.startswith(f".{DB_NAME}."):
            return False
    return True


class Project(TidyMixin):
    """A camcmm project folder. Make one with :meth:`create`, :meth:`open` or
    :meth:`open_or_create`; close it with :meth:`close` or use it as a context manager.

    All methods may be called from several threads. Errors are :class:`ProjectError`
    (or :class:`InputError` for a bad source file), with a one-line reason.
    """

    # -- opening and creating --------------------------------------------------------
    def __init__(self, root: Path, conn: sqlite3.Connection, schema_version: int):
        """Internal; use :meth:`open`, :meth:`create` or :meth:`open_or_create`."""
        self.path = root
        self.db_path = root / DB_NAME
        self.schema_version = schema_version
        self._conn: sqlite3.Connection | None = conn
        self._lock = threading.RLock()
        self._blobs = BlobStore(root / DATA_DIR)
        row = conn.execute("SELECT value FROM meta WHERE key = 'name'").fetchone()
        self.name: str = row[0] if row else root.name
        self._sweep_leftovers()

    def _sweep_leftovers(self, max_age_s: float = 3600.0) -> int:
        """Remove what killed writers left: temp data files and temp databases of an
        interrupted create or backup, each named with its writer's pid. Those of a
        writer that is no longer running go at once, the others after ``max_age_s``
        (a running writer's may be in use right now). Returns how many were removed."""
        n = self._blobs.sweep_tmp(max_age_s)
        now = time.time()
        for p in self.path.glob(f".{DB_NAME}.*"):
            m = _DB_TMP_PID.match(p.name)
            try:
                if orphaned(p.stat().st_mtime, int(m.group(1)) if m else None, now, max_age_s):
                    p.unlink()
                    n += 1
            except OSError:
                pass
        return n

    @classmethod
    def open(cls, path: str | os.PathLike) -> Project:
        """Open an existing project, migrating an older schema (after a backup copy
        ``project.sqlite.schema<N>.bak``). Raises ProjectError if the folder does not
        exist, is not a project, is from a newer camcmm, or its database is corrupt."""
        root = Path(path).expanduser()
        if root.name == DB_NAME and root.is_file():
            root = root.parent  # the database file itself was given
        root = root.absolute()
        if not root.exists():
            raise ProjectError(f"no such project folder: {root}")
        if not root.is_dir():
            raise ProjectError(f"{root} is a file, not a project folder")
        db = root / DB_NAME
        if not db.is_file():
            raise ProjectError(f"{root} is not a camcmm project (it has no {DB_NAME})")
        try:
            conn = _connect(db)
        except sqlite3.Error as exc:
            raise ProjectError(f"cannot open {db}: {exc}") from exc
        try:
            version = cls._check_and_migrate(conn, db)
            return cls(root, conn, version)
        except BaseException:
            conn.close()
            raise

    @classmethod
    def _check_and_migrate(cls, conn: sqlite3.Connection, db: Path) -> int:
        try:
            # quick_check reads every page (the database holds metadata only, so this
            # takes milliseconds) and turns garbage into an error here rather than a
            # strange failure in the middle of the operator's work.
            problems = [r[0] for r in conn.execute("PRAGMA quick_check").fetchall()]
            version = schema.read_version(conn)
        except sqlite3.OperationalError as exc:  # locked, unreadable, I/O error
            raise ProjectError(f"cannot read {db}: {exc}") from exc
        except sqlite3.DatabaseError as exc:  # not a database / malformed
            raise ProjectError(f"corrupt database {db}: {exc}") from exc
        if problems != ["ok"]:
            raise ProjectError(f"corrupt database {db}: {problems[0]}")
        latest = schema.latest()
        if version is None or version == 0:
            what = "is an empty database" if version == 0 else "has no camcmm meta table"
            raise ProjectError(f"{db.parent} is not a camcmm project: {db.name} {what}")
        if version > latest:
            raise ProjectError(
                f"project {db.parent} was written by camcmm schema {version}; "
                f"this version reads up to {latest}; update camcmm to open it"
            )
        try:
            _set_pragmas(conn)
        except sqlite3.Error as exc:
            raise ProjectError(f"cannot read {db}: {exc}") from exc
        if version < latest:
            cls._backup(conn, db, version)
            try:
                version = schema.migrate(conn, version, latest)
            except Exception as exc:
                reached = schema.read_version(conn) or 0
                raise ProjectError(
                    f"migrating {db} from schema {reached} to {reached + 1} failed "
                    f"({type(exc).__name__}: {exc}); the project was left at schema "
                    f"{reached}"
                ) from exc
        _enforce_foreign_keys(conn)
        return version

    @staticmethod
    def _backup(conn: sqlite3.Connection, db: Path, version: int) -> None:
        """Copy the database before migrating it, so that the camcmm that wrote it can
        still read the copy. Written to a temp name and renamed: never a half copy."""
        dest = db.with_name(f"{db.name}.schema{version}.bak")
        tmp = db.with_name(f".{db.name}.{os.getpid()}.bak.tmp")
        try:
            out = sqlite3.connect(tmp)
            try:
                conn.backup(out)
            finally:
                out.close()
            os.replace(tmp, dest)
            fsync_dir(db.parent)
        except (sqlite3.Error, OSError) as exc:
            tmp.unlink(missing_ok=True)
            raise ProjectError(f"cannot back up {db} before migrating it: {exc}") from exc

    @classmethod
    def create(cls, path: str | os.PathLike, name: str | None = None) -> Project:
        """Create a new project folder (and its parents). The folder may exist if it is
        empty. The database is built under a temp name and linked into place, so a
        crash never leaves a half-made ``project.sqlite``."""
        root = Path(path).expanduser().absolute()
        db = root / DB_NAME
        if root.exists():
            if not root.is_dir():
                raise ProjectError(f"cannot create a project at {root}: it is a file")
            if db.exists():
                raise ProjectError(f"{root} is already a camcmm project; open it instead")
            if not _only_leftovers(root):
                raise ProjectError(
                    f"cannot create a project in {root}: the folder is not empty and is not a camcmm project"
                )
        if not cls._create_db(root, name or root.name):
            raise ProjectError(f"{root} is already a camcmm project; open it instead")
        return cls.open(root)

    @classmethod
    def _create_db(cls, root: Path, name: str) -> bool:
        """Build the database; False if another process created one meanwhile."""
        db = root / DB_NAME
        tmp = root / f".{DB_NAME}.{os.getpid()}.{threading.get_ident()}.tmp"
        try:
            (root / DATA_DIR).mkdir(parents=True, exist_ok=True)
            tmp.unlink(missing_ok=True)
            conn = _connect(tmp, create=True)
            try:
                _set_pragmas(conn)
                schema.migrate(conn, 0)
                _enforce_foreign_keys(conn)
                now = utcnow()
                conn.execute("BEGIN IMMEDIATE")
                conn.executemany("INSERT INTO meta(key, value) VALUES (?, ?)", [("name", name), ("created", now)])
                conn.execute("COMMIT")
            finally:
                conn.close()  # checkpoints the WAL into the file and removes it
            fsync_dir(root)
            try:
                # link() fails if the name exists: two processes racing to create the
                # same project cannot overwrite each other's database.
                os.link(tmp, db)
            except FileExistsError:
                return False
            except OSError:  # file systems without hard links (FAT, some shares)
                if db.exists():
                    return False
                os.replace(tmp, db)
            fsync_dir(root)
            return True
        except (sqlite3.Error, OSError) as exc:
            raise ProjectError(f"cannot create a project in {root}: {exc}") from exc
        finally:
            for p in (tmp, tmp.with_name(tmp.name + "-wal"), tmp.with_name(tmp.name + "-shm")):
                try:
                    p.unlink(missing_ok=True)
                except OSError:
                    pass

    @classmethod
    def open_or_create(cls, path: str | os.PathLike, name: str | None = None) -> Project:
        """Open the project at ``path``, creating it if the folder is missing or empty."""
        root = Path(path).expanduser().absolute()
        if (root / DB_NAME).exists() or (root.name == DB_NAME and root.is_file()):
            return cls.open(root)
        try:
            return cls.create(root, name)
        except ProjectError:
            if (root / DB_NAME).exists():  # created by another process meanwhile
                return cls.open(root)
            raise

    def close(self) -> None:
        """Close the database (idempotent). Committed data is safe without it."""
        with self._lock:
            if self._conn is not None:
                try:
                    self._conn.close()
                finally:
                    self._conn = None

    def __enter__(self) -> Project:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._conn is None else f"schema {self.schema_version}"
        return f"<Project {self.name!r} at {self.path} ({state})>"

    # -- transactions ------------------------------------------------------------------
    def _live(self) -> sqlite3.Connection:
        if self._conn is None:
            raise ProjectError(f"project {self.path} is closed")
        return self._conn

    @contextmanager
    def _tx(self, what: str) -> Iterator[sqlite3.Connection]:
        """One write transaction. BEGIN IMMEDIATE takes the write lock up front: a
        deferred BEGIN (what ``with conn:`` does) that first reads and then writes can
        fail with SQLITE_BUSY when another process wrote meanwhile, and in WAL mode the
        busy timeout does not help then. ProjectErrors raised inside roll back too."""
        with self._lock:
            conn = self._live()
            try:
                conn.execute("BEGIN IMMEDIATE")
                try:
                    yield conn
                    conn.execute("COMMIT")
                except BaseException:
                    if conn.in_transaction:
                        conn.execute("ROLLBACK")
                    raise
            except sqlite3.Error as exc:
                raise ProjectError(f"{self.db_path}: {what} failed: {exc}") from exc

    @contextmanager
    def _read(self, what: str) -> Iterator[sqlite3.Connection]:
        with self._lock:
            conn = self._live()
            try:
                yield conn
            except sqlite3.Error as exc:
                raise ProjectError(f"{self.db_path}: {what} failed: {exc}") from exc

    def change_token(self) -> int | None:
        """A number that changes when another connection (another GUI session, the CLI)
        commits to this project; this object's own commits leave it alone (SQLite's
        ``PRAGMA data_version``). Costs one pragma, no table is read. None when the store
        is busy in another thread or closed: ask again later; never raises."""
        if not self._lock.acquire(blocking=False):
            return None
        try:
            if self._conn is None:
                return None
            return int(self._conn.execute("PRAGMA data_version").fetchone()[0])
        except sqlite3.Error:
            return None
        finally:
            self._lock.release()

    # -- data files ---------------------------------------------------------------------
    def add_file(self, src: str | os.PathLike) -> str:
        """Copy a file into the project; returns its sha256. Adding the same content
        again is a no-op that returns the same hash. InputError if ``src`` is missing."""
        tmp, h, size = self._blobs.copy_in(src)  # slow part, outside the lock
        return self._register(tmp, h, size, normalise_ext(src), Path(src).name)

    def add_object(self, obj: Any, name: str, ext: str | None = None) -> str:
        """Write a PointCloud/TriangleMesh/HeightMap with :func:`camcmm.io.write` and add
        the file; returns its sha256. ``ext`` picks the format: by default ``.ply``, and
        ``.x3p`` for a height map (ISO 25178-72 with camcmm's intensity and metadata
        members: it comes back whole, heights bit for bit)."""
        io = importlib.import_module("camcmm.io")  # lazy: the formats pull in Open3D
        if ext is None:
            ext = ".x3p" if type(obj).__name__ == "HeightMap" else ".ply"
        ext = normalise_ext("x" + (ext if ext.startswith(".") else f".{ext}")) or ".ply"
        tmp = self._blobs.new_tmp(suffix=ext)
        try:
            io.write(obj, tmp)
            h, size = self._blobs.seal(tmp)
        except BaseException as exc:
            tmp.unlink(missing_ok=True)
            if isinstance(exc, (CamcmmError, KeyboardInterrupt, SystemExit)):
                raise
            raise ProjectError(f"cannot write {name!r} into the project: {type(exc).__name__}: {exc}") from exc
        original = name if normalise_ext(name) == ext else f"{name}{ext}"
        return self._register(tmp, h, size, ext, original)

    def _register(self, tmp: Path, h: str, size: int, ext: str, original_name: str) -> str:
        with self._read("looking up a file") as conn:
            row = conn.execute("SELECT ext FROM files WHERE hash = ?", (h,)).fetchone()
        if row is not None:
            ext = row["ext"]  # same bytes, already known: keep the first name
        self._blobs.place(tmp, h, ext, size)  # durable on disk ...
        if row is None:
            with self._tx(f"adding file {original_name}") as conn:  # ... before the row commits
                conn.execute(
                    "INSERT INTO files(hash, ext, size, original_name, added) VALUES (?, ?, ?, ?, ?) "
                    "ON CONFLICT(hash) DO NOTHING",
                    (h, ext, size, original_name, utcnow()),
                )
        return h

    def has_file(self, h: str) -> bool:
        with self._read("looking up a file") as conn:
            return conn.execute("SELECT 1 FROM files WHERE hash = ?", (h,)).fetchone() is not None

    def file_path(self, h: str) -> Path:
        """The path of a data file in the project. ProjectError if the hash is unknown
        or its file is missing from disk."""
        check_hash(h)
        with self._read("looking up a file") as conn:
            row = conn.execute("SELECT ext FROM files WHERE hash = ?", (h,)).fetchone()
        if row is None:
            raise ProjectError(f"file {h} is not in project {self.path}")
        path = self._blobs.path(h, row["ext"])
        if not path.is_file():
            raise ProjectError(f"data file {path} is missing from project {self.path}")
        return path

    def files(self) -> list[dict[str, Any]]:
        """Every data file: hash, path, size, original_name, added."""
        with self._read("listing files") as conn:
            rows = conn.execute("SELECT * FROM files ORDER BY added, hash").fetchall()
        return [
            {
                "hash": r["hash"],
                "path": str(self._blobs.path(r["hash"], r["ext"])),
                "size": r["size"],
                "original_name": r["original_name"],
                "added": r["added"],
            }
            for r in rows
        ]

    # -- measuring systems and artefacts ------------------------------------------------
    def add_system(self, name: str, meta: dict[str, Any] | None = None) -> int:
        """Record a measuring system (cameras, projector, ...); ``meta`` holds e.g. the
        measuring volume and the hash of its calibration file. Returns its id."""
        name = _text(name, "system name")
        meta_json = dumps(meta or {}, f"system {name!r} meta")
        with self._tx(f"adding system {name!r}") as conn:
            cur = conn.execute("INSERT INTO systems(name, meta, created) VALUES (?, ?, ?)", (name, meta_json, utcnow()))
            return int(cur.lastrowid or 0)

    def update_system(self, sid: int, name: str | None = None, meta: dict[str, Any] | None = None) -> None:
        """Rename a system and/or replace its meta (e.g. after a new calibration)."""
        sets, args = [], []
        if name is not None:
            sets.append("name = ?")
            args.append(_text(name, "system name"))
        if meta is not None:
            sets.append("meta = ?")
            args.append(dumps(meta, f"system {sid} meta"))
        if not sets:
            return
        with self._tx(f"updating system {sid}") as conn:
            if conn.execute(f"UPDATE systems SET {', '.join(sets)} WHERE id = ?", (*args, int(sid))).rowcount == 0:
                raise ProjectError(f"no measuring system with id {sid} in project {self.path}")

    def systems(self) -> list[dict[str, Any]]:
        """id, name, meta (dict), created."""
        with self._read("listing systems") as conn:
            rows = conn.execute("SELECT * FROM systems ORDER BY id").fetchall()
        return [_system(r) for r in rows]

    def system(self, sid: int) -> dict[str, Any]:
        with self._read("reading a system") as conn:
            row = conn.execute("SELECT * FROM systems WHERE id = ?", (int(sid),)).fetchone()
        if row is None:
            raise ProjectError(f"no measuring system with id {sid} in project {self.path}")
        return _system(row)

    def add_artefact(self, artefact: Any) -> str:
        """Insert or replace (by id) a :class:`camcmm.model.Artefact` (or its dict);
        returns its id."""
        from ..model import Artefact  # lazy: model imports numpy

        if isinstance(artefact, dict):
            try:
                artefact = Artefact.from_dict(artefact)
            except (KeyError, TypeError, ValueError) as exc:
                raise InputError(f"artefact {artefact.get('id', '?')!r}: {type(exc).__name__}: {exc}") from exc
        if not isinstance(artefact, Artefact):
            raise ProjectError(f"add_artefact needs an Artefact, got {type(artefact).__name__}")
        aid = _text(artefact.id, "artefact id")
        data = dumps(artefact.to_dict(), f"artefact {aid!r}")
        with self._tx(f"saving artefact {aid!r}") as conn:
            conn.execute(
                "INSERT INTO artefacts(id, kind, data, updated) VALUES (?, ?, ?, ?) "
                "ON CONFLICT(id) DO UPDATE SET kind = excluded.kind, data = excluded.data, "
                "updated = excluded.updated",
                (aid, artefact.kind, data, utcnow()),
            )
        return aid

    def artefacts(self) -> list[Any]:
        """All artefacts as :class:`camcmm.model.Artefact`, sorted by id."""
        from ..model import Artefact

        with self._read("listing artefacts") as conn:
            rows = conn.execute("SELECT data FROM artefacts ORDER BY id").fetchall()
        return [Artefact.from_dict(loads(r["data"])) for r in rows]

    def artefact(self, aid: str) -> Any:
        from ..model import Artefact

        with self._read("reading an artefact") as conn:
            row = conn.execute("SELECT data FROM artefacts WHERE id = ?", (aid,)).fetchone()
        if row is None:
            raise ProjectError(f"no artefact with id {aid!r} in project {self.path}")
        return Artefact.from_dict(loads(row["data"]))

    # -- measurements ----------------------------------------------------------------------
    def add_measurement(
        self,
        name: str,
        file_hash: str,
        kind: str = "pointcloud",
        system_id: int | None = None,
        artefact_id: str | None = None,
        meta: dict[str, Any] | None = None,
    ) -> int:
        """Record a measurement whose data is the project file ``file_hash`` (from
        :meth:`add_file`/:meth:`add_object`). Returns its id."""
        name = _text(name, "measurement name")
        kind = _text(kind, f"measurement {name!r} kind")
        check_hash(file_hash)
        meta_json = dumps(meta or {}, f"measurement {name!r} meta")
        with self._tx(f"adding measurement {name!r}") as conn:
            if conn.execute("SELECT 1 FROM files WHERE hash = ?", (file_hash,)).fetchone() is None:
                raise ProjectError(
                    f"measurement {name!r}: file {file_hash} is not in the project; add it with add_file first"
                )
            if (
                system_id is not None
                and conn.execute("SELECT 1 FROM systems WHERE id = ?", (int(system_id),)).fetchone() is None
            ):
                raise ProjectError(f"measurement {name!r}: no measuring system with id {system_id}")
            if (
                artefact_id is not None
                and conn.execute("SELECT 1 FROM artefacts WHERE id = ?", (artefact_id,)).fetchone() is None
            ):
                raise ProjectError(f"measurement {name!r}: no artefact with id {artefact_id!r}")
            cur = conn.execute(
                "INSERT INTO measurements(name, kind, hash, system_id, artefact_id, meta, created) "
                "VALUES (?, ?, ?, ?, ?, ?, ?)",
                (
                    name,
                    kind,
                    file_hash,
                    None if system_id is None else int(system_id),
                    artefact_id,
                    meta_json,
                    utcnow(),
                ),
            )
            return int(cur.lastrowid or 0)

    _MEASUREMENT_SQL = "SELECT m.*, f.ext FROM measurements m JOIN files f ON f.hash = m.hash"

    def measurements(self, include_removed: bool = False) -> list[dict[str, Any]]:
        """Measurements in the order they were added: id, name, kind, hash, path,
        created (UTC ISO), meta (dict), system_id, artefact_id, removed (None or time),
        hidden (bool, see :mod:`.tidy`). Removed ones only with ``include_removed``."""
        where = "" if include_removed else " WHERE m.removed IS NULL"
        with self._read("listing measurements") as conn:
            rows = conn.execute(f"{self._MEASUREMENT_SQL}{where} ORDER BY m.id").fetchall()
        return [self._measurement(r) for r in rows]

    def measurement(self, mid: int) -> dict[str, Any]:
        """One measurement by id - also a removed one (with ``removed`` set), because
        results keep referring to it."""
        with self._read("reading a measurement") as conn:
            row = conn.execute(f"{self._MEASUREMENT_SQL} WHERE m.id = ?", (int(mid),)).fetchone()
        if row is None:
            raise ProjectError(f"no measurement with id {mid} in project {self.path}")
        return self._measurement(row)

    def _measurement(self, r: sqlite3.Row) -> dict[str, Any]:
        return {
            "id": r["id"],
            "name": r["name"],
            "kind": r["kind"],
            "hash": r["hash"],
            "path": str(self._blobs.path(r["hash"], r["ext"])),
            "created": r["created"],
            "meta": loads(r["meta"], {}),
            "system_id": r["system_id"],
            "artefact_id": r["artefact_id"],
            "removed": r["removed"],
            "hidden": hidden_of(r),
        }

    def load_measurement(self, mid: int) -> Any:
        """The measurement's data read with :func:`camcmm.io.read` (PointCloud or
        TriangleMesh), named after the measurement; in the length unit recorded as
        ``meta["unit"]`` when the import gave one (a file that does not state its own)."""
        m = self.measurement(mid)
        path = self.file_path(m["hash"])
        io = importlib.import_module("camcmm.io")
        unit = (m.get("meta") or {}).get("unit")
        obj = io.read(path, unit=str(unit)) if unit else io.read(path)
        if hasattr(obj, "name"):
            try:
                obj.name = m["name"]
            except AttributeError:
                pass
        return obj

    def remove_measurement(self, mid: int) -> None:
        """Hide a measurement from :meth:`measurements`. Nothing is deleted: its file
        stays, results that used it keep their ids and input hashes."""
        with self._tx(f"removing measurement {mid}") as conn:
            cur = conn.execute(
                "UPDATE measurements SET removed = ? WHERE id = ? AND removed IS NULL", (utcnow(), int(mid))
            )
            if (
                cur.rowcount == 0
                and conn.execute("SELECT 1 FROM measurements WHERE id = ?", (int(mid),)).fetchone() is None
            ):
                raise ProjectError(f"no measurement with id {mid} in project {self.path}")

    # -- results ---------------------------------------------------------------------------
    def add_result(
        self, run: Any, measurement_ids: Iterable[int] = (), files: dict[str, str] | None = None, label: str = ""
    ) -> int:
        """Record a plugin run: a :class:`camcmm.host.RunResult` or a dict like
        ``RunResult.to_json()``. ``files`` maps output names to hashes of data files
        already added for it (write them with add_file/add_object first). Returns its id."""
        d = _run_dict(run)
        plugin = d["plugin"]
        cols = (
            plugin,
            d["version"],
            dumps(d.get("params") or {}, f"{plugin} params"),
            dumps(d.get("input_hashes") or {}, f"{plugin} input_hashes"),
            dumps(d.get("outputs") or {}, f"{plugin} outputs"),
            d.get("started"),
            d.get("finished"),
            dumps(list(d.get("warnings") or []), f"{plugin} warnings"),
            utcnow(),
            str(label or ""),
        )
        mids = sorted({int(m) for m in measurement_ids})
        files = dict(files or {})
        for h in files.values():
            check_hash(h)
        with self._tx(f"saving result of {plugin}") as conn:
            if mids:
                found = {
                    r[0]
                    for r in conn.execute(
                        f"SELECT id FROM measurements WHERE id IN ({','.join('?' * len(mids))})", mids
                    )
                }
                missing = [m for m in mids if m not in found]
                if missing:
                    raise ProjectError(f"result of {plugin}: no measurement with id {missing[0]}")
            for out, h in files.items():
                if conn.execute("SELECT 1 FROM files WHERE hash = ?", (h,)).fetchone() is None:
                    raise ProjectError(
                        f"result of {plugin}: output file {out!r} ({h}) is not in the project; "
                        "add it with add_file first"
                    )
            cur = conn.execute(
                "INSERT INTO results(plugin, version, params, input_hashes, outputs, started, finished, "
                "warnings, created, label) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                cols,
            )
            rid = int(cur.lastrowid or 0)
            conn.executemany(
                "INSERT INTO result_measurements(result_id, measurement_id) VALUES (?, ?)", [(rid, m) for m in mids]
            )
            conn.executemany(
                "INSERT INTO result_files(result_id, name, hash) VALUES (?, ?, ?)",
                [(rid, str(k), h) for k, h in files.items()],
            )
            return rid

    def results(self, plugin_id: str | None = None) -> list[dict[str, Any]]:
        """Results in the order they were saved, optionally of one plugin: id, plugin,
        version, params, input_hashes, outputs, started, finished, warnings,
        measurement_ids, files ({name: hash}), label, created."""
        where, args = ("WHERE r.plugin = ?", (plugin_id,)) if plugin_id is not None else ("", ())
        with self._read("listing results") as conn:
            rows = conn.execute(f"SELECT r.* FROM results r {where} ORDER BY r.id", args).fetchall()
            links = conn.execute(
                f"SELECT x.* FROM result_measurements x JOIN results r ON r.id = x.result_id "
                f"{where} ORDER BY x.measurement_id",
                args,
            ).fetchall()
            outs = conn.execute(
                f"SELECT x.* FROM result_files x JOIN results r ON r.id = x.result_id {where} ORDER BY x.name", args
            ).fetchall()
        return _assemble(rows, links, outs)

    def result(self, rid: int) -> dict[str, Any]:
        with self._read("reading a result") as conn:
            rows = conn.execute("SELECT * FROM results WHERE id = ?", (int(rid),)).fetchall()
            links = conn.execute(
                "SELECT * FROM result_measurements WHERE result_id = ? ORDER BY measurement_id", (int(rid),)
            ).fetchall()
            outs = conn.execute("SELECT * FROM result_files WHERE result_id = ? ORDER BY name", (int(rid),)).fetchall()
        if not rows:
            raise ProjectError(f"no result with id {rid} in project {self.path}")
        return _assemble(rows, links, outs)[0]

    # -- small key/value state (GUI, wizard resume) -------------------------------------
    def set_state(self, key: str, value: Any) -> None:
        key = _text(key, "state key")
        text = dumps(value, f"state {key!r}")
        with self._tx(f"saving state {key!r}") as conn:
            conn.execute(
                "INSERT INTO state(key, value, updated) VALUES (?, ?, ?) ON CONFLICT(key) DO UPDATE "
                "SET value = excluded.value, updated = excluded.updated",
                (key, text, utcnow()),
            )

    def get_state(self, key: str, default: Any = None) -> Any:
        with self._read(f"reading state {key!r}") as conn:
            row = conn.execute("SELECT value FROM state WHERE key = ?", (key,)).fetchone()
        return default if row is None else loads(row["value"])

    # -- checking --------------------------------------------------------------------------
    def verify(self, hashes: bool = True) -> list[str]:
        """Problems found, one line each (empty when all is well): SQLite's integrity
        check, and every data file present with its size (and, if ``hashes``, its
        sha256) as recorded."""
        with self._read("checking the database") as conn:
            problems = [r[0] for r in conn.execute("PRAGMA integrity_check").fetchall() if r[0] != "ok"]
            problems += [f"foreign key: {tuple(r)}" for r in conn.execute("PRAGMA foreign_key_check")]
            rows = conn.execute("SELECT hash, ext, size FROM files").fetchall()
        for r in rows:
            path = self._blobs.path(r["hash"], r["ext"])
            if not path.is_file():
                problems.append(f"missing data file {path}")
            elif path.stat().st_size != r["size"]:
                problems.append(f"data file {path} has {path.stat().st_size} bytes, expected {r['size']}")
            elif hashes and file_hash(path) != r["hash"]:
                problems.append(f"data file {path} does not match its hash")
        return problems


# -- helpers ---------------------------------------------------------------------------------
def _text(value: Any, what: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ProjectError(f"{what} must be a non-empty string, got {value!r}")
    return value


def _run_dict(run: Any) -> dict[str, Any]:
    """A RunResult (anything with ``to_json``) or its dict, checked."""
    if hasattr(run, "to_json"):
        d = run.to_json()
    elif isinstance(run, dict):
        d = dict(run)
        d.setdefault("plugin", d.pop("plugin_id", None))
        d.setdefault("version", d.pop("plugin_version", None))
    else:
        raise ProjectError(f"add_result needs a RunResult or its dict, got {type(run).__name__}")
    for key in ("plugin", "version"):
        if not isinstance(d.get(key), str) or not d[key]:
            raise ProjectError(
                f"result has no {key!r} (got {d.get(key)!r}); every result records "
                "the plugin id and version that made it"
            )
    return d


def _system(r: sqlite3.Row) -> dict[str, Any]:
    return {"id": r["id"], "name": r["name"], "meta": loads(r["meta"], {}), "created": r["created"]}


def _assemble(rows: list[sqlite3.Row], links: list[sqlite3.Row], outs: list[sqlite3.Row]) -> list[dict[str, Any]]:
    mids: dict[int, list[int]] = {}
    for x in links:
        mids.setdefault(x["result_id"], []).append(x["measurement_id"])
    files: dict[int, dict[str, str]] = {}
    for x in outs:
        files.setdefault(x["result_id"], {})[x["name"]] = x["hash"]
    return [
        {
            "id": r["id"],
            "plugin": r["plugin"],
            "version": r["version"],
            "params": loads(r["params"], {}),
            "input_hashes": loads(r["input_hashes"], {}),
            "outputs": loads(r["outputs"], {}),
            "started": r["started"],
            "finished": r["finished"],
            "warnings": loads(r["warnings"], []),
            "measurement_ids": mids.get(r["id"], []),
            "files": files.get(r["id"], {}),
            "label": r["label"],
            "created": r["created"],
        }
        for r in rows
    ]
