"""The Monte Carlo on a Dask distributed cluster.

The work is the same list of chunks the local run computes — each chunk a number of
trials with its own ``np.random.SeedSequence`` child (see
:func:`camcmm_plugins.uncertainty.montecarlo.plan`) — sent with ``Client.map`` and
gathered in submission order, then merged in that order exactly as locally: a Dask run
and a local run with the same seed give identical numbers, whatever the number of
workers. For studies that outgrow one machine: many configurations, many points,
multi-camera networks.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from camcmm.api import InputError


class DaskExecutor:
    """``map(fn, tasks)`` over a Dask cluster: a scheduler address or a ``Client``."""

    def __init__(self, scheduler: Any, timeout: float = 30.0):
        try:
            from dask.distributed import Client
        except ImportError as exc:  # pragma: no cover - dask is a dependency
            raise InputError(f"--scheduler needs dask[distributed]: {exc}") from None
        if isinstance(scheduler, Client):
            self.client, self._own = scheduler, False
        else:
            try:
                self.client, self._own = Client(scheduler, timeout=timeout), True
            except Exception as exc:  # noqa: BLE001 - any connection failure is the address's fault
                raise InputError(
                    f"Dask scheduler {scheduler!r}: cannot connect ({type(exc).__name__}: {exc})"
                ) from None

    def map(self, fn: Callable, tasks: Sequence[tuple], progress: Callable | None = None) -> list:
        from dask.distributed import as_completed

        if not tasks:
            return []
        setup = tasks[0][0]
        shared = self.client.scatter(setup, broadcast=True)  # the grid and cameras once per worker
        futures = [self.client.submit(fn, shared, *t[1:], pure=False) for t in tasks]
        if progress is not None:
            for i, _ in enumerate(as_completed(futures)):
                progress((i + 1) / len(futures), "Monte Carlo (Dask)")
        return self.client.gather(futures)  # in submission order

    def close(self) -> None:
        if self._own:
            self.client.close()
