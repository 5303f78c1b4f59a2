"""What every page that runs one plugin on project items shares (Photogrammetry, Fuse, ...):
the page's error line, the plugin found by its task, the last run restored from the
project, closing, and mounting with its view tools.

A page subclasses :class:`RunPage`, sets ``KEY`` (its page key), ``PREFIX`` (its state
keys' prefix, e.g. ``fu``), ``WHAT`` (the run's noun for messages), ``runs`` (its ``run``
module: ``TASK`` and ``stored(project)``), and writes ``_set_request`` and
``show_record(rec, draw=False)``; :func:`mount` creates it for a session.
"""

from __future__ import annotations

import logging
from types import ModuleType
from typing import Any

from ..errors import one_line

log = logging.getLogger("camcmm.gui.runpage")


class RunPage:
    KEY = ""
    PREFIX = ""
    WHAT = "run"
    runs: ModuleType

    def __init__(self, server: Any, session: Any):
        self.server = server
        self.session = session
        self.state = session.state
        self.project = session.project
        self.host = session.host
        self.tools: Any = None  # the view's toolbar (mount)
        self.record: dict[str, Any] | None = None
        self._shown_result: Any = None

    def _error(self, msg: Any) -> None:
        line = one_line(msg)
        self.state[f"{self.PREFIX}_error"] = line
        self.session.error(line, page=self.KEY)

    def _clear_error(self) -> None:
        self.state[f"{self.PREFIX}_error"] = ""
        self.session.clear_error(page=self.KEY)

    def spec(self) -> Any:
        """The manifest of the plugin that does this page's task."""
        return self.host.provider(self.runs.TASK)

    def _set_request(self, req: dict[str, Any]) -> None:
        raise NotImplementedError

    def show_record(self, rec: dict[str, Any], *args: Any, draw: bool = True, **kw: Any) -> None:
        raise NotImplementedError

    def opened(self) -> None:
        """The page is shown (override to draw the stored run's scene)."""

    def restore(self) -> None:
        """The last run, as the project keeps it (the scene is drawn when the page opens)."""
        try:
            rec = self.runs.stored(self.project)
            if rec is None:
                return
            self._set_request(rec.get("request") or {})
            self.show_record(rec, draw=False)
            self.state[f"{self.PREFIX}_message"] = f"result #{rec.get('result')} from the project"
        except Exception as exc:  # a damaged record must not keep the page from opening
            log.warning("cannot restore the %s: %s", self.WHAT, exc)
            self.state[f"{self.PREFIX}_message"] = f"the stored {self.WHAT} could not be read: {one_line(exc)}"

    def _jobs(self) -> list[Any]:
        return [self.job]

    def close(self) -> None:
        for job in self._jobs():
            job.close()
        try:
            self.view.plotter.close()
        except Exception:
            pass


def stored_record(project: Any, key: str) -> dict[str, Any] | None:
    """A page's record of its last run under the project state ``key`` (None: none yet, or
    not readable: a damaged record must not keep the page from opening)."""
    try:
        rec = project.get_state(key)
    except Exception:
        return None
    return rec if isinstance(rec, dict) and rec.get("result") is not None else None


def mount(cls: type[RunPage], server: Any, session: Any, tools: str) -> Any:
    """Create the page for a session and its view tools (state prefix ``tools``) before
    the server starts; the page's ``opened`` runs each time it is shown."""
    from .viewtools import mount_view_tools

    page = cls(server, session)
    page.tools = mount_view_tools(server, page.view, tools)

    @server.state.change("page")
    def _page_changed(**changes: Any) -> None:
        if changes.get("page") == cls.KEY:
            page.opened()

    return page
