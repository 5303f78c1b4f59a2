"""The Inspect page's formatter is the app's one number rule: :mod:`camcmm.numbers`.

Kept so that ``from ..inspect import numbers`` keeps working; new code imports
``camcmm.numbers`` (plugins: ``from camcmm.api import numbers``).
"""

from __future__ import annotations

from ....numbers import *  # noqa: F403  (the whole rule, re-exported)
from ....numbers import __all__ as __all__
