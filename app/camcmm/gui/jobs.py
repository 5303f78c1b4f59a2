"""Background work of a page, written once: start, throttled progress, cancel, failure, result.

A page owns one :class:`Job` (or a few: one per kind of work that may overlap). The
work runs in the job's worker thread while the server's event loop keeps the page
live; progress reaches the page at most ``1 / interval`` times a second; a cancelled
run raises :class:`Cancelled` (test it with ``isinstance``, never by its text); any
other failure is shown as one line (:func:`camcmm.errors.one_line`). Async only: the
server's loop drives it, and tests drive it with :func:`asyncio.run`.

Typical use in a page::

    self.job = Job("compare", state=session.state, on_progress=self._show_progress)

    async def run_async(self, params):
        try:
            result = await self.job.run(self._compute, params)   # in the worker thread
        except Exception as exc:
            status, message = Job.outcome(exc, "inspect.compare")
            ...

Every job's work is a run the web server starts, so it is confined (issue 26,
docs/security.md): :func:`camcmm.gui.app.build` registers the session's
:class:`~camcmm.gui.roots.Roots` for its trame state (:func:`confine_jobs`) and each call
of a job with that state runs inside :func:`camcmm.reach.server_run` — paths to the
project folder and the data roots, network addresses to the configured schedulers — *in
the job's worker thread* (a contextvar: set nowhere else, so apps built in one process,
as tests do, never leak it into each other or into the caller). A plugin run that goes
to a worker process takes the folders with it (:func:`camcmm.worker.run_isolated`).
"""

from __future__ import annotations

import asyncio
import functools
import logging
import threading
import time
import weakref
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from ..errors import CamcmmError, one_line
from ..host import Cancelled
from ..reach import server_run

__all__ = ["Busy", "Cancelled", "Job", "confine_jobs", "in_background"]

#: trame state -> the Roots its jobs are confined to (:func:`confine_jobs`)
_REACH: weakref.WeakKeyDictionary[Any, Any] = weakref.WeakKeyDictionary()


def confine_jobs(state: Any, roots: Any) -> None:
    """Confine every job of ``state`` (the trame state of one app) to ``roots``
    (``folders`` and ``schedulers``): each call runs inside :func:`camcmm.reach.server_run`."""
    _REACH[state] = roots


def _confined_call(folders: Any, schedulers: Any, fn: Callable[..., Any]) -> Any:
    with server_run(folders, schedulers):
        return fn()


#: Tasks started by :func:`in_background`, held so the loop does not drop them half-way.
_TASKS: set[asyncio.Task[Any]] = set()


def in_background(coro: Any, state: Any = None) -> asyncio.Task[Any]:
    """Run ``coro`` (a page's run) as a task of the server's loop and return at once.

    A button's handler must never await a long run: wslink reads one browser tab's
    messages one after the other and trame awaits an async handler, so an awaited run
    would hold back that tab's Cancel (and every other click) until the run was over.
    trame pushes the state a handler changed when the handler returns; the task returns
    later, so ``state`` (the trame state) is pushed when it ends (a refusal's message,
    the result) — progress on the way is pushed by :meth:`Job.post`. The run reports its
    own outcome on the page; an exception it let escape is logged.
    """

    async def run_then_push() -> Any:
        try:
            return await coro
        finally:
            if state is not None:
                try:
                    state.flush()
                except Exception:  # a client gone mid-run must not hide the run's outcome
                    logging.getLogger("camcmm.gui").exception("state flush failed")

    task = asyncio.get_running_loop().create_task(run_then_push())
    _TASKS.add(task)
    task.add_done_callback(_finished)
    return task


def _finished(task: asyncio.Task[Any]) -> None:
    _TASKS.discard(task)
    if not task.cancelled() and task.exception() is not None:
        logging.getLogger("camcmm.gui").error("background run failed", exc_info=task.exception())


class Busy(CamcmmError):
    """A job was started while the previous run of the same job is still going."""


class Job:
    """One kind of background work of a page.

    Parameters
    ----------
    name
        What the operator calls the work ("the comparison", "calibration"): it names
        the job in messages and its worker threads.
    state
        The trame state: progress and results posted from the worker are pushed to
        the browser inside ``with state:``. None in tests without a server.
    on_progress
        ``on_progress(fraction, message)``, called on the loop thread with
        ``fraction`` in 0..1.
    workers
        Worker threads (1: the work of this job runs in order).
    interval
        Least time between two progress updates in s (the final 1.0 always passes).
    """

    def __init__(
        self,
        name: str,
        *,
        state: Any = None,
        on_progress: Callable[[float, str], Any] | None = None,
        workers: int = 1,
        interval: float = 0.1,
    ):
        self.name = name
        self.state = state
        self._on_progress = on_progress
        self._interval = float(interval)
        self._pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix=f"camcmm-{name.replace(' ', '-')}")
        self._cancel = threading.Event()
        self._last = 0.0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._loop_thread: int | None = None
        self.running = False

    # -- a run ---------------------------------------------------------------------------
    def begin(self) -> threading.Event:
        """Mark the job running and return the run's cancel event; :class:`Busy` if it is."""
        if self.running:
            raise Busy(f"{self.name} is running; wait for it or cancel it")
        self._bind()
        self.running = True
        self._cancel = threading.Event()
        self._last = 0.0
        return self._cancel

    def end(self) -> None:
        """Mark the run finished (done, failed or cancelled)."""
        self.running = False

    @property
    def cancel_event(self) -> threading.Event:
        """The current run's cancel event (hand it to :func:`camcmm.worker.run`)."""
        return self._cancel

    def cancel(self) -> bool:
        """Ask the running work to stop; True if a run was going."""
        self._cancel.set()
        return self.running

    def cancelled(self) -> bool:
        return self._cancel.is_set()

    def check(self) -> None:
        """Raise :class:`Cancelled` if the operator cancelled (for the work's own loops)."""
        if self._cancel.is_set():
            raise Cancelled(f"{self.name}: cancelled")

    def progress(self, fraction: float, message: str = "") -> None:
        """The work's progress callback (any thread); throttled to the page."""
        now = time.monotonic()
        if float(fraction) < 1.0 and now - self._last < self._interval:
            return
        self._last = now
        if self._on_progress is not None:
            self.post(self._on_progress, float(fraction), message)

    async def call(self, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """``fn(*args, **kwargs)`` in the job's worker thread; its result or its exception."""
        self._bind()
        loop = asyncio.get_running_loop()
        work = functools.partial(fn, *args, **kwargs)
        roots = _REACH.get(self.state) if self.state is not None else None
        if roots is not None:  # entered in the worker thread, for this call only
            work = functools.partial(_confined_call, roots.folders, roots.schedulers, work)
        return await loop.run_in_executor(self._pool, work)

    async def run(self, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """:meth:`begin`, :meth:`call`, :meth:`end` (also when the work fails)."""
        self.begin()
        try:
            return await self.call(fn, *args, **kwargs)
        finally:
            self.end()

    # -- the page's thread ----------------------------------------------------------------
    def _bind(self) -> None:
        try:
            self._loop = asyncio.get_running_loop()
            self._loop_thread = threading.get_ident()
        except RuntimeError:  # called outside a loop (a test's set-up): post runs at once
            pass

    def post(self, fn: Callable[..., Any], *args: Any) -> None:
        """Run ``fn(*args)`` on the loop thread (at once when already on it, or no loop)."""
        loop = self._loop
        if loop is not None and threading.get_ident() != self._loop_thread and not loop.is_closed():

            def call() -> None:
                if self.state is None:
                    fn(*args)
                    return
                with self.state:  # leaving the block pushes the changes to the browser
                    fn(*args)

            loop.call_soon_threadsafe(call)
        else:
            fn(*args)

    @staticmethod
    def outcome(exc: BaseException, name: str = "") -> tuple[str, str]:
        """``("cancelled" | "failed", one-line message)`` for a run that raised ``exc``."""
        if isinstance(exc, Cancelled):
            return "cancelled", one_line(exc, name)
        return "failed", one_line(exc, name)

    def close(self) -> None:
        """Cancel and let the worker threads go (the server stops)."""
        self._cancel.set()
        self._pool.shutdown(wait=False, cancel_futures=True)
