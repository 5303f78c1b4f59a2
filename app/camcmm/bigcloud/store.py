"""The on-disk store of a big cloud, built out of core: the points in level-of-detail order.

A store is a folder::

    meta.json            counts, bounds (mm), unit, grid, fields, provenance (source SHA-256)
    points.npy           (N, 3) float64, mm, in store order (cells in Morton order, random within a cell)
    source_index.npy     (N,) int64: each stored point's row in the source file
    cells.npy            (C, 4) int64: the occupied cells' grid indices i, j, k and point count, in order
    fields/NAME.npy      (N,) per-point scalar fields in store order, in the source's dtype

``.npy`` files are read through memory maps (:class:`camcmm.bigcloud.lod.LodIndex.open`).
Coordinates are kept as float64 mm: exact for float32 and float64 sources in mm (a unit
other than mm is multiplied by its factor, rounded once as :func:`camcmm.io.read` does).

Building (:func:`build_store`) holds at most one chunk of the source (``chunk`` rows) and
one bucket at a time, never the whole cloud:

1. read the file through once: count, bounds, non-finite rows (left out, with a warning),
   a sample of every ``stride``-th row (stride a power of two, so at most
   :data:`SAMPLE` rows); the octree level and bucket bounds (Morton ranges holding about
   ``2 chunk`` points) come from the sample;
2. read it again: each row's record (x, y, z, row, fields) is appended to its bucket file;
3. each bucket is loaded, sorted by the store key (:func:`camcmm.bigcloud.grid.sort_key`)
   and written to its place in the output; its cells are counted.

The SHA-256 of the source file is a third read. ``meta.json`` is written last: a folder
without it is no store (an interrupted build).
"""

from __future__ import annotations

import json
import re
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..errors import InputError
from ..hashing import file_hash
from ..limits import check_disk
from ..units import decide_unit
from .grid import CELL_POINTS, Grid, choose_level, sort_key
from .sources import CHUNK, open_source

FORMAT = "camcmm-bigcloud"
VERSION = 1
#: Most sample rows used to choose the octree level and the bucket bounds.
SAMPLE = 1 << 19
_FIELD_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}$")


def sample_stride(n: int) -> int:
    """The smallest power of two ``s`` with ``ceil(n / s) <= SAMPLE``: the sample is rows
    ``0, s, 2s, ...`` whether the rows come in one array or in chunks."""
    s = 1
    while -(-n // s) > SAMPLE:
        s *= 2
    return s


def is_store(folder: str | Path) -> bool:
    return (Path(folder) / "meta.json").is_file()


def read_meta(folder: str | Path) -> dict[str, Any]:
    """The store's ``meta.json``; InputError (one line) when the folder is no store."""
    f = Path(folder) / "meta.json"
    if not f.is_file():
        raise InputError(f"{folder}: not a big-cloud store (no meta.json; build one with camcmm cloud index FILE)")
    try:
        meta = json.loads(f.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{f}: unreadable ({type(exc).__name__})") from None
    if meta.get("format") != FORMAT or meta.get("version") != VERSION:
        raise InputError(
            f"{f}: format {meta.get('format')!r} version {meta.get('version')!r}, expected {FORMAT} {VERSION}"
        )
    return meta


def layout(points: np.ndarray, rows: np.ndarray, grid: Grid, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Order of ``points`` (rows ``rows`` of the source) in the store, and their occupied
    cells (Morton-sorted ``ijk`` (C, 3), counts (C,)). The points are one bucket: whole cells."""
    code = grid.morton(points)
    order = np.argsort(sort_key(code, rows, seed), kind="stable")
    sc = code[order]
    first = np.flatnonzero(np.concatenate([[True], sc[1:] != sc[:-1]]))
    counts = np.diff(np.append(first, len(sc))).astype(np.int64)
    return order, grid.ijk(points[order[first]]), counts


def build_store(
    source: str | Path,
    folder: str | Path,
    *,
    unit: str | None = None,
    chunk: int = CHUNK,
    seed: int = 0,
    cell_points: int = CELL_POINTS,
    progress: Callable[[float, str], None] | None = None,
) -> dict[str, Any]:
    """Build the store of point file ``source`` in ``folder`` (created; must be empty or
    absent) out of core, ``chunk`` rows at a time. Returns the metadata (also in
    ``folder/meta.json``)."""
    t0 = time.perf_counter()
    src = open_source(source, unit)
    out = Path(folder)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError(f"{out}: the store folder exists and is not empty; name a new folder")
    bad_names = [k for k in src.fields if not _FIELD_NAME.match(k)]
    if bad_names:
        raise InputError(f"{src.name}: field name {bad_names[0]!r} cannot name a file (letters, digits, _ . -)")
    if chunk < 1:
        raise InputError(f"chunk {chunk}: must be at least 1")
    rec_fields = [(k, np.dtype(v)) for k, v in src.fields.items()]
    rec = np.dtype([("p", "<f8", (3,)), ("row", "<i8"), *[(f"f_{k}", dt) for k, dt in rec_fields]])
    size = src.path.stat().st_size
    check_disk(f"big-cloud store of {src.name}", 2.2 * size * max(1.0, rec.itemsize / 12.0), out.parent)
    say = progress or (lambda f, m: None)

    # -- pass 1: count, bounds, sample
    n_rows = n_bad = 0
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    stride, sample = 1, []
    for pts, _ in src.chunks(chunk):
        ok = np.isfinite(pts).all(axis=1)
        good = pts if ok.all() else pts[ok]
        if len(good):
            lo, hi = np.minimum(lo, good.min(axis=0)), np.maximum(hi, good.max(axis=0))
        rows = np.arange(n_rows, n_rows + len(pts))
        take = (rows % stride == 0) & ok
        sample.append((rows[take], pts[take]))
        n_rows += len(pts)
        n_bad += int(len(pts) - ok.sum())
        while -(-n_rows // stride) > SAMPLE:  # the stride doubles as the file goes on
            stride *= 2
            sample = [(r[r % stride == 0], p[r % stride == 0]) for r, p in sample]
        say(0.3 * n_rows / max(src.n or n_rows, 1), f"reading {n_rows:,} points")
    n = n_rows - n_bad
    if n == 0:
        raise InputError(f"{src.name}: no finite points")
    sample_pts = np.concatenate([p for _, p in sample]) if sample else np.empty((0, 3))
    level = choose_level(sample_pts, n, lo, hi, cell_points)
    grid = Grid.of(lo, hi, level)
    # bucket bounds: Morton codes splitting the sample into pieces of ~2 chunks
    codes = np.sort(grid.morton(sample_pts))
    per = max(1, int(len(codes) * (2 * chunk) / n))
    bounds = np.unique(codes[per::per]) if len(codes) > per else np.empty(0, np.uint32)

    created = not out.exists()
    try:
        # -- pass 2: records into bucket files
        out.mkdir(parents=True, exist_ok=True)
        tmp = out / "_buckets"
        tmp.mkdir()
        files = [open(tmp / f"{b:05d}.rec", "wb") for b in range(len(bounds) + 1)]
        counts_b = np.zeros(len(bounds) + 1, dtype=np.int64)
        try:
            row0 = 0
            for pts, fields in src.chunks(chunk):
                ok = np.isfinite(pts).all(axis=1)
                keep = slice(None) if ok.all() else ok
                b = np.searchsorted(bounds, grid.morton(pts[keep]), side="right")
                # stable, in row order within a bucket; 16-bit ids sort by radix (10x faster)
                order = np.argsort(b.astype(np.uint16) if len(bounds) < 65535 else b, kind="stable")
                r = np.empty(len(order), dtype=rec)
                r["p"] = pts[keep][order]
                r["row"] = (np.arange(len(pts)) if ok.all() else np.flatnonzero(ok))[order] + row0
                for k, _ in rec_fields:
                    r[f"f_{k}"] = fields[k][keep][order]
                row0 += len(pts)
                cuts = np.searchsorted(b[order], np.arange(len(bounds) + 2))
                for j in np.flatnonzero(np.diff(cuts)):
                    files[j].write(r[cuts[j] : cuts[j + 1]].tobytes())
                counts_b += np.diff(cuts)
                say(0.3 + 0.3 * row0 / max(n_rows, 1), f"sorting {row0:,} points into {len(files)} buckets")
        finally:
            for f in files:
                f.close()

        # -- pass 3: each bucket sorted into place
        mm_points = np.lib.format.open_memmap(out / "points.npy", "w+", "<f8", (n, 3))
        mm_rows = np.lib.format.open_memmap(out / "source_index.npy", "w+", "<i8", (n,))
        (out / "fields").mkdir()
        mm_fields = {
            k: np.lib.format.open_memmap(out / "fields" / f"{k}.npy", "w+", dt.newbyteorder("<"), (n,))
            for k, dt in rec_fields
        }
        cells_ijk, cells_n = [], []
        at = 0
        for jb, m in enumerate(counts_b.tolist()):
            bucket = tmp / f"{jb:05d}.rec"
            if m:
                r = np.fromfile(bucket, rec)
                order, ijk, cnt = layout(r["p"], r["row"], grid, seed)
                r = r[order]
                mm_points[at : at + m] = r["p"]
                mm_rows[at : at + m] = r["row"]
                for k, _ in rec_fields:
                    mm_fields[k][at : at + m] = r[f"f_{k}"]
                cells_ijk.append(ijk)
                cells_n.append(cnt)
                at += m
            bucket.unlink()
            say(0.6 + 0.3 * at / n, f"writing {at:,} points")
        shutil.rmtree(tmp)
        for a in (mm_points, mm_rows, *mm_fields.values()):
            a.flush()
        del mm_points, mm_rows, mm_fields
        cells = np.column_stack([np.concatenate(cells_ijk), np.concatenate(cells_n)]).astype(np.int64)
        np.save(out / "cells.npy", cells)
        say(0.9, "hashing the source")
        warnings = []
        decision = decide_unit((hi - lo).tolist(), src.unit if src.stated else None, name=src.name)
        if decision.status == "ask":  # no unit stated and a size implausible as mm (docs/units.md)
            warnings.append(decision.reason)
        if n_bad:
            warnings.append(f"{src.name}: {n_bad} rows with non-finite coordinates left out")
        meta = {
            "format": FORMAT,
            "version": VERSION,
            "n": n,
            "n_source_rows": n_rows,
            "n_invalid": n_bad,
            "bounds": [lo.tolist(), hi.tolist()],
            "unit": "mm",
            "dtype": "float64",
            "grid": grid.to_dict(),
            "n_cells": len(cells),
            "seed": seed,
            "fields": {k: dt.newbyteorder("<").str for k, dt in rec_fields},
            "source": {
                "file": str(src.path.resolve()),
                "format": src.format,
                "bytes": size,
                "sha256": file_hash(src.path),
                "unit": src.unit,
                "unit_stated": src.stated,
                "factor_to_mm": src.factor,
            },
            "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "camcmm": __version__,
            "build_seconds": round(time.perf_counter() - t0, 3),
            "warnings": warnings,
        }
        (out / "meta.json").write_text(json.dumps(meta, indent=2))
    except BaseException:
        _discard(out, created)  # a failed or interrupted build leaves nothing behind
        raise
    say(1.0, "done")
    return meta


def _discard(out: Path, created: bool) -> None:
    if created:
        shutil.rmtree(out, ignore_errors=True)
    elif out.is_dir():
        for child in out.iterdir():
            if child.is_dir():
                shutil.rmtree(child, ignore_errors=True)
            else:
                child.unlink(missing_ok=True)
