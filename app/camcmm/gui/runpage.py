"""What every page that runs one task on project items shares (Fuse, Photogrammetry,
Studies): the page's error line, the plugin found by its task, the last run restored from
the project, and mounting with its view tools.

A page holds a :class:`RunShared` (composition, not a base class) made with its page key,
its state keys' prefix (e.g. ``fu``), the run's noun for messages and its task module
(:mod:`camcmm.tasks.fusion` ...: ``TASK`` and ``restore(project)`` -> ``(request, record)``);
:func:`mount` adds the view tools and calls the page's ``opened`` each time it is shown.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from types import ModuleType
from typing import Any

from ..errors import one_line

log = logging.getLogger("camcmm.gui.runpage")


class RunShared:
    """The error line, provider and stored run of page ``key`` (state keys ``{prefix}_*``)."""

    def __init__(self, session: Any, key: str, prefix: str, what: str, task: ModuleType):
        self.session = session
        self.state = session.state
        self.key, self.prefix, self.what, self.task = key, prefix, what, task

    def error(self, msg: Any) -> None:
        """Show ``msg`` as one line on the page and in the shell's drawer."""
        line = one_line(msg)
        self.state[f"{self.prefix}_error"] = line
        self.session.error(line, page=self.key)

    def clear_error(self) -> None:
        self.state[f"{self.prefix}_error"] = ""
        self.session.clear_error(page=self.key)

    def spec(self) -> Any:
        """The manifest of the plugin that does the page's task."""
        return self.session.host.provider(self.task.TASK)

    @staticmethod
    async def run_in(job: Any, fn: Callable[..., Any], *args: Any) -> Any:
        """``fn(*args, progress, cancel)`` in ``job``'s worker thread: the task's run with
        the job's throttled progress and this run's cancel event (no Job in the task)."""
        cancel = job.begin()
        try:
            return await job.call(fn, *args, job.progress, cancel)
        finally:
            job.end()

    def restore(self, set_request: Callable[[Any], None], show: Callable[..., None]) -> dict[str, Any] | None:
        """The last run as the project keeps it: ``set_request(request)`` then
        ``show(record, draw=False)`` (the scene is drawn when the page opens); a damaged
        record is a message, it must not keep the page from opening."""
        try:
            got = self.task.restore(self.session.project)
            if got is None:
                return None
            req, rec = got
            set_request(req)
            show(rec, draw=False)
            self.state[f"{self.prefix}_message"] = f"result #{rec.get('result')} from the project"
            return rec
        except Exception as exc:
            log.warning("cannot restore the %s: %s", self.what, exc)
            self.state[f"{self.prefix}_message"] = f"the stored {self.what} could not be read: {one_line(exc)}"
            return None


def mount(page: Any, server: Any, tools: str) -> Any:
    """Give ``page`` (made for a session before the server starts) its view tools (state
    prefix ``tools``) and call its ``opened`` each time it is shown; returns the page."""
    from .viewtools import mount_view_tools

    page.tools = mount_view_tools(server, page.view, tools)

    @server.state.change("page")
    def _page_changed(**changes: Any) -> None:
        if changes.get("page") == page.KEY:
            page.opened()

    return page
