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


def test_sizes_in_bytes_never_in_exponent_form():
    from camcmm.gui.uploads import size_text as upload_size
    from camcmm.limits import human_bytes

    # ".3g" wrote 999.6 kB as "1e+03 kB"
    assert human_bytes(999.6e3) == "1000 kB" and human_bytes(12345678) == "12.3 MB" and human_bytes(512) == "512 B"
    assert upload_size(1000 * 1024) == "1000 KB" and upload_size(1.5 * 1024**3) == "1.5 GB"
