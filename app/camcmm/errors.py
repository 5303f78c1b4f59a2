"""Exceptions with a one-line, user-facing reason.

Every error the app shows an operator is a :class:`CamcmmError` whose ``str()`` is a
single line naming the culprit (a file, a value, a plugin). The CLI prints it to stderr
and exits non-zero; the GUI shows it and keeps running.
"""

from __future__ import annotations


class CamcmmError(Exception):
    """Base class: ``str(err)`` is one line that names what is wrong."""

    def __str__(self) -> str:  # keep the reason to one line, whatever the caller passed
        return " ".join(super().__str__().split())


class InputError(CamcmmError):
    """Bad input data: a file that cannot be read, NaN coordinates, wrong delimiter..."""


class ParameterError(CamcmmError):
    """A parameter value outside its declared type or limits."""


class PluginError(CamcmmError):
    """A plugin that cannot be found, loaded or run."""


class GeometryError(CamcmmError):
    """Degenerate geometry: too few points, collinear points for a plane, ..."""


class ProjectError(CamcmmError):
    """A project folder that cannot be opened or written."""
