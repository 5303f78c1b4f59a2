"""The virtual lab: simulated measurements with known truth. ``virtuallab.artefact-cloud``
simulates one artefact measurement (sphere, ball bar, flat, ball plate) as an area
scanner or a turntable photogrammetry system sees it, with noise and an optional
systematic distortion of the measuring volume (thesis ch. 3.3.1);
``virtuallab.acceptance-set`` writes a complete VDI/VDE 2634 part 2 or part 3
measurement set with its plan. Kept light: the manifest is read without importing."""
