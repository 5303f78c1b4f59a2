"""camcmm — a workbench for camera-based close-range coordinate metrology.

Importing ``camcmm`` is cheap: it loads neither trame, VTK nor Open3D. The public
plugin API lives in :mod:`camcmm.api`.
"""

__version__ = "0.1.0"
