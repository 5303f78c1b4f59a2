"""Plugin runs in a worker process, so that a crash in native code cannot take the server down.

    run(host, plugin_id, inputs, params, progress=None, cancel=None) -> RunResult
    run_isolated(...)   the same, always in a worker process
    isolatable(host)    whether ``host`` can be rebuilt in a worker process
    shutdown()          stop every worker (at exit, or in tests)

A plugin is numpy, OpenCV, Open3D: C and C++ that a bad input can make read memory it
does not own. In the CLI that ends one command; in the GUI server it ended every
operator's session. So the GUI's plugin runs go through :func:`run`: the inputs are
pickled to a worker process, which runs ``PluginHost.run`` there and pickles the
RunResult back; progress comes back over the same pipe, a cancel over a second one. A
worker that dies (SIGSEGV, SIGABRT, killed for memory) becomes one line, a
:class:`PluginError`, and the next run gets a fresh worker.

A worker is a fresh interpreter (``python -c``, as multiprocessing's ``spawn`` start
method but without re-importing the server's ``__main__``; never ``fork`` from the
threaded trame server, whose locks a forked child would inherit held), talking over two
``multiprocessing.connection`` pipes (requests and answers; cancel). Workers are kept
warm between runs, so the start-up (Python, the host's manifests; the plugin's imports
on its first run) is paid once. A worker is keyed by its host's entry points and
``sys.path``; it may start processes of its own (Dask, process pools). Runs at the same
time get workers of their own; at most ``KEEP_IDLE`` idle workers are kept. A worker
whose server is gone exits (within a second, even mid-run).

A host that cannot be rebuilt in another process (not a :class:`PluginHost`, e.g. a
test's stand-in) runs in the calling thread, as does every run when the environment
variable ``CAMCMM_ISOLATE`` is ``0`` and on a system that is not POSIX.
"""

from __future__ import annotations

import atexit
import importlib.metadata as md
import logging
import multiprocessing as mp
import os
import pickle
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

from .confine import confined, current
from .errors import CamcmmError, PluginError
from .reach import addresses, check_addresses

log = logging.getLogger(__name__)

KEEP_IDLE = 2  # idle workers kept warm (over every host)
CANCEL_GRACE_S = 10.0  # after a cancel, how long a plugin may take to notice before its worker is stopped
_POLL_S = 0.05
_PROGRESS_EVERY_S = 0.02

_lock = threading.Lock()
_idle: list[_Worker] = []
_all: set[_Worker] = set()
_spawn_seconds: list[float] = []


# -- the worker process ------------------------------------------------------------------
def _host_from(recipe: tuple | None) -> Any:
    from .host import PluginHost

    if recipe is None:
        return PluginHost()
    installed = {(ep.name, ep.value, ep.group): ep for ep in md.entry_points(group="camcmm.plugins")}
    # an installed entry point keeps its distribution (the plugin version in results)
    return PluginHost([installed.get(r) or md.EntryPoint(*r) for r in recipe])


def _portable(exc: BaseException, plugin_id: str) -> BaseException:
    """``exc`` if it survives pickling, else a PluginError with its one line."""
    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:
        msg = str(exc) if isinstance(exc, CamcmmError) else f"{type(exc).__name__}: {exc}"
        return PluginError(f"plugin {plugin_id!r}: {' '.join(msg.split())}")


def _answer(result: Any, plugin_id: str) -> bytes:
    try:
        return pickle.dumps(("ok", result), protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:
        bad = "?"
        for name, value in getattr(result, "outputs", {}).items():
            try:
                pickle.dumps(value)
            except Exception:
                bad = f"{name!r} ({type(value).__name__})"
                break
        err = PluginError(
            f"plugin {plugin_id!r}: output {bad} cannot be passed back from the worker process "
            f"({type(exc).__name__}: {' '.join(str(exc).split())[:120]})"
        )
        return pickle.dumps(("error", err))


def _child() -> None:
    """The worker's main (``python -c``; argv: the two pipes' descriptors)."""
    from multiprocessing.connection import Connection

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl+C in the terminal is the server's to handle
    conn, ctl = Connection(int(sys.argv[1])), Connection(int(sys.argv[2]))
    try:
        recipe, path = conn.recv()
    except (EOFError, OSError):  # the server stopped before handing over its recipe
        return
    sys.path[:] = path
    cancel = threading.Event()
    current = [0]
    asked = [0]  # the latest run a cancel was asked for: it may overtake the run it names

    def listen() -> None:  # cancel requests arrive while the main thread computes
        while True:
            try:
                n = ctl.recv()
            except (EOFError, OSError):
                return
            asked[0] = max(asked[0], n)
            if n == current[0]:
                cancel.set()

    threading.Thread(target=listen, daemon=True, name="camcmm-worker-cancel").start()
    server = os.getppid()

    def orphaned() -> None:  # a server killed mid-run must not leave its worker computing for nobody
        while os.getppid() == server:
            time.sleep(1.0)
        os._exit(0)

    threading.Thread(target=orphaned, daemon=True, name="camcmm-worker-orphan").start()
    host = _host_from(recipe)
    conn.send(("ready", os.getpid()))
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):  # the server is gone
            return
        if msg is None:
            return
        n, plugin_id, inputs, params, folders = msg
        cancel.clear()
        current[0] = n
        if asked[0] >= n:  # cancelled before it arrived here (a worker still starting)
            cancel.set()
        last = [0.0]
        sending = threading.Lock()  # a plugin may report progress from threads of its own

        def progress(fraction: float, message: str) -> None:
            with sending:
                now = time.monotonic()
                if fraction < 1.0 and now - last[0] < _PROGRESS_EVERY_S:
                    return
                last[0] = now
                conn.send(("progress", fraction, message))

        try:
            with confined(folders):  # the server's roots: paths inside documents are checked too
                data = _answer(host.run(plugin_id, inputs, params, progress=progress, cancel=cancel), plugin_id)
        except BaseException as exc:  # noqa: BLE001 - everything goes back as one line
            data = pickle.dumps(("error", _portable(exc, plugin_id)))
        current[0] = 0
        try:
            conn.send_bytes(data)
        except (EOFError, OSError):
            return


# -- the server's side -------------------------------------------------------------------
def _recipe(host: Any) -> tuple | None:
    eps = getattr(host, "entry_points", None)
    return None if eps is None else tuple((ep.name, ep.value, ep.group) for ep in eps)


def isolatable(host: Any) -> bool:
    """Whether ``host``'s runs can go to a worker process (a PluginHost, isolation on)."""
    from .host import PluginHost

    # the pipes are handed over as inherited descriptors (POSIX); elsewhere runs stay in process
    return os.name == "posix" and os.environ.get("CAMCMM_ISOLATE", "1") != "0" and type(host) is PluginHost


class _Worker:
    def __init__(self, recipe: tuple | None):
        self.key = (recipe, tuple(sys.path))
        self.runs = 0
        self.broken = False
        t0 = time.monotonic()
        self.conn, child = mp.Pipe()
        self.ctl, child_ctl = mp.Pipe()
        fds = (child.fileno(), child_ctl.fileno())
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-c", "from camcmm.worker import _child; _child()", *map(str, fds)],
                pass_fds=fds,
                stdin=subprocess.DEVNULL,
                close_fds=True,
            )
        finally:
            child.close()
            child_ctl.close()
        try:
            self.conn.send((recipe, list(sys.path)))
            ready = self.conn.recv() if self.conn.poll(120) else None
        except (EOFError, OSError):
            ready = None
        if not ready or ready[0] != "ready":
            self.kill()
            raise PluginError(f"the plugin worker process did not start ({_death(self.proc.poll())})")
        _spawn_seconds.append(time.monotonic() - t0)
        log.info("plugin worker %s started in %.2f s", self.proc.pid, _spawn_seconds[-1])

    def alive(self) -> bool:
        return not self.broken and self.proc.poll() is None

    def stop(self) -> None:
        try:
            self.conn.send(None)
            self.proc.wait(2)
        except (OSError, ValueError, subprocess.TimeoutExpired):
            pass
        self.kill()

    def kill(self) -> None:
        self.broken = True
        if self.proc.poll() is None:
            self.proc.kill()
        try:
            self.proc.wait(5)
        except subprocess.TimeoutExpired:
            pass
        for c in (self.conn, self.ctl):
            try:
                c.close()
            except OSError:
                pass
        with _lock:
            _all.discard(self)


def _death(code: int | None) -> str:
    if code is None:
        return "no exit code"
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        return f"{name}, out of memory?" if name == "SIGKILL" else name
    return f"exit code {code}"


def _take(recipe: tuple | None) -> _Worker:
    key = (recipe, tuple(sys.path))
    found = None
    with _lock:
        stale = [w for w in _idle if not w.alive()]
        for w in stale:
            _idle.remove(w)
        found = next((w for w in _idle if w.key == key), None)
        if found is not None:
            _idle.remove(found)
    for w in stale:  # died while idle (killed from outside): reap it
        w.kill()
    if found is not None:
        return found
    w = _Worker(recipe)
    with _lock:
        _all.add(w)
    return w


def _give(w: _Worker) -> None:
    if not w.alive():
        w.kill()
        return
    with _lock:
        _idle.insert(0, w)
        extra = _idle[KEEP_IDLE:]
        del _idle[KEEP_IDLE:]
    for old in extra:
        old.stop()


def run_isolated(
    host: Any,
    plugin_id: str,
    inputs: dict[str, Any] | None = None,
    params: dict[str, Any] | None = None,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> Any:
    """``host.run(plugin_id, inputs, params, progress, cancel)`` in a worker process.

    Returns the RunResult (outputs pickled back); raises what the run raised, a
    :class:`~camcmm.host.Cancelled` when cancelled, or a one-line PluginError when the
    worker died (the next run starts a new one).
    """
    from .host import Cancelled

    w = _take(_recipe(host))
    done = False
    try:
        w.runs += 1
        try:
            w.conn.send((w.runs, plugin_id, inputs or {}, params or {}, current()))
        except (pickle.PicklingError, TypeError, AttributeError) as exc:
            done = True  # nothing reached the worker: it stays good
            raise PluginError(
                f"plugin {plugin_id!r}: an input cannot be passed to the worker process "
                f"({type(exc).__name__}: {' '.join(str(exc).split())[:160]})"
            ) from None
        asked = None
        while True:
            if w.conn.poll(_POLL_S):
                try:
                    msg = w.conn.recv()
                except (EOFError, OSError):
                    msg = None
                if msg is None:
                    break  # the pipe closed: the worker died
                if msg[0] != "progress":
                    done = True
                    if msg[0] == "ok":
                        return msg[1]
                    raise msg[1]
                if progress is not None:
                    try:
                        progress(msg[1], msg[2])
                    except Exception:  # a page's display must not break the run
                        log.exception("progress callback failed")
            elif w.proc.poll() is not None and not w.conn.poll(0):
                break
            if cancel is not None and cancel.is_set():
                if asked is None:
                    try:
                        w.ctl.send(w.runs)
                    except OSError:
                        pass
                    asked = time.monotonic()
                elif time.monotonic() - asked > CANCEL_GRACE_S:
                    w.kill()
                    raise Cancelled(
                        f"{plugin_id}: cancelled (the plugin did not stop by itself within "
                        f"{CANCEL_GRACE_S:g} s; its worker process was stopped)"
                    )
        try:
            code = w.proc.wait(5)
        except subprocess.TimeoutExpired:
            code = None
        w.kill()
        raise PluginError(
            f"{plugin_id}: the worker process died ({_death(code)}); the server keeps running "
            f"— check the inputs (a calibration or a file with impossible values?)"
        )
    finally:
        if done:
            _give(w)
        elif w.alive():  # interrupted in the parent (an exception here): its state is unknown
            w.kill()


def run(
    host: Any,
    plugin_id: str,
    inputs: dict[str, Any] | None = None,
    params: dict[str, Any] | None = None,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> Any:
    """A plugin run in a worker process when ``host`` can be rebuilt there (see
    :func:`isolatable`), else ``host.run`` in the calling thread.

    In a run the web server started (:func:`camcmm.reach.server_run`) a parameter that is a
    network address must be one the operator configured (``--scheduler``): refused here,
    in one line, before anything could connect."""
    if addresses() is not None and callable(getattr(host, "get", None)):
        params = check_addresses(host.get(plugin_id).parameters, params)
    if isolatable(host):
        return run_isolated(host, plugin_id, inputs, params, progress, cancel)
    return host.run(plugin_id, inputs=inputs, params=params, progress=progress, cancel=cancel)


def warm(host: Any) -> None:
    """Start a worker for ``host`` ahead of the first run (e.g. in a thread at server start)."""
    if isolatable(host):
        _give(_take(_recipe(host)))


def warm_later(host: Any) -> threading.Thread:
    """:func:`warm` in a background thread (at server start: the first run then finds its
    worker ready); a failure is logged as one line, the first run will try again."""

    def go() -> None:
        try:
            warm(host)
        except Exception as exc:
            log.warning("plugin worker not started ahead: %s", " ".join(str(exc).split()))

    t = threading.Thread(target=go, daemon=True, name="camcmm-worker-warm")
    t.start()
    return t


def spawn_seconds() -> list[float]:
    """How long each worker took to start (s), for benchmarks and the log."""
    return list(_spawn_seconds)


@atexit.register
def shutdown() -> None:
    """Stop every worker, idle or busy (a non-daemon busy one would block the exit)."""
    with _lock:
        workers = list(_all)
        _idle.clear()
    for w in workers:
        w.kill()


__all__ = ["run", "run_isolated", "isolatable", "warm", "warm_later", "shutdown", "spawn_seconds", "KEEP_IDLE"]
