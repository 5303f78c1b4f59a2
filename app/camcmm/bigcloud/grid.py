"""The cells of a big cloud: a cubic grid over its bounding box at one octree level,
cells in Morton (Z-curve) order, and within each cell the points in a random order.

A point's cell at level ``L`` is ``i = floor((p - lo) / a)`` per axis (clipped to
``0 .. 2^L - 1``) with ``a = max(hi - lo) / 2^L`` (cubic cells; the grid starts at the
box's low corner ``lo``). The level is chosen so that an occupied cell holds about
``cell_points`` points (:func:`choose_level`), from a sample when the cloud is streamed.

The order of the points in the store is the stable sort by the 64-bit key
``(Morton code << 34) | r``, where ``r`` is 34 bits of SplitMix64 (Steele, Lea & Flood,
OOPSLA 2014) of the point's row in the source file and the seed (equal keys keep the rows'
order). ``r`` depends on the row alone, not on how the file was cut into chunks, so a
store built out of core and an index built in memory from the same points order them
identically; a prefix of a cell is then a random sample of that cell.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..meshdistance import spread_bits10

#: Deepest octree level: 1024 cells per axis (a Morton code of 30 bits).
MAX_LEVEL = 10
#: Points an occupied cell should hold on average (the granularity of view culling).
CELL_POINTS = 2048
#: The store's sort key holds the cell's 30-bit Morton code above 34 random bits.
RANDOM_BITS = 34
MAX_CELLS = 1 << 23


@dataclass(frozen=True)
class Grid:
    """The cubic grid of level ``level`` from corner ``lo`` (mm) with cell side ``cell`` (mm)."""

    lo: np.ndarray
    cell: float
    level: int

    @classmethod
    def of(cls, lo, hi, level: int) -> Grid:
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        side = float((hi - lo).max()) or 1.0
        return cls(lo, side / (1 << level), level)

    def ijk(self, points: np.ndarray) -> np.ndarray:
        """(m, 3) int64 cell indices of ``points`` (mm)."""
        q = ((points - self.lo) / self.cell).astype(np.int64)  # truncation: floor for points at or above lo
        return np.clip(q, 0, (1 << self.level) - 1, out=q)

    def morton(self, points: np.ndarray) -> np.ndarray:
        return morton(self.ijk(points))

    def to_dict(self) -> dict:
        return {"lo": self.lo.tolist(), "cell": self.cell, "level": self.level}

    @classmethod
    def from_dict(cls, d: dict) -> Grid:
        return cls(np.asarray(d["lo"], dtype=float), float(d["cell"]), int(d["level"]))


def morton(ijk: np.ndarray) -> np.ndarray:
    """Morton code (uint32, 30 bits) of (m, 3) cell indices below 1024."""
    return (
        spread_bits10(ijk[:, 0])
        | (spread_bits10(ijk[:, 1]) << np.uint32(1))
        | (spread_bits10(ijk[:, 2]) << np.uint32(2))
    )


def choose_level(sample: np.ndarray, n: int, lo, hi, cell_points: int = CELL_POINTS) -> int:
    """The finest level whose occupied cells hold ``cell_points`` points or more on average,
    estimated from ``sample`` (points of the cloud of ``n``): ``n / occupied(level)``."""
    best = 0
    for level in range(1, MAX_LEVEL + 1):
        occupied = len(np.unique(Grid.of(lo, hi, level).morton(sample))) if len(sample) else 1
        if n / occupied < cell_points or occupied > MAX_CELLS:
            break
        best = level
    return best


_M64 = np.uint64(0xFFFFFFFFFFFFFFFF)


def random_bits(rows: np.ndarray, seed: int) -> np.ndarray:
    """34 pseudo-random bits (uint64) per source row: SplitMix64 of ``row + seed * golden``."""
    with np.errstate(over="ignore"):
        z = rows.astype(np.uint64) + np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15)
        z = z + np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    return z >> np.uint64(64 - RANDOM_BITS)


def sort_key(code: np.ndarray, rows: np.ndarray, seed: int) -> np.ndarray:
    """The store order's key: the cell's Morton code above the row's random bits."""
    return (code.astype(np.uint64) << np.uint64(RANDOM_BITS)) | random_bits(rows, seed)


def cell_boxes(grid: Grid, ijk: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) corners (mm) of the cells ``ijk`` (C, 3)."""
    lo = grid.lo + ijk * grid.cell
    return lo, lo + grid.cell


def largest_remainder(k: int, counts: np.ndarray) -> np.ndarray:
    """``k`` split over cells in proportion to ``counts`` (Hamilton's method), each
    share at most the cell's count; the shares add up to min(k, counts.sum())."""
    total = int(counts.sum())
    if k >= total:
        return counts.astype(np.int64).copy()
    exact = counts * (k / total)
    share = np.floor(exact).astype(np.int64)
    left = k - int(share.sum())
    if left > 0:
        share[np.argsort(-(exact - share), kind="stable")[:left]] += 1
    return np.minimum(share, counts)


def prefix_rows(starts: np.ndarray, take: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``starts[c] + 0 .. take[c]-1`` of every cell, and each row's position in its
    cell as a fraction ``(j + 1/2) / take[c]`` (the order that interleaves the cells)."""
    take = take.astype(np.int64)
    total = int(take.sum())
    cell = np.repeat(np.arange(len(take)), take)
    first = np.cumsum(take) - take
    j = np.arange(total, dtype=np.int64) - first[cell]
    return starts[cell] + j, (j + 0.5) / take[cell]
