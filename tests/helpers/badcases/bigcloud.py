"""Bad inputs of ``camcmm cloud index|compare|info`` (big clouds out of core, issue 29).

Every refusal comes before any heavy work (no Dask cluster is started: the store, the
nominal and the options are checked first), one line naming the file, the folder or the
option. Ids start with ``bc-``."""

from __future__ import annotations

import functools
import io
import json

import numpy as np

from helpers.badinputs import Case, ply_ascii, ply_binary, ply_mesh


@functools.cache
def _pts() -> np.ndarray:
    return np.random.default_rng(2).uniform(-10, 10, (300, 3))


def _npy(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def _ply_xy() -> bytes:
    head = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nend_header\n"
    return head.encode() + np.zeros((3, 2), "<f4").tobytes()


def _store_meta(n: int = 10) -> bytes:
    return json.dumps(
        {"format": "camcmm-bigcloud", "version": 1, "n": n, "grid": {"lo": [0, 0, 0], "cell": 1, "level": 0}}
    ).encode()


def _mesh() -> bytes:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return ply_mesh(v, f)


def cases() -> list[Case]:
    p = _pts()
    ok = ply_binary(p)
    idx = ("cloud", "index")
    return [
        Case("bc-index-ascii-ply", (*idx, "c.ply", "--out", "st"), {"c.ply": ply_ascii(p)}, ("c.ply",)),
        Case("bc-index-truncated", (*idx, "c.ply", "--out", "st"), {"c.ply": ply_binary(p, 1000)}, ("c.ply",)),
        Case("bc-index-no-z", (*idx, "c.ply", "--out", "st"), {"c.ply": _ply_xy()}, ("c.ply",)),
        Case("bc-index-extension", (*idx, "c.las", "--out", "st"), {"c.las": ok}, ("c.las",)),
        Case("bc-index-missing", (*idx, "nothere.ply", "--out", "st"), {}, ("nothere.ply",)),
        Case("bc-index-folder", (*idx, "d", "--out", "st"), {"d/": b""}, ("d",)),
        Case("bc-index-out-not-empty", (*idx, "c.ply", "--out", "st"), {"c.ply": ok, "st/x": b"1"}, ("st",)),
        Case("bc-index-all-nan", (*idx, "c.ply", "--out", "st"), {"c.ply": ply_binary(p * np.nan)}, ("c.ply",)),
        Case("bc-index-unit", (*idx, "c.ply", "--out", "st", "--unit", "parsec"), {"c.ply": ok}, ("parsec",)),
        Case("bc-index-chunk", (*idx, "c.ply", "--out", "st", "--chunk", "0"), {"c.ply": ok}, ("--chunk",)),
        Case("bc-index-xyz-word", (*idx, "c.xyz", "--out", "st"), {"c.xyz": b"1 2 3\n4 5 6\n7 x 9\n"}, ("c.xyz",)),
        Case("bc-index-xyz-columns", (*idx, "c.xyz", "--out", "st"), {"c.xyz": b"1 2\n3 4\n"}, ("c.xyz",)),
        Case("bc-index-npy-1d", (*idx, "c.npy", "--out", "st"), {"c.npy": _npy(np.arange(5.0))}, ("c.npy",)),
        Case("bc-index-metres-no-unit", (*idx, "c.npy", "--out", "st"), {"c.npy": _npy(p / 1000)}, ("c.npy",)),
        Case("bc-index-npy-garbage", (*idx, "c.npy", "--out", "st"), {"c.npy": b"\x93NUMPY garbage"}, ("c.npy",)),
        Case(
            "bc-compare-not-store",
            ("cloud", "compare", "d", "--nominal", "m.ply"),
            {"d/": b"", "m.ply": _mesh()},
            ("d",),
        ),
        Case(
            "bc-compare-bad-meta",
            ("cloud", "compare", "d", "--nominal", "m.ply"),
            {"d/meta.json": b"{not json", "m.ply": _mesh()},
            ("meta.json",),
        ),
        Case(
            "bc-compare-damaged",
            ("cloud", "compare", "d", "--nominal", "m.ply"),
            {"d/meta.json": _store_meta(), "m.ply": _mesh()},
            ("points.npy",),
        ),
        Case(
            "bc-compare-nominal-cloud",
            ("cloud", "compare", "d", "--nominal", "c.ply"),
            {"d/meta.json": _store_meta(), "d/points.npy": _npy(np.zeros((10, 3))), "c.ply": ok},
            ("c.ply",),
        ),
        Case(
            "bc-compare-bin-width",
            ("cloud", "compare", "d", "--nominal", "m.ply", "--bin-width", "0"),
            {"d/meta.json": _store_meta(), "m.ply": _mesh()},
            ("--bin-width",),
        ),
        Case(
            "bc-compare-workers-and-scheduler",
            ("cloud", "compare", "d", "--nominal", "m.ply", "--workers", "2", "--scheduler", "tcp://127.0.0.1:9"),
            {"d/meta.json": _store_meta(), "m.ply": _mesh()},
            ("--workers",),
        ),
        Case("bc-info-not-store", ("cloud", "info", "d"), {"d/": b""}, ("d",)),
        Case("bc-no-action", ("cloud",), {}, ("index",)),
    ]
