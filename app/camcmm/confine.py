"""The folders a run may touch: none are enforced in the CLI, the project folder and
the data roots in the web server (issue 26, docs/security.md "Paths").

The server checks the paths the browser sends (parameters declared ``type: path``,
inputs, server folders) with :class:`camcmm.gui.roots.Roots`. But a document the
browser names — a study file, a plan, a calibrated-lengths file, a projector sequence —
names paths of its own (a study's ``work:`` folder, a light-field run's clouds). So a
run the server starts is *confined*: :func:`confined` sets the allowed folders for the
calling context (and the worker process gets them with the run), and every reader that
takes a path out of a document resolves it with :func:`document_path`, which refuses a
path outside those folders before anything is opened, created or listed.

The refusal says only that the path was refused (:data:`OUTSIDE`): never whether it
exists, nor a byte of it, so no error is an oracle for the files of the machine.
Outside a confined context (the CLI, a script) :func:`check` and :func:`document_path`
only resolve: the user may read whatever they may read.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

from .errors import InputError

#: the message tail of every refusal (tests and docs quote it)
OUTSIDE = (
    "outside the folders this server may read (project folder and --data-root); "
    "start camcmm serve with --data-root FOLDER to allow another folder"
)

_FOLDERS: ContextVar[tuple[Path, ...] | None] = ContextVar("camcmm_confined_folders", default=None)


class PathRefused(InputError):
    """A path outside the folders of a confined run (one line, naming the path as given)."""


def resolve_folders(folders: Iterable[str | Path]) -> tuple[Path, ...]:
    """``folders`` resolved (``~``, ``..``, symlinks), duplicates dropped, order kept."""
    return tuple(dict.fromkeys(Path(f).expanduser().resolve() for f in folders))


def current() -> tuple[Path, ...] | None:
    """The folders of the confined context, or None when nothing is confined (the CLI)."""
    return _FOLDERS.get()


@contextmanager
def confined(folders: Iterable[str | Path] | None) -> Iterator[tuple[Path, ...] | None]:
    """Confine the paths of this context (thread, task) to ``folders`` (the first one is
    the project folder, where relative paths start); ``None`` lifts nothing and confines
    nothing, so a caller can pass a session's roots or ``None`` alike."""
    if folders is None:
        yield current()
        return
    resolved = resolve_folders(folders)
    token = _FOLDERS.set(resolved)
    try:
        yield resolved
    finally:
        _FOLDERS.reset(token)


def within(path: str | Path, folders: tuple[Path, ...], what: str = "", base: str | Path | None = None) -> Path:
    """``path`` resolved (relative ones from ``base``, else from ``folders[0]``) if it lies
    in one of ``folders``; else :class:`PathRefused`. ``what`` names the field or key."""
    text = str(path).strip().strip('"').strip()
    label = f"{what}: {text}" if what else text
    if not text or "\x00" in text:
        raise PathRefused(f"{label or what or 'path'}: not a path")
    p = Path(text).expanduser()
    if not p.is_absolute():
        p = Path(base if base is not None else folders[0]) / p
    try:
        r = p.resolve()
    except (OSError, RuntimeError) as exc:  # a symlink loop
        raise PathRefused(f"{label}: cannot be resolved ({type(exc).__name__})") from None
    if any(r == f or r.is_relative_to(f) for f in folders):
        return r
    raise PathRefused(f"{label}: {OUTSIDE}")


def check(path: str | Path, what: str = "", base: str | Path | None = None) -> Path:
    """``path`` resolved (relative from ``base``, else the working folder or, when
    confined, the project folder); in a confined context it must lie in the folders."""
    folders = current()
    if folders is not None:
        return within(path, folders, what, base)
    text = str(path).strip()
    if not text or "\x00" in text:
        raise InputError(f"{what or 'path'}: {text!r} is not a path" if text else f"{what or 'path'}: empty path")
    p = Path(text).expanduser()
    if not p.is_absolute() and base is not None:
        p = Path(base) / p
    return p


def document_path(value: str | Path, document: str | Path, key: str) -> Path:
    """A path named inside a document: relative to the document's folder, checked like
    every other path of a confined run. ``key`` names where it stands in the document
    (``"work"``, ``"runs[2].cloud"``); the error reads ``STUDY.yaml: runs[2].cloud: …``."""
    doc = Path(document)
    try:
        return check(value, key, base=doc.parent)
    except PathRefused as exc:
        raise PathRefused(f"{doc.name}: {exc}") from None
