"""``camcmm cloud``: big clouds out of core (:mod:`camcmm.bigcloud`).

    camcmm cloud index FILE --out DIR [--unit U] [--chunk N] [--seed S]
        the level-of-detail store of a binary PLY / .npy / .xyz, built in chunks
    camcmm cloud compare STORE --nominal MESH [--scheduler ADDRESS] [--workers N]
                         [--chunk N] [--bin-width MM] [--tolerance MM]
        signed distances to a nominal mesh on Dask (a local cluster by default),
        statistics merged exactly; the distances become the store's field ``deviation``
    camcmm cloud info STORE
        the store's metadata

The work is light to import: :mod:`camcmm.bigcloud` and Dask load when a command runs.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from ..errors import ParameterError

SUMMARY = "Big clouds out of core: index a file into a level-of-detail store, compare it with a mesh on Dask."


def _whole(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return v


def _length(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (mm)") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"{text!r} must be a length above 0 mm")
    return v


def configure(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="cloud_command", metavar="ACTION")
    ix = sub.add_parser("index", help="build the level-of-detail store of a point file, in chunks")
    ix.add_argument("file", help="binary PLY, .npy (N x 3 or x/y/z records) or .xyz/.txt/.csv")
    ix.add_argument("--out", required=True, help="store folder (created; must be new or empty)")
    ix.add_argument("--unit", help="length unit of the file (m, cm, mm, um, in); default: the file's own, else mm")
    ix.add_argument("--chunk", type=_whole, default=1_000_000, help="points read at a time (default 1000000)")
    ix.add_argument("--seed", type=int, default=0, help="seed of the random order within the cells (default 0)")
    ix.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    cp = sub.add_parser("compare", help="signed distances of a store to a nominal mesh on Dask")
    cp.add_argument("store", help="store folder (camcmm cloud index)")
    cp.add_argument("--nominal", required=True, help="nominal triangle mesh (STL, PLY, OBJ)")
    cp.add_argument("--scheduler", help="Dask scheduler address (tcp://host:8786); default: a local cluster")
    cp.add_argument("--workers", type=_whole, help="workers of the local cluster (default 2)")
    cp.add_argument("--chunk", type=_whole, default=1_000_000, help="points per task (default 1000000)")
    cp.add_argument("--bin-width", type=_length, default=0.001, help="histogram bin width, mm (default 0.001)")
    cp.add_argument("--tolerance", type=_length, help="report the share of |deviation| <= this, mm")
    cp.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    inf = sub.add_parser("info", help="the metadata of a store")
    inf.add_argument("store", help="store folder")
    inf.add_argument("--json", action="store_true", help="print one JSON document on stdout")


def run(args: argparse.Namespace) -> dict[str, Any]:
    what = getattr(args, "cloud_command", None)
    if what == "index":
        from ..bigcloud import build_store

        return {"action": "index", **build_store(args.file, args.out, unit=args.unit, chunk=args.chunk, seed=args.seed)}
    if what == "compare":
        from ..bigcloud.compare import compare_store

        if args.scheduler is not None and args.workers is not None:
            raise ParameterError("--workers sizes the local cluster; with --scheduler the cluster has its own workers")
        return {
            "action": "compare",
            **compare_store(
                args.store,
                args.nominal,
                scheduler=args.scheduler,
                workers=args.workers,
                chunk=args.chunk,
                bin_width=args.bin_width,
                tolerance=args.tolerance,
            ),
        }
    if what == "info":
        from ..bigcloud import read_meta

        return {"action": "info", "store": args.store, **read_meta(args.store)}
    raise ParameterError("camcmm cloud: name an action: index, compare or info")


def text(r: dict[str, Any]) -> str:
    if r["action"] in ("index", "info"):
        lo, hi = r["bounds"]
        lines = [
            f"store {r.get('store', '')}".rstrip() if r["action"] == "info" else "store built",
            f"  points: {r['n']:,} in {r['n_cells']:,} cells (octree level {r['grid']['level']}, "
            f"cell {r['grid']['cell']:.4g} mm)",
            "  bounds [mm]: (" + ", ".join(f"{x:.4f}" for x in lo) + ") .. (" + ", ".join(f"{x:.4f}" for x in hi) + ")",
            f"  fields: {', '.join(r['fields']) or '-'}",
            f"  source: {r['source']['file']} ({r['source']['format']}, unit {r['source']['unit']}, "
            f"sha256 {r['source']['sha256'][:16]}...)",
        ]
        if r["action"] == "index":
            lines.append(f"  built in {r['build_seconds']:.2f} s")
        lines += [f"warning: {w}" for w in r.get("warnings", [])]
        return "\n".join(lines)
    s = r["statistics"]
    um = lambda x, sign="+": f"{1000 * x:{sign}.3f} um"  # noqa: E731
    lines = [
        f"{s['n']:,} points of {r['store']} against {r['nominal']['name']} "
        f"({r['nominal']['n_triangles']:,} triangles), {r['n_chunks']} chunks on {r['scheduler']}",
        f"  mean {um(s['mean'])}  std {um(s['std'], '')}  rms {um(s['rms'], '')}",
        f"  min {um(s['min'])}  max {um(s['max'])}",
        f"  95 % within {um(s['p2_5'])} .. {um(s['p97_5'])}  median {um(s['p50'])}"
        + ("" if r["exact"]["percentiles"] else " (interpolated in the histogram's bins)"),
    ]
    if "within_tolerance" in s:
        lines.append(f"  within +-{s['tolerance']} mm: {100 * s['within_tolerance']:.3f} %")
    lines.append(f"  {r['seconds']['total']:.2f} s; deviations written to {r['field']}")
    lines += [f"warning: {w}" for w in r.get("warnings", [])]
    return "\n".join(lines)
