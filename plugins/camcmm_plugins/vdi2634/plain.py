"""Results as JSON: numpy to Python, clouds to a short summary, NaN to None (shared by
:mod:`.standard` and :mod:`.report`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import PointCloud


def plain(x: Any) -> Any:
    """JSON-able copy: numpy to Python, clouds to a short summary, NaN to None."""
    if isinstance(x, dict):
        return {str(k): plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return plain(x.tolist())
    if isinstance(x, np.generic):
        return plain(x.item())
    if isinstance(x, float) and not np.isfinite(x):
        return None
    if isinstance(x, PointCloud):
        return {"kind": "pointcloud", "name": x.name, "n_points": x.n_points}
    if isinstance(x, Path):
        return str(x)
    return x
