"""The project tidy: rename, hide, delete and restore measurements (items).

Mixed into :class:`camcmm.project.store.Project`. Nothing here deletes a row or a file:

* a rename changes the name the lists show; results keep referring to the measurement
  by id, and their inputs are pinned by hash, so no result changes meaning;
* hidden (schema 3) keeps an item out of the lists and pickers, and can be undone at
  any time;
* a delete is the soft ``removed`` of schema 1, undone by :meth:`TidyMixin.restore_measurement`.
  A measurement that a stored result used as an input is deleted only when the caller
  confirms: :meth:`TidyMixin.delete_measurement` otherwise refuses, naming the results,
  so that a page can list them and ask.
"""

from __future__ import annotations

import sqlite3
from contextlib import AbstractContextManager
from typing import Any

from ..errors import ProjectError
from ..jsonable import utc_now


class TidyMixin:
    """Rename, hide, delete (soft) and restore; the results that use a measurement."""

    path: Any

    def _tx(self, what: str) -> AbstractContextManager[sqlite3.Connection]:  # pragma: no cover - Project's
        raise NotImplementedError

    def _read(self, what: str) -> AbstractContextManager[sqlite3.Connection]:  # pragma: no cover - Project's
        raise NotImplementedError

    def _update(self, mid: int, what: str, sql: str, args: tuple) -> None:
        """One UPDATE of measurement ``mid``; a missing id is a one-line error."""
        with self._tx(f"{what} measurement {mid}") as conn:
            if conn.execute("SELECT 1 FROM measurements WHERE id = ?", (int(mid),)).fetchone() is None:
                raise ProjectError(f"no measurement with id {mid} in project {self.path}")
            conn.execute(sql, (*args, int(mid)))

    def rename_measurement(self, mid: int, name: str) -> str:
        """Give measurement ``mid`` a new name (stripped, one line); returns it."""
        if not isinstance(name, str) or not " ".join(name.split()):
            raise ProjectError(f"measurement {mid}: a new name must be a non-empty text, got {name!r}")
        name = " ".join(name.split())
        if len(name) > 200:
            raise ProjectError(f"measurement {mid}: a name may have at most 200 characters, got {len(name)}")
        self._update(mid, "renaming", "UPDATE measurements SET name = ? WHERE id = ?", (name,))
        return name

    def set_measurement_hidden(self, mid: int, hidden: bool = True) -> None:
        """Hide measurement ``mid`` from the lists (``hidden=False`` shows it again)."""
        self._update(mid, "hiding", "UPDATE measurements SET hidden = ? WHERE id = ?", (1 if hidden else 0,))

    def results_using(self, mid: int) -> list[dict[str, Any]]:
        """The stored results that used measurement ``mid`` as an input, oldest first:
        ``{id, plugin, version, finished, label}``."""
        with self._read("listing the results of a measurement") as conn:
            rows = conn.execute(
                "SELECT r.id, r.plugin, r.version, r.finished, r.label FROM results r "
                "JOIN result_measurements x ON x.result_id = r.id WHERE x.measurement_id = ? ORDER BY r.id",
                (int(mid),),
            ).fetchall()
        return [{k: r[k] for k in ("id", "plugin", "version", "finished", "label")} for r in rows]

    def delete_measurement(self, mid: int, confirm: bool = False) -> list[dict[str, Any]]:
        """Delete measurement ``mid`` (soft: it leaves the lists, its file and every
        result stay; :meth:`restore_measurement` undoes it). A measurement that stored
        results used is deleted only with ``confirm``; without it a ProjectError names
        those results. Returns the results that used it."""
        using = self.results_using(mid)
        if using and not confirm:
            names = ", ".join(f"#{r['id']} {r['plugin']}" for r in using[:5]) + (" …" if len(using) > 5 else "")
            raise ProjectError(
                f"measurement {mid} is an input of {len(using)} stored result(s) ({names}); "
                "confirm to delete it anyway (the results stay)"
            )
        self._update(
            mid, "deleting", "UPDATE measurements SET removed = COALESCE(removed, ?) WHERE id = ?", (utc_now(),)
        )
        return using

    def restore_measurement(self, mid: int) -> None:
        """Undo a delete: measurement ``mid`` is listed again."""
        self._update(mid, "restoring", "UPDATE measurements SET removed = NULL WHERE id = ?", ())


def hidden_of(row: sqlite3.Row) -> bool:
    """A measurement row's hidden flag (False on a database before schema 3)."""
    return bool(row["hidden"]) if "hidden" in row.keys() else False


__all__ = ["TidyMixin", "hidden_of"]
