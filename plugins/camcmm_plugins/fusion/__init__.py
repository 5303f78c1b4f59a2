"""Fusion of coherence-scanning-interferometer (CSI) height maps with a photogrammetry
cloud (thesis ch. 6.1, fig. 6.1): one module per stage of the pipeline.

- :mod:`.project` — 1: the cloud's plane, projection along its normal, grey image;
- :mod:`.prepare` — 2: the CSI grey image, contrast stretch, Gaussian blur;
- :mod:`.match` — 3: SIFT matching and the two RANSAC rejections;
- :mod:`.similarity2d` — 4: the 2-D similarity of eq. 6.1;
- :mod:`.zreg` — 5: z registration and the 3-DOF (tz, rx, ry) ICP;
- :mod:`.merge` — 6: the fused cloud with its source field;
- :mod:`.difference` — 7: CSI − photogrammetry, histogram, Abbott-Firestone curve;
- :mod:`.plugin` (host entry), :mod:`.cli` (``camcmm fuse csi``), :mod:`.report`.
"""
