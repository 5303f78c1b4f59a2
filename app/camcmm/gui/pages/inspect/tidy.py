"""The project tidy on the Inspect page: rename, hide, delete an item, and undo.

State it owns: ``tidy_rename`` (``{id, name}`` while the rename dialog is open, else
None), ``tidy_confirm`` (``{id, name, results: [text]}`` while a delete waits for the
user to confirm, else None), ``tidy_undo`` (the last action, one line, "" when none),
``tidy_can_undo``, ``tidy_new_name`` (the rename field), ``show_hidden``. The store does the work
(:mod:`camcmm.project.tidy`): a delete is soft, so it can be undone for as long as this
session runs (and the row, its file and every result stay in the project after it).
A stored result's input is deleted only after the user saw which results used it.
Every value from the browser is checked here: the id must name an item of the project.
"""

from __future__ import annotations

from typing import Any

from ....errors import one_line


class Tidy:
    def __init__(self, session: Any):
        self.session = session
        self.state = session.state
        self._undo: list[tuple[str, str, Any]] = []  # (action, item key, previous value)
        self.state.update(
            {
                "tidy_rename": None,
                "tidy_new_name": "",
                "tidy_confirm": None,
                "tidy_undo": "",
                "tidy_can_undo": False,
                "show_hidden": False,
            }
        )

    # -- helpers ----------------------------------------------------------------------
    def _record(self, key: Any) -> dict[str, Any] | None:
        """The project's record of item ``key``, or None after saying why."""
        m = self.session.measurement(key)
        if m is None:
            self.session.error(f"no item {key!r} in this project (listed again)")
            self.session.refresh_items()
        return m

    def _done(self, action: str, key: str, before: Any, line: str) -> None:
        self._undo.append((action, key, before))
        self.state.tidy_undo = line
        self.state.tidy_can_undo = True
        self.session.refresh_items()

    # -- rename -----------------------------------------------------------------------
    def ask_rename(self, key: Any) -> None:
        m = self._record(key)
        if m is not None:
            self.state.tidy_rename = {"id": str(m["id"]), "name": str(m["name"])}
            self.state.tidy_new_name = str(m["name"])

    def rename(self, key: Any, name: Any) -> bool:
        """Rename item ``key`` to ``name``; False (with the reason shown) when refused."""
        self.state.tidy_rename = None
        m = self._record(key)
        if m is None:
            return False
        try:
            new = self.session.project.rename_measurement(int(m["id"]), name if isinstance(name, str) else "")
        except Exception as exc:
            self.session.error(one_line(exc))
            return False
        obj = self.session.loaded(m["id"])  # a loaded item carries its name
        if obj is not None and hasattr(obj, "name"):
            obj.name = new
        self._done("rename", str(m["id"]), m["name"], f"renamed '{m['name']}' to '{new}'")
        return True

    # -- hide -------------------------------------------------------------------------
    def set_hidden(self, key: Any, hidden: Any = True) -> bool:
        m = self._record(key)
        if m is None:
            return False
        try:
            self.session.project.set_measurement_hidden(int(m["id"]), bool(hidden))
        except Exception as exc:
            self.session.error(one_line(exc))
            return False
        word = "hid" if hidden else "showed again"
        self._done("hide", str(m["id"]), bool(m.get("hidden")), f"{word} '{m['name']}'")
        return True

    # -- delete -----------------------------------------------------------------------
    def ask_delete(self, key: Any) -> bool:
        """Delete item ``key`` at once when no stored result used it; else open the
        confirmation listing those results. True when deleted."""
        m = self._record(key)
        if m is None:
            return False
        try:
            using = self.session.project.results_using(int(m["id"]))
        except Exception as exc:
            self.session.error(one_line(exc))
            return False
        if using:
            self.state.tidy_confirm = {
                "id": str(m["id"]),
                "name": str(m["name"]),
                "results": [
                    f"#{r['id']} {r['plugin']} {r['version']} ({r['finished'] or 'not finished'})" for r in using
                ],
            }
            return False
        return self.delete(key, confirm=False)

    def delete(self, key: Any, confirm: Any = True) -> bool:
        """Delete (soft) item ``key``; ``confirm``: the user saw the results that use it."""
        self.state.tidy_confirm = None
        m = self._record(key)
        if m is None:
            return False
        try:
            self.session.project.delete_measurement(int(m["id"]), confirm=confirm is True)
        except Exception as exc:
            self.session.error(one_line(exc))
            return False
        k = str(m["id"])
        if self.state.selected_item == k:
            self.session.unselect_item()
        if self.state.picked_item == k:
            self.state.picked_item = None
        self._done("delete", k, None, f"deleted '{m['name']}'")
        return True

    def cancel(self) -> None:
        self.state.tidy_confirm = None
        self.state.tidy_rename = None

    # -- undo -------------------------------------------------------------------------
    def undo(self) -> bool:
        """Undo the last rename, hide or delete of this session."""
        if not self._undo:
            self.state.tidy_undo, self.state.tidy_can_undo = "", False
            return False
        action, key, before = self._undo.pop()
        project = self.session.project
        try:
            if action == "rename":
                project.rename_measurement(int(key), before)
                obj = self.session.loaded(key)
                if obj is not None and hasattr(obj, "name"):
                    obj.name = before
            elif action == "hide":
                project.set_measurement_hidden(int(key), before)
            else:
                project.restore_measurement(int(key))
        except Exception as exc:
            self.session.error(one_line(exc))
            return False
        self.state.tidy_undo = f"undone: {action}"
        self.state.tidy_can_undo = bool(self._undo)
        self.session.refresh_items()
        return True
