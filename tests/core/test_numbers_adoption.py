"""Where the core writes a number a person reads, it follows the number rule: an item's
size and the unit question's span never in exponent form."""

from __future__ import annotations

import numpy as np

from camcmm.model import PointCloud
from camcmm.tasks.items import size_text
from camcmm.units import _g


def test_spans_never_in_exponent_form():
    assert _g(2.5e-5) == "0.000025" and _g(1234.6) == "1235" and _g(0.1 + 0.2) == "0.3"
    flat = PointCloud(np.array([[0.0, 0.0, 0.0], [150.0, 60.0, 2.0e-5]]), name="flat")
    assert size_text(flat) == "150 × 60 × 0.00002 mm"
