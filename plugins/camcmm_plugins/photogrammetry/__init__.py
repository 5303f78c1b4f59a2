"""Multi-view photogrammetry (thesis ch. 2.3-2.5, 4): structure from motion with
pycolmap, a CPU dense stage on OpenCV, scale from calibrated spheres or lengths, import
of COLMAP and Metashape reconstructions, and the laser-speckle stability test.

Kept import-light: the host reads ``plugin.yaml`` beside this file without importing
pycolmap or OpenCV.
"""
