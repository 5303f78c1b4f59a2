"""The calibrated-lengths file of ``--scale lengths:FILE``.

YAML (or JSON)::

    lengths: [5.942, 7.956, 9.957]   # a ball plate: L1 = |c1c2|, L2 = |c2c3|, L3 = |c3c1|, mm
    u: 0.00025                       # standard uncertainty of each length, mm (optional)

or the pairs spelt out (spheres numbered from 1)::

    lengths:
      - {from: 1, to: 2, length: 5.942, u: 0.00025}
      - {from: 2, to: 3, length: 7.956}

CSV (.csv, .txt): one row ``from,to,length[,u]`` per length; a header row and ``#``
comments are skipped.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

from camcmm.api import InputError, read_yaml

MAX_LENGTHS = 64


def _num(v: Any, path: Path, where: str, positive: bool = True) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{path}: {where}: {v!r} is not a number") from None
    if not (x == x and abs(x) != float("inf")) or (x <= 0 if positive else x < 0):
        raise InputError(f"{path}: {where}: {v!r} must be {'> 0' if positive else '>= 0'} (mm)")
    return x


def _index(v: Any, path: Path, where: str) -> int:
    try:
        i = int(v)
    except (TypeError, ValueError):
        raise InputError(f"{path}: {where}: sphere number {v!r} is not an integer") from None
    if not 1 <= i <= 7:
        raise InputError(f"{path}: {where}: sphere number {i} outside 1..7")
    return i - 1


def read_lengths(path: Path) -> dict[str, Any]:
    """``{pairs [(a, b)] (0-based sphere numbers), lengths [mm], u [mm], file}``."""
    path = Path(path)
    rows: list[tuple[Any, Any, Any, Any, str]] = []
    if path.suffix.lower() in (".yaml", ".yml", ".json"):
        doc = read_yaml(path)
        if not isinstance(doc, dict) or not isinstance(doc.get("lengths"), list):
            raise InputError(f"{path}: expected a mapping with a list 'lengths'")
        u0 = doc.get("u", 0.0)
        items = doc["lengths"]
        if items and all(not isinstance(x, dict) for x in items):
            if len(items) != 3:
                raise InputError(f"{path}: 'lengths' as plain numbers means a ball plate's three; got {len(items)}")
            rows = [(a + 1, (a + 1) % 3 + 1, x, u0, f"lengths[{a}]") for a, x in enumerate(items)]
        else:
            for k, x in enumerate(items):
                if not isinstance(x, dict) or not {"from", "to", "length"} <= set(x):
                    raise InputError(f"{path}: lengths[{k}]: expected {{from, to, length[, u]}}")
                rows.append((x["from"], x["to"], x["length"], x.get("u", u0), f"lengths[{k}]"))
    else:
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(f"{path}: cannot read ({exc})") from None
        for k, f in enumerate(csv.reader(text.splitlines()), 1):
            f = [x.strip() for x in f]
            if not f or not f[0] or f[0].startswith("#"):
                continue
            if k == 1 and not f[0].lstrip("+-").isdigit():
                continue  # a header
            if len(f) not in (3, 4):
                raise InputError(f"{path}: line {k}: expected from,to,length[,u]")
            rows.append((f[0], f[1], f[2], f[3] if len(f) == 4 else 0.0, f"line {k}"))
    if not rows:
        raise InputError(f"{path}: no calibrated lengths")
    if len(rows) > MAX_LENGTHS:
        raise InputError(f"{path}: more than {MAX_LENGTHS} lengths")
    pairs, lengths, us = [], [], []
    for a, b, length, u, where in rows:
        i, j = _index(a, path, where), _index(b, path, where)
        if i == j:
            raise InputError(f"{path}: {where}: a length from sphere {i + 1} to itself")
        pairs.append((i, j))
        lengths.append(_num(length, path, where))
        us.append(_num(u, path, where + " u", positive=False))
    used = {k for p in pairs for k in p}
    if used != set(range(max(used) + 1)):
        raise InputError(f"{path}: spheres must be numbered 1..{max(used) + 1} without gaps")
    return {"pairs": pairs, "lengths": lengths, "u": us, "file": str(path)}
