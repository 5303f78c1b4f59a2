"""Inspection of a measured point cloud against a nominal (CAD mesh or reference cloud):
alignment, signed deviations, statistics, coverage by area and the material-ratio
(Abbott-Firestone) analysis of ISO 13565-2 / ISO 25178-2.

The package is light on purpose (the plugin host reads ``plugin.yaml`` without
importing code). One module per topic, each usable as plain functions on numpy arrays:

- :mod:`.align` — global registration (FPFH + RANSAC), point-to-plane ICP with a robust
  kernel, similarity ICP (one uniform scale), three point pairs, failure detection;
- :mod:`.distance` — signed point-to-mesh distance (closest point from Open3D's
  RaycastingScene, sign from angle-weighted pseudo-normals checked by ray parity),
  cloud-to-cloud nearest-neighbour and local-plane distances;
- :mod:`.stats` — deviation statistics, percentiles, histogram;
- :mod:`.coverage` — the fraction of the nominal surface *area* with measured points near it;
- :mod:`.material_ratio` — the material-ratio curve, Sk, Spk, Svk, Smr1, Smr2, Smc(mr);
- :mod:`.plugin` (host entries), :mod:`.cli` (``camcmm inspect``), :mod:`.report`.
"""
