"""Geometric element fitting: least-squares and minimum-zone lines, planes, circles,
spheres, cylinders, cones and tori with the outlier rules of the standards, and sphere
segmentation for the acceptance tests.

The package is light on purpose (the plugin host reads ``plugin.yaml`` without
importing code). The Python API is :mod:`camcmm_plugins.fitting.api`; the plugin entry
points are in :mod:`camcmm_plugins.fitting.plugin`, the ``camcmm fit`` command in
:mod:`camcmm_plugins.fitting.cli`.
"""
