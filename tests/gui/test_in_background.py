"""gui.jobs.in_background: a button's handler returns at once and the run goes on.

wslink reads one tab's messages in order and trame awaits an async handler, so a handler
that awaited its run held back the tab's Cancel until the run was over (seen in Chromium on
the Photogrammetry page). Every long Run/Acquire handler now starts the run with
in_background; here the behaviour that makes Cancel reachable is pinned down.
"""

from __future__ import annotations

import asyncio
import logging

from camcmm.gui.jobs import Job, in_background


def test_handler_returns_before_the_run_and_cancel_reaches_it():
    job = Job("test run")
    seen: list[str] = []

    def work():
        while not job.cancelled():  # the run only ends when cancelled
            job.progress(0.5, "working")
        job.check()

    async def run():
        try:
            await job.run(work)
        except Exception as exc:
            seen.append(type(exc).__name__)

    async def tab():
        in_background(run())  # the Run click: returns at once
        await asyncio.sleep(0.05)
        assert job.running  # still going after the handler returned
        assert job.cancel()  # the next message of the same tab: Cancel
        for _ in range(200):
            await asyncio.sleep(0.01)
            if seen:
                break

    asyncio.run(tab())
    assert seen == ["Cancelled"] and not job.running


def test_an_escaped_exception_is_logged(caplog):
    async def broken():
        raise RuntimeError("boom")

    async def tab():
        in_background(broken())
        await asyncio.sleep(0.05)

    with caplog.at_level(logging.ERROR, logger="camcmm.gui"):
        asyncio.run(tab())
    assert any("background run failed" in r.message for r in caplog.records)


def test_the_state_is_pushed_when_the_run_ends():
    """trame pushes what a handler changed when the handler returns; a background run ends
    later, so its outcome (a refusal's message) must be pushed then (the Calibration page's
    refusal of a folder outside the roots never reached the browser without it)."""

    class State:
        flushed: list[str] = []
        message = ""

        def flush(self):
            self.flushed.append(self.message)

    state = State()

    async def refuse():
        await asyncio.sleep(0)
        state.message = "server folder: outside the folders this server may read"

    async def tab():
        task = in_background(refuse(), state)
        assert state.flushed == []  # the handler returned before the run
        await task

    asyncio.run(tab())
    assert state.flushed == ["server folder: outside the folders this server may read"]
