"""Database schema and its migrations.

``MIGRATIONS[n]`` takes a database from schema version ``n`` to ``n + 1`` (version 0 is
an empty database), so ``MIGRATIONS[0]`` is the frozen DDL of version 1. Never edit a
released entry: an old project must migrate through exactly the steps its version
missed. To change the schema, append a step; ``SCHEMA_VERSION`` follows.

Each step runs in one ``BEGIN IMMEDIATE`` transaction together with the update of
``meta.schema_version`` (SQLite DDL is transactional), so a crash or an error inside a
migration leaves the project at the previous version, never half-migrated.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Callable

Migration = str | Callable[[sqlite3.Connection], None]

# Version 1, frozen. Notes on choices:
# * AUTOINCREMENT on measurements/results: ids are never reused, so an id recorded in
#   a result (or printed in a report) never comes to mean a different row later.
# * measurements are soft-deleted (``removed``) - nothing is lost, and a result that
#   used a removed measurement can still show its name.
# * result_measurements has no foreign key to measurements on purpose: the link is a
#   historical record, the inputs are pinned by their hashes in results.input_hashes.
# * files lists the content-addressed data files; a row is inserted only after the
#   file is durable on disk, so every hash referenced through it exists.
V1_DDL = """
CREATE TABLE meta (
    key   TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
CREATE TABLE files (
    hash          TEXT PRIMARY KEY CHECK (length(hash) = 64),
    ext           TEXT NOT NULL DEFAULT '',
    size          INTEGER NOT NULL,
    original_name TEXT NOT NULL DEFAULT '',
    added         TEXT NOT NULL
);
CREATE TABLE systems (
    id      INTEGER PRIMARY KEY AUTOINCREMENT,
    name    TEXT NOT NULL,
    meta    TEXT NOT NULL DEFAULT '{}',
    created TEXT NOT NULL
);
CREATE TABLE artefacts (
    id      TEXT PRIMARY KEY,
    kind    TEXT NOT NULL,
    data    TEXT NOT NULL,
    updated TEXT NOT NULL
);
CREATE TABLE measurements (
    id          INTEGER PRIMARY KEY AUTOINCREMENT,
    name        TEXT NOT NULL,
    kind        TEXT NOT NULL,
    hash        TEXT NOT NULL REFERENCES files(hash),
    system_id   INTEGER REFERENCES systems(id),
    artefact_id TEXT REFERENCES artefacts(id),
    meta        TEXT NOT NULL DEFAULT '{}',
    created     TEXT NOT NULL,
    removed     TEXT
);
CREATE TABLE results (
    id           INTEGER PRIMARY KEY AUTOINCREMENT,
    plugin       TEXT NOT NULL,
    version      TEXT NOT NULL,
    params       TEXT NOT NULL DEFAULT '{}',
    input_hashes TEXT NOT NULL DEFAULT '{}',
    outputs      TEXT NOT NULL DEFAULT '{}',
    started      TEXT,
    finished     TEXT,
    warnings     TEXT NOT NULL DEFAULT '[]',
    created      TEXT NOT NULL
);
CREATE INDEX results_plugin ON results(plugin);
CREATE TABLE result_measurements (
    result_id      INTEGER NOT NULL REFERENCES results(id),
    measurement_id INTEGER NOT NULL,
    PRIMARY KEY (result_id, measurement_id)
);
CREATE TABLE result_files (
    result_id INTEGER NOT NULL REFERENCES results(id),
    name      TEXT NOT NULL,
    hash      TEXT NOT NULL REFERENCES files(hash),
    PRIMARY KEY (result_id, name)
);
CREATE TABLE state (
    key     TEXT PRIMARY KEY,
    value   TEXT NOT NULL,
    updated TEXT NOT NULL
);
"""

# Version 2: a free-text label per result ("after re-calibration", "operator B" ...).
V2_RESULT_LABEL = """
ALTER TABLE results ADD COLUMN label TEXT NOT NULL DEFAULT '';
"""

# Version 3: the project tidy - an item can be hidden from the lists (not deleted; a
# delete stays the soft ``removed`` of version 1).
V3_MEASUREMENT_HIDDEN = """
ALTER TABLE measurements ADD COLUMN hidden INTEGER NOT NULL DEFAULT 0;
"""

MIGRATIONS: list[Migration] = [V1_DDL, V2_RESULT_LABEL, V3_MEASUREMENT_HIDDEN]

SCHEMA_VERSION = len(MIGRATIONS)


def latest() -> int:
    """The newest version this code knows (read at call time, so tests can patch
    ``MIGRATIONS``)."""
    return len(MIGRATIONS)


def statements(script: str) -> list[str]:
    """Split an SQL script into statements.

    ``Connection.executescript`` would COMMIT any open transaction first, which would
    break the one-transaction-per-migration rule, so scripts are run statement by
    statement with ``execute`` instead.
    """
    out, buf = [], ""
    for line in script.splitlines(keepends=True):
        buf += line
        if sqlite3.complete_statement(buf):
            out.append(buf.strip())
            buf = ""
    rest = "\n".join(l for l in buf.splitlines() if l.strip() and not l.strip().startswith("--"))
    if rest:
        raise ValueError(f"incomplete SQL statement at the end of a migration: {rest[:60]!r}")
    return out


def read_version(conn: sqlite3.Connection) -> int | None:
    """The schema version recorded in ``meta``, 0 for an empty database, None when the
    database is not empty but has no ``meta`` table (not a camcmm project)."""
    tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    if "meta" not in tables:
        return 0 if not tables else None
    row = conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
    return None if row is None else int(row[0])


def apply(conn: sqlite3.Connection, step: int) -> None:
    """Run ``MIGRATIONS[step]`` (version ``step`` -> ``step + 1``) in one transaction.

    ``conn`` must be in autocommit mode (``isolation_level=None``) with no open
    transaction and, as SQLite advises for schema changes, ``foreign_keys`` off; the
    keys are checked with ``PRAGMA foreign_key_check`` before the commit instead. On any error
    the transaction is rolled back and the error re-raised.
    """
    migration = MIGRATIONS[step]
    conn.execute("BEGIN IMMEDIATE")
    try:
        if callable(migration):
            migration(conn)
        else:
            for sql in statements(migration):
                conn.execute(sql)
        broken = conn.execute("PRAGMA foreign_key_check").fetchone()
        if broken is not None:  # migrations run with foreign_keys off, so check here
            raise sqlite3.IntegrityError(
                f"migration to schema {step + 1} broke a foreign key: table {broken[0]} row {broken[1]} -> {broken[2]}"
            )
        conn.execute(
            "INSERT INTO meta(key, value) VALUES ('schema_version', ?) "
            "ON CONFLICT(key) DO UPDATE SET value = excluded.value",
            (str(step + 1),),
        )
        conn.execute("COMMIT")
    except BaseException:
        conn.execute("ROLLBACK")
        raise


def migrate(
    conn: sqlite3.Connection, current: int, target: int | None = None, before_step: Callable[[int], None] | None = None
) -> int:
    """Migrate from ``current`` up to ``target`` (default: the newest); returns the
    version reached. ``before_step(n)`` is called before step n -> n+1."""
    target = len(MIGRATIONS) if target is None else target
    while current < target:
        if before_step is not None:
            before_step(current)
        apply(conn, current)
        current += 1
    return current
