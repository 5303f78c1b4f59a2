"""Big clouds out of core: an on-disk store in level-of-detail order, view-dependent
selection, and comparisons with a nominal mesh in chunks on Dask (issue 29).

    build_store(FILE, FOLDER)          -> metadata; the store of a binary PLY / .npy / .xyz, built in chunks
    LodIndex.from_points(points)       -> an index held in memory
    LodIndex.open(FOLDER)              -> the index of a store, memory-mapped
    index.uniform(k), index.select(camera, viewport, budget), index.fields(rows)
    compare_store(FOLDER, mesh, scheduler=None) -> signed distances on Dask, statistics merged exactly

Modules: :mod:`.sources` (chunked readers), :mod:`.grid` (cells and order), :mod:`.store`,
:mod:`.lod`, :mod:`.exact` (exact sums, histograms, order statistics), :mod:`.compare`.
"""

from .compare import compare_store
from .lod import LodIndex, in_view, view_matrix
from .store import build_store, is_store, read_meta

__all__ = ["LodIndex", "build_store", "compare_store", "in_view", "is_store", "read_meta", "view_matrix"]
