"""Point-cloud preparation: voxel downsampling, outlier removal, normal estimation.

Kept import-light: the host reads ``plugin.yaml`` beside this file without importing
the numerics in :mod:`.ops`.
"""
