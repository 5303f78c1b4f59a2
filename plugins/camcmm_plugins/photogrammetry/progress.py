"""Progress of structure from motion that moves: images done, pairs matched, images registered.

pycolmap's feature extraction and matching take no progress callback and run for minutes on
a long series (templeRing, 47 views, exhaustive: 1081 pairs; the issue saw matching sit at
one percentage for 3 min). :func:`in_chunks` therefore hands them the work in pieces — the
images to extract, the image pairs to match — and reports ``done of total`` with an
estimate of the time left after each piece; the results are those of one call (each image's
features and each pair's verification do not depend on the others; same seed). A call has
a cost of its own (matcher threads, the database read again): measured on templeRing, 47
views, ring matching (``benchmarks/bench_photogrammetry_progress.py``, CPU time of the
process, load 9-13): matching +9 to +12 % (~0.2 s per extra call), extraction +0 to +5 %.
So the pieces are sized from the rate so far to last :data:`TARGET_S` each: on a long run
(minutes of matching) that is a few per cent, and the count moves every few seconds.
(Counting the rows COLMAP writes to its database from a second connection instead made
COLMAP abort with "database is locked": it sets no busy handler.)

Messages read ``<stage>: <done> of <total> <unit>, about <time> left`` (:func:`step_text`;
:func:`parse_step` reads them back); the fractions a :class:`Stages` reports never decrease.
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from camcmm.api import Cancelled, numbers

#: seconds each piece of work should last (from the rate so far): a call's own ~0.2 s is
#: ~4 % of it, and the count moves every few seconds
TARGET_S = 5.0
#: no estimate of the time left before this many seconds of a stage have passed (the first
#: items carry the start-up cost)
MIN_ELAPSED_S = 2.0


def step_text(stage: str, done: int, total: int, unit: str, elapsed_s: float | None = None) -> str:
    """``"matching: 120 of 232 pairs, about 40 s left"``; the estimate (remaining items at
    the mean rate so far) once ``elapsed_s`` >= :data:`MIN_ELAPSED_S` and something is done."""
    text = f"{stage}: {done} of {total} {unit}"
    if elapsed_s is not None and elapsed_s >= MIN_ELAPSED_S and 0 < done < total:
        text += f", about {numbers.time(elapsed_s * (total - done) / done)} left"
    return text


_STEP = re.compile(r"^(?P<stage>[^:]+): (?P<done>\d+) of (?P<total>\d+) (?P<unit>[a-z]+)")


def parse_step(message: str) -> tuple[str, int, int, str] | None:
    """``(stage, done, total, unit)`` of a :func:`step_text` message, else None."""
    m = _STEP.match(str(message or ""))
    return None if m is None else (m["stage"], int(m["done"]), int(m["total"]), m["unit"])


class Stages:
    """Progress over the stages of SfM (weights :data:`WEIGHTS`, summing to 1) and a
    cancellation token polled from ``cancel``. ``progress(fraction, message)`` may be called
    from several threads (the stage's own and pycolmap's mapper callbacks); the fraction never decreases."""

    WEIGHTS = {"extract": 0.25, "match": 0.4, "map": 0.3, "refine": 0.05}

    def __init__(self, pycolmap: Any, progress: Callable[[float, str], None] | None, cancel: Any):
        self.progress, self.cancel = progress, cancel
        self.token = pycolmap.CancellationToken() if hasattr(pycolmap, "CancellationToken") else None
        self.done = 0.0
        self.timings: dict[str, float] = {}
        self._last = 0.0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        if cancel is not None and self.token is not None:
            threading.Thread(target=self._watch, daemon=True).start()

    def _watch(self) -> None:
        while not self._stop.wait(0.2):
            if self.cancel():
                if self.token is not None:
                    self.token.cancel()
                return

    def check(self) -> None:
        if (self.cancel is not None and self.cancel()) or (self.token is not None and self.token.is_cancelled):
            self.close()
            raise Cancelled("photogrammetry: cancelled")

    def report(self, stage: str, within: float, message: str) -> None:
        """``within`` (0..1) of ``stage`` done; a fraction below one reported before is raised to it."""
        if self.progress is None:
            return
        with self._lock:
            self._last = max(self._last, min(1.0, self.done + self.WEIGHTS.get(stage, 0.0) * min(1.0, within)))
            self.progress(self._last, message)

    def run(self, stage: str, message: str, fn: Callable[[], Any]) -> Any:
        self.check()
        self.report(stage, 0.0, message)
        t0 = time.perf_counter()
        try:
            out = fn()
        except InterruptedError:  # pycolmap's answer to the cancellation token mid-stage
            self.close()
            raise Cancelled("photogrammetry: cancelled") from None
        self.timings[stage] = time.perf_counter() - t0
        self.check()
        self.done += self.WEIGHTS.get(stage, 0.0)
        return out

    def close(self) -> None:
        self._stop.set()


T = TypeVar("T")


def in_chunks(
    stages: Stages,
    stage: str,
    label: str,
    unit: str,
    items: Sequence[T],
    work: Callable[[Sequence[T], bool], None],
    *,
    first: int,
    start: float = 0.0,
    target_s: float = TARGET_S,
) -> None:
    """``work(piece, is_first)`` over ``items`` in pieces, in order: ``first`` items, then as
    many as the rate so far does in ``target_s`` (at least ``first``). Before the first and
    after each piece ``label: done of total unit`` (with the time left) is reported within
    ``stage`` from ``start`` (0..1 of the stage, for work done before) to 1; a cancel is
    looked at between pieces."""
    n = len(items)
    t0 = time.perf_counter()
    stages.report(stage, start, step_text(label, 0, n, unit))
    done, size = 0, max(1, int(first))
    while done < n:
        stages.check()
        piece = items[done : done + size]
        work(piece, done == 0)
        done += len(piece)
        elapsed = time.perf_counter() - t0
        stages.report(stage, start + (1.0 - start) * done / n, step_text(label, done, n, unit, elapsed))
        size = max(int(first), int(done / max(elapsed, 1e-3) * target_s))
