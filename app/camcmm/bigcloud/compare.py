"""Signed distances of a big cloud to a nominal mesh, in chunks from its store, on Dask.

The store's points (:mod:`camcmm.bigcloud.store`) are cut into chunks of ``chunk`` rows.
Each chunk is one Dask task: it reads its rows from the store's memory map, computes the
signed distances with :class:`camcmm.meshdistance.MeshDistance` (the nominal's vertices
and faces are scattered to every worker once; each worker prepares the mesh once and
keeps it for all its chunks) and returns the distances with their chunk statistics. The
client writes the distances into the store (``fields/deviation.npy``, store order: the
view can colour by them) and merges the statistics, exactly:

* ``n``, ``n_invalid``, ``min``, ``max``, ``max_abs``, the histogram counts (bins
  ``[k w, (k+1) w)`` of width ``bin_width``, :class:`camcmm.bigcloud.exact.Histogram`) and
  the share within a tolerance are exact whatever the chunks;
* ``mean = fsum(d) / n`` and ``rms = sqrt(fsum(d²) / n)`` use exact sums
  (:class:`camcmm.bigcloud.exact.ExactSum`): the same digits as ``math.fsum`` over all the
  distances in memory, whatever the chunks and workers; ``std`` (sample, n - 1) is
  ``sqrt((S2 - S1² / n) / (n - 1))`` with the exact sums S1 = Σd, S2 = Σ fl(d²)
  evaluated as rational numbers, rounded once;
* the percentiles ``p0_5 ... p99_5`` (Hazen, as :mod:`camcmm_plugins.inspection.stats`
  reports them) and the Abbott-Firestone (material-ratio) curve at 101 material ratios
  ``c(mr) = Hazen quantile at 1 - mr`` come from exact order statistics: the histogram
  names the bins holding the ranks, one more pass over the written distances collects
  them (:func:`camcmm.bigcloud.exact.hazen`). They equal ``numpy.percentile(d,
  method="hazen")`` of all the distances to the last digit; if those bins held more than
  20 M values they would be interpolated in the bins instead, and ``exact.percentiles``
  says false.

The numbers do not depend on the scheduler, the number of workers or the chunk size,
only (for ``mean``'s last digit compared with numpy's pairwise ``mean``) on the
summation, which here is exact. Without ``scheduler`` a local cluster
(``dask.distributed.LocalCluster``, ``workers`` processes of one thread) runs the chunks;
with an address (``tcp://host:8786``) that cluster does, and its workers must see the
store's folder at the same path (a shared disk).
"""

from __future__ import annotations

import hashlib
import json
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, ParameterError
from ..meshdistance import MeshDistance
from ..model import TriangleMesh
from .exact import ExactSum, Histogram, hazen
from .store import read_meta

#: Percentiles reported, the same as camcmm_plugins.inspection.stats.PERCENTILES.
PERCENTILES = (0.5, 2.5, 5.0, 25.0, 50.0, 75.0, 95.0, 97.5, 99.5)
#: Material ratios (percent) of the Abbott-Firestone curve reported.
CURVE_MR = np.linspace(0.0, 1.0, 101) * 100.0
#: Default histogram bin width, mm (1 µm).
BIN_WIDTH = 0.001
#: Histograms with more bins than this are reported merged (an integer number of bins each).
MAX_REPORTED_BINS = 2000
FIELD = "deviation"

_PREPARED: dict[str, MeshDistance] = {}
_LOCK = threading.Lock()


@dataclass
class Nominal:
    """A nominal mesh as shipped to the workers: vertices, faces and their hash."""

    vertices: np.ndarray
    faces: np.ndarray
    key: str
    name: str = "nominal"

    @classmethod
    def of(cls, mesh: Any) -> Nominal:
        if isinstance(mesh, (str, Path)):
            from ..io import read

            obj = read(mesh)
            if not isinstance(obj, TriangleMesh) or len(obj.faces) == 0:
                raise InputError(f"{mesh}: the nominal must be a triangle mesh (STL, PLY, OBJ with faces)")
            mesh = obj
        if isinstance(mesh, TriangleMesh):
            V, F, name = mesh.vertices, mesh.faces, mesh.name
        else:
            V, F = mesh
            name = "nominal"
        V = np.ascontiguousarray(V, dtype=np.float64)
        F = np.ascontiguousarray(F, dtype=np.int64)
        key = hashlib.sha256(V.tobytes() + F.tobytes()).hexdigest()
        return cls(V, F, key, name)

    def prepared(self) -> MeshDistance:
        """The MeshDistance of this mesh, prepared once per process."""
        with _LOCK:
            md = _PREPARED.get(self.key)
            if md is None:
                md = _PREPARED[self.key] = MeshDistance((self.vertices, self.faces))
            return md


@dataclass
class ChunkStats:
    """What one chunk returns: its distances and their mergeable statistics."""

    start: int
    d: np.ndarray
    n: int
    n_invalid: int
    lo: float
    hi: float
    s1: ExactSum
    s2: ExactSum
    hist: Histogram
    within: int


def chunk_task(nominal: Nominal, folder: str, start: int, stop: int, width: float, tol: float | None) -> ChunkStats:
    """One chunk on a worker: signed distances of store rows ``start:stop``, and their statistics."""
    pts = np.asarray(np.load(Path(folder) / "points.npy", mmap_mode="r")[start:stop])
    d = nominal.prepared().signed_distance(pts)
    return chunk_stats(start, d, width, tol)


def chunk_stats(start: int, d: np.ndarray, width: float, tol: float | None) -> ChunkStats:
    ok = np.isfinite(d)
    f = d if ok.all() else d[ok]
    return ChunkStats(
        start,
        d,
        int(f.size),
        int(d.size - f.size),
        float(f.min()) if f.size else math.inf,
        float(f.max()) if f.size else -math.inf,
        ExactSum().add(f),
        ExactSum().add(f * f),
        Histogram(width).add(f),
        int(np.count_nonzero(np.abs(f) <= tol)) if tol is not None else 0,
    )


class _Runner:
    """A Dask client on ``scheduler`` (an address or a Client) or on a new local cluster."""

    def __init__(self, scheduler: Any, workers: int | None, timeout: float = 30.0):
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - dask is a dependency
            raise InputError(f"--scheduler needs dask[distributed]: {exc}") from None
        self.cluster = None
        if scheduler is None:
            n = workers or 2
            self.cluster = LocalCluster(
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None, memory_limit=0
            )
            self.client, self.own, self.where = Client(self.cluster), True, f"local cluster ({n} workers)"
        elif isinstance(scheduler, Client):
            self.client, self.own, self.where = scheduler, False, "client"
        else:
            try:
                self.client, self.own = Client(scheduler, timeout=timeout), True
            except Exception as exc:  # noqa: BLE001 - any connection failure is the address's fault
                raise InputError(
                    f"Dask scheduler {scheduler!r}: cannot connect ({type(exc).__name__}: {exc})"
                ) from None
            self.where = str(scheduler)

    def close(self) -> None:
        if self.own:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def compare_store(
    folder: str | Path,
    mesh: Any,
    *,
    scheduler: Any = None,
    workers: int | None = None,
    chunk: int = 1_000_000,
    bin_width: float = BIN_WIDTH,
    tolerance: float | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> dict[str, Any]:
    """Signed distances of the store ``folder``'s points to ``mesh`` (a file, a
    TriangleMesh or (vertices, faces)) on Dask, with statistics merged exactly (see the
    module docstring). Writes ``folder/fields/deviation.npy``; returns a JSON-able dict."""
    t0 = time.perf_counter()
    meta = read_meta(folder)
    folder = Path(folder)
    if FIELD in meta.get("fields", {}):
        raise InputError(f"{folder}: field {FIELD!r} comes from the source file; a comparison would overwrite it")
    if not (isinstance(chunk, int) and chunk >= 1):
        raise ParameterError(f"chunk = {chunk!r}: a whole number of points >= 1")
    if tolerance is not None and not (math.isfinite(tolerance) and tolerance > 0):
        raise ParameterError(f"tolerance = {tolerance!r}: must be above 0 mm")
    if workers is not None and not (isinstance(workers, int) and 1 <= workers <= 256):
        raise ParameterError(f"workers = {workers!r}: a whole number 1 .. 256")
    hist = Histogram(bin_width)  # checks the width
    try:  # the store's points, checked here: a worker's failure would come back as a traceback
        shape = np.load(folder / "points.npy", mmap_mode="r").shape
    except (OSError, ValueError) as exc:
        raise InputError(f"{folder / 'points.npy'}: damaged store ({type(exc).__name__})") from None
    if shape != (int(meta["n"]), 3):
        raise InputError(f"{folder / 'points.npy'}: damaged store (shape {shape}, meta.json says n={meta['n']})")
    nominal = Nominal.of(mesh)
    say = progress or (lambda f, m: None)
    n = int(meta["n"])
    (folder / "fields").mkdir(exist_ok=True)
    # written under a temporary name, renamed when complete: a failed run leaves no field
    tmp = folder / "fields" / f".{FIELD}.partial.npy"
    out = np.lib.format.open_memmap(tmp, "w+", "<f8", (n,))
    cuts = list(range(0, n, chunk)) + [n]
    s1, s2 = ExactSum(), ExactSum()
    count = n_bad = within = 0
    lo, hi = math.inf, -math.inf
    t_setup = time.perf_counter()
    runner = _Runner(scheduler, workers)
    try:
        from dask.distributed import as_completed

        t_cluster = time.perf_counter()
        shared = runner.client.scatter(nominal, broadcast=True)
        futures = [
            runner.client.submit(chunk_task, shared, str(folder.resolve()), a, b, hist.width, tolerance, pure=False)
            for a, b in zip(cuts[:-1], cuts[1:])
        ]
        for k, fut in enumerate(as_completed(futures)):
            r: ChunkStats = fut.result()
            fut.release()
            out[r.start : r.start + len(r.d)] = r.d
            count, n_bad, within = count + r.n, n_bad + r.n_invalid, within + r.within
            lo, hi = min(lo, r.lo), max(hi, r.hi)
            s1.merge(r.s1)
            s2.merge(r.s2)
            hist.merge(r.hist)
            say(0.9 * (k + 1) / len(futures), f"chunk {k + 1}/{len(futures)} (Dask)")
        del futures
        md_info = runner.client.submit(_mesh_info, shared, pure=False).result()
    finally:
        runner.close()
    out.flush()
    del out
    t_dist = time.perf_counter()
    if count == 0:
        raise InputError(f"{folder}: no finite distances")

    def values():
        dev = np.load(tmp, mmap_mode="r")
        for a in range(0, n, chunk):
            d = np.asarray(dev[a : a + chunk])
            yield d[np.isfinite(d)]

    pct = list(PERCENTILES) + list(100.0 * (1.0 - CURVE_MR / 100.0))
    q, exact_q = hazen(hist, count, pct, values)
    tmp.replace(folder / "fields" / f"{FIELD}.npy")
    t_pct = time.perf_counter()
    stats: dict[str, Any] = {
        "n": count,
        "n_invalid": n_bad,
        "mean": s1.value() / count,
        "std": _std(s1, s2, count),
        "rms": math.sqrt(s2.value() / count),
        "min": lo,
        "max": hi,
        "max_abs": max(abs(lo), abs(hi)),
    }
    stats.update({"p" + f"{p:g}".replace(".", "_"): float(v) for p, v in zip(PERCENTILES, q)})
    stats["interval95"] = [stats["p2_5"], stats["p97_5"]]
    if tolerance is not None:
        stats["tolerance"] = tolerance
        stats["within_tolerance"] = within / count
    edges, counts, group = hist.dense(MAX_REPORTED_BINS)  # merged bins: counts summed exactly
    warnings = []
    if not exact_q:
        warnings.append(
            f"percentiles interpolated in {hist.width} mm bins: the bins holding them hold over 20 M points"
        )
    result = {
        "store": str(folder),
        "n": n,
        "nominal": {"name": nominal.name, "sha256": nominal.key, "n_triangles": len(nominal.faces), "mesh": md_info},
        "executor": "dask",
        "scheduler": runner.where,
        "chunk": chunk,
        "n_chunks": len(cuts) - 1,
        "statistics": stats,
        "exact": {
            "count_min_max_histogram": True,
            "mean_rms": "fsum",
            "percentiles": exact_q,
        },
        "histogram": {"bin_width": hist.width * group, "edges": edges, "counts": counts, "unit": "mm"},
        "material_ratio": {"mr_percent": CURVE_MR, "height": q[len(PERCENTILES) :], "unit": "mm"},
        "field": str(folder / "fields" / f"{FIELD}.npy"),
        "seconds": {
            "total": round(time.perf_counter() - t0, 3),
            "mesh_and_store": round(t_setup - t0, 3),
            "cluster_start": round(t_cluster - t_setup, 3),
            "distances": round(t_dist - t_cluster, 3),
            "percentile_pass": round(t_pct - t_dist, 3),
        },
        "warnings": warnings,
    }
    _record(folder, result)
    say(1.0, "done")
    return result


def _mesh_info(nominal: Nominal) -> dict[str, Any]:
    return nominal.prepared().info.to_dict()


def _std(s1: ExactSum, s2: ExactSum, n: int) -> float:
    if n < 2:
        return 0.0
    var = (s2.fraction() - s1.fraction() ** 2 / n) / (n - 1)
    return math.sqrt(float(max(var, Fraction(0))))


def _record(folder: Path, result: dict[str, Any]) -> None:
    """Note the comparison in the store's meta.json (what the deviation field holds)."""
    f = folder / "meta.json"
    meta = json.loads(f.read_text())
    meta.setdefault("results", {})[FIELD] = {
        "nominal": result["nominal"]["name"],
        "nominal_sha256": result["nominal"]["sha256"],
        "unit": "mm",
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "statistics": {k: result["statistics"][k] for k in ("n", "mean", "std", "rms", "min", "max")},
    }
    f.write_text(json.dumps(meta, indent=2))
