"""The :class:`Wizard` itself: one class made of the steps in the modules beside it, so
each topic reads on its own while callers keep one object."""

from __future__ import annotations

from .evaluate import WizardImport
from .positions import WizardPositions
from .result import WizardResult
from .setup import WizardSetup
from .state import WizardState


class Wizard(WizardResult, WizardImport, WizardPositions, WizardSetup, WizardState):
    """An acceptance test on a project, saved under :data:`STATE_KEY` as it happens."""
