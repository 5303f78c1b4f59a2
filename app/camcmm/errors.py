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


def one_line(exc: BaseException | str, name: str = "", *paths: object) -> str:
    """The reason an operator reads: one line, naming ``name`` (a file, a plugin).

    A :class:`CamcmmError` is its own message; anything else (a bug, a library's
    error) is prefixed with its type so it is not mistaken for a checked reason.
    ``paths`` (e.g. the temporary copy of an upload) are replaced by ``name``, the
    name the operator knows.
    """
    if isinstance(exc, str):
        msg = exc
    elif isinstance(exc, CamcmmError):
        msg = str(exc)
    else:
        msg = f"{type(exc).__name__}: {exc}"
    msg = " ".join(msg.split()) or "unknown error"
    for p in paths:
        if p:
            msg = msg.replace(str(p), name)
    if name and name not in msg:
        msg = f"{name}: {msg}"
    return msg
