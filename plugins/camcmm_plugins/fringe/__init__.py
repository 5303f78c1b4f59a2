"""Fringe projection (thesis ch. 5): pattern sequences (sequence, patterns), decoding
(phase, codes, unwrap, decode), 3-D (triangulate, reconstruct), calibration folders
(calib) and exact synthetic captures (synthetic). Plugins fringe.patterns, fringe.decode,
fringe.reconstruct and the ``camcmm fringe`` command; see docs/fringe.md."""
