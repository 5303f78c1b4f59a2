"""The session children: one ``python -m camcmm.gui … --session-child`` process per
browser session, bound to 127.0.0.1 on a free port, holding a secret only the front
knows. One spare child is kept started (within the limit) so that a new tab does not
wait for trame and VTK to load. Children whose tabs are all gone for ``idle`` seconds
are stopped, and so are sessions no tab ever connected to (``unused`` seconds after the
last request for them: a plain ``GET /`` must not hold one of the few sessions for
minutes); all are stopped with the front (and stop themselves if the front dies:
:func:`camcmm.gui.launcher.child.watch_parent`)."""

from __future__ import annotations

import asyncio
import secrets
import sys
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ..security import printable
from .child import READY, SECRET_ENV, WS_SECRET_ENV

#: how many ended session ids are remembered (to tell a reload why its session is gone)
REMEMBER_ENDED = 256
#: stop: SIGTERM, then SIGKILL after this many seconds
STOP_GRACE_S = 6.0


@dataclass(eq=False)
class Child:
    id: str
    secret: str
    ws_secret: str  # the websocket's (wslink's) secret: given to its page only (front: paraview/)
    proc: Any = None
    port: int | None = None
    ready: asyncio.Event = field(default_factory=asyncio.Event)
    started: float = field(default_factory=time.monotonic)
    ready_after: float | None = None  # seconds from spawn to listening
    sockets: int = 0  # open websockets (tabs) through the front
    idle_since: float | None = None
    used: bool = False  # a websocket (a tab's page) has connected once
    touched: float = field(default_factory=time.monotonic)  # the last request forwarded to it
    ended: str | None = None  # why it is no longer usable
    tail: list[str] = field(default_factory=list)  # last lines it printed

    @property
    def alive(self) -> bool:
        return self.ended is None and self.proc is not None and self.proc.returncode is None


class Sessions:
    """The children of one front server. ``command``: the child's command line;
    ``env``: its environment (the secrets are added per child)."""

    def __init__(
        self,
        command: list[str],
        env: dict[str, str],
        max_sessions: int = 4,
        idle: float = 300.0,
        unused: float = 30.0,
        start_timeout: float = 180.0,
        log: Callable[[str], None] = lambda line: print(line, flush=True),
    ):
        self.command, self.env = command, env
        self.max_sessions, self.idle, self.unused, self.start_timeout = max_sessions, idle, unused, start_timeout
        self.log = log
        self.live: dict[str, Child] = {}  # sessions given to a tab
        self.spare: Child | None = None
        self.ended: OrderedDict[str, str] = OrderedDict()
        self.spare_failures = 0
        self._tasks: set[asyncio.Task[Any]] = set()
        self._opening = asyncio.Lock()
        self.closing = False

    # -- children ------------------------------------------------------------------------
    async def spawn(self) -> Child:
        # the id in lower-case hex: the trame client lower-cases the websocket URL it is given
        child = Child(id=secrets.token_hex(12), secret=secrets.token_urlsafe(32), ws_secret=secrets.token_urlsafe(32))
        env = dict(self.env, **{SECRET_ENV: child.secret, WS_SECRET_ENV: child.ws_secret})
        child.proc = await asyncio.create_subprocess_exec(
            *self.command,
            stdin=asyncio.subprocess.PIPE,  # never written: it ends when the front does
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.STDOUT,
            env=env,
        )
        self.log(f"camcmm: session {child.id[:6]}: process {child.proc.pid} started")
        self._keep(asyncio.ensure_future(self._read(child)))
        return child

    async def _read(self, child: Child) -> None:
        """Forward the child's output (tagged with its id) and learn its port."""
        tag = f"[session {child.id[:6]}] "
        assert child.proc.stdout is not None
        while True:
            try:
                raw = await child.proc.stdout.readline()
            except ValueError:  # a line longer than the stream's limit: read on
                continue
            if not raw:
                break
            # a child logs what browsers sent: never a control character raw to the terminal
            line = printable(raw.decode("utf-8", "replace").rstrip("\r\n"))
            if line.startswith(READY) and child.port is None:
                child.port = int(line[len(READY) :])
                child.ready_after = time.monotonic() - child.started
                child.touched = time.monotonic()  # the unused clock runs from here: a tab waited for it
                self.log(
                    f"camcmm: session {child.id[:6]}: ready on 127.0.0.1:{child.port} after {child.ready_after:.1f} s"
                )
                child.ready.set()
                continue
            child.tail = (child.tail + [line])[-5:]
            self.log(tag + line if line.strip() else "")  # blank lines stay blank: they separate tracebacks
        code = await child.proc.wait()
        self._end(child, child.ended or f"its server process stopped (exit code {code})")
        child.ready.set()  # wake whoever waits: it will find it ended

    async def _wait_ready(self, child: Child) -> Child:
        try:
            await asyncio.wait_for(child.ready.wait(), self.start_timeout)
        except TimeoutError:
            await self.stop(child, f"it did not start within {self.start_timeout:g} s")
        if not child.alive or child.port is None:
            raise RuntimeError(child.ended or "it did not start")
        return child

    def start_failure(self, child: Child) -> str:
        last = " | ".join(child.tail[-3:])
        return f"the session server did not start: {child.ended}" + (f" ({last})" if last else "")

    async def stop(self, child: Child, why: str) -> None:
        self._end(child, why)
        proc = child.proc
        if proc is None or proc.returncode is not None:
            return
        proc.terminate()
        try:
            await asyncio.wait_for(proc.wait(), STOP_GRACE_S)
        except TimeoutError:
            proc.kill()
            await proc.wait()

    def _end(self, child: Child, why: str) -> None:
        if child.ended is None:
            child.ended = why
        if self.live.get(child.id) is child:
            del self.live[child.id]
            self.ended[child.id] = child.ended
            while len(self.ended) > REMEMBER_ENDED:
                self.ended.popitem(last=False)
            self.log(f"camcmm: session {child.id[:6]} ended: {child.ended}")
            self._keep(asyncio.ensure_future(self.keep_spare()))
        if self.spare is child:
            self.spare = None

    # -- sessions ------------------------------------------------------------------------
    def count(self) -> int:
        return len(self.live) + (self.spare is not None)

    async def keep_spare(self) -> None:
        """Start a spare child when there is room for one (not after three failed starts
        in a row: a broken installation must not restart children forever)."""
        async with self._opening:  # one spawn at a time: the limit holds under concurrent tabs
            if self.closing or self.spare is not None or self.count() >= self.max_sessions or self.spare_failures >= 3:
                return
            self.spare = child = await self.spawn()
        try:
            await self._wait_ready(child)
            self.spare_failures = 0
        except RuntimeError:
            self.spare_failures += 1
            self.log("camcmm: " + self.start_failure(child))
            if self.spare is child:
                self.spare = None

    async def open(self) -> Child | None:
        """A new session: the spare child, else a new one; None when the limit is reached.
        Raises RuntimeError (one line) when a child fails to start."""
        async with self._opening:
            if self.closing:
                return None
            child = self.spare if self.spare is not None and not self.spare.ended else None
            if child is None and len(self.live) >= self.max_sessions:
                return None
            if child is None:
                child = await self.spawn()
            self.spare = None
            self.live[child.id] = child
            child.idle_since = child.touched = time.monotonic()  # until its tab connects
        try:
            await self._wait_ready(child)
        except RuntimeError:
            raise RuntimeError(self.start_failure(child)) from None
        self._keep(asyncio.ensure_future(self.keep_spare()))
        return child

    def get(self, sid: str) -> Child | None:
        child = self.live.get(sid)
        return child if child is not None and child.alive and child.port is not None else None

    def why_ended(self, sid: str) -> str | None:
        return self.ended.get(sid)

    def connected(self, child: Child, delta: int) -> None:
        """A websocket of ``child`` opened (+1) or closed (-1)."""
        child.sockets += delta
        child.used = True
        child.idle_since = None if child.sockets > 0 else time.monotonic()

    async def reap(self) -> None:
        """Stop every session whose tabs have all been gone for ``idle`` seconds, and
        every one no tab connected to within ``unused`` seconds of its last request."""
        now = time.monotonic()
        for child in list(self.live.values()):
            started = child.port is not None
            if started and not child.used and child.sockets <= 0 and now - child.touched > self.unused:
                await self.stop(child, f"closed: no page connected to it within {self.unused:g} s")
                continue
            if child.sockets <= 0 and child.idle_since is not None and now - child.idle_since > self.idle:
                await self.stop(child, f"closed {self.idle:g} s after its last tab")

    async def run_reaper(self) -> None:
        while True:
            await asyncio.sleep(max(0.2, min(5.0, self.idle / 4, self.unused / 4)))
            await self.reap()

    async def stop_all(self) -> None:
        self.closing = True
        async with self._opening:  # a spawn under way is finished (and listed) first
            children = list(self.live.values()) + ([self.spare] if self.spare else [])
        await asyncio.gather(*(self.stop(c, "the server stopped") for c in children))
        for t in list(self._tasks):
            t.cancel()

    def _keep(self, task: asyncio.Task[Any]) -> None:
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)


def child_command(project: str, data_roots: list[str]) -> list[str]:
    cmd = [sys.executable, "-m", "camcmm.gui", str(project), "--port", "0", "--host", "127.0.0.1", "--session-child"]
    for d in data_roots:
        cmd += ["--data-root", str(d)]
    return cmd
