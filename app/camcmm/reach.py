"""What a run the web server starts may reach: folders and network addresses (issue 26,
docs/security.md).

A plugin parameter says what it is in its manifest (:mod:`camcmm.params`): ``type: path``
(a file or folder, ``access: read|write``) or ``type: address`` (a network address the
plugin connects to: a Dask scheduler ``tcp://host:8786``). In the web server

* a **path** must lie in the project folder or a ``--data-root`` folder
  (:mod:`camcmm.confine`; checked by what it is, not by its parameter's name);
* an **address** must equal one the operator configured at start
  (``camcmm serve --scheduler ADDRESS``, repeatable). Anything else is refused in one
  line *before* any connection is tried, with the same text whether something listens
  there or not: the server connects nowhere the operator did not name, and its answers
  tell nothing about the network behind it (no port scanner).

:func:`server_run` sets both for the calling context: a page's job enters it in its own
thread for every run (:mod:`camcmm.gui.jobs`), never at app build (tests build apps
in-process). :func:`camcmm.worker.run` holds every plugin run to the addresses
(:func:`check_addresses`) before anything reaches the worker process. Outside a server
run (the CLI, a script) nothing is checked: the user may connect wherever they may.

A lab's older manifest that declares a path or an address as ``type: str`` is still
recognised by the parameter's name (:data:`PATH_NAMES`, :data:`ADDRESS_NAMES`).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

from .confine import confined, within
from .errors import InputError

#: parameter names that name a file or a folder in a manifest that does not say so (``type: path``)
PATH_NAMES = frozenset({"save", "out", "output", "outdir", "directory", "dir", "folder", "path", "file", "plan", "cti"})
PATH_SUFFIXES = ("_path", "_dir", "_file", "_folder", "_directory")
#: parameter names that hold a network address in a manifest that does not say so (``type: address``)
ADDRESS_NAMES = frozenset({"scheduler"})
ADDRESS_SUFFIXES = ("_scheduler",)

#: the message tail of every refused address (tests and docs quote it)
NOT_CONFIGURED = (
    "not a scheduler this server was started with (camcmm serve --scheduler ADDRESS); refused without connecting"
)

_ADDRESSES: ContextVar[tuple[str, ...] | None] = ContextVar("camcmm_allowed_addresses", default=None)


def is_path_param(p: Any) -> bool:
    """Does parameter declaration ``p`` name a file or folder? Declared ``type: path``, or
    (a lab's older manifest) a ``str`` parameter named like one (``out``, ``save``, ``*_dir`` ...)."""
    kind = getattr(p, "type", "")
    if kind == "path":
        return True
    name = str(getattr(p, "name", "")).lower()
    return kind == "str" and (name in PATH_NAMES or name.endswith(PATH_SUFFIXES))


def is_address_param(p: Any) -> bool:
    """Does parameter declaration ``p`` hold a network address? Declared ``type: address``,
    or (a lab's older manifest) a ``str`` parameter named ``scheduler`` or ``*_scheduler``."""
    kind = getattr(p, "type", "")
    if kind == "address":
        return True
    name = str(getattr(p, "name", "")).lower()
    return kind == "str" and (name in ADDRESS_NAMES or name.endswith(ADDRESS_SUFFIXES))


def normal_address(text: Any) -> str:
    """An address as compared: stripped, without a trailing ``/``."""
    return str(text).strip().rstrip("/")


def addresses() -> tuple[str, ...] | None:
    """The addresses a run of this context may connect to, or None when nothing is
    restricted (the CLI)."""
    return _ADDRESSES.get()


@contextmanager
def server_run(folders: Iterable[str | Path] | None, allowed: Iterable[str] = ()) -> Iterator[None]:
    """Confine this context (thread, task) as a run the web server starts: paths to
    ``folders`` (the first is the project folder), network addresses to ``allowed``.
    ``folders`` None: nothing is confined (a session without a browser)."""
    if folders is None:
        yield
        return
    token = _ADDRESSES.set(tuple(dict.fromkeys(normal_address(a) for a in allowed if normal_address(a))))
    try:
        with confined(folders):
            yield
    finally:
        _ADDRESSES.reset(token)


def address_in(value: Any, allowed: Iterable[str], what: str) -> str:
    """``value`` (stripped) if it equals one of ``allowed``; else one line naming ``what``
    and the value. Nothing is resolved or connected to: the answer is the same whatever
    listens at that address."""
    text = normal_address(value)
    if text in {normal_address(a) for a in allowed}:
        return text
    shown = text if len(text) <= 80 else text[:77] + "..."
    raise InputError(f"{what}: {shown!r}: {NOT_CONFIGURED}")


def check_values(
    parameters: Iterable[Any],
    values: dict[str, Any] | None,
    folders: tuple[Path, ...] | None,
    allowed: Iterable[str] | None,
) -> dict[str, Any]:
    """``values`` (a copy) with every path parameter checked against ``folders`` and made
    absolute, every address parameter checked against ``allowed``; an empty value is "not
    given" and passes. ``folders`` / ``allowed`` None: that kind is not checked."""
    out = dict(values or {})
    for p in parameters or ():
        v = out.get(p.name)
        if not isinstance(v, (str, Path)) or not str(v).strip():
            continue
        if folders is not None and is_path_param(p):
            out[p.name] = str(within(v, folders, f"parameter {p.name!r}"))
        elif allowed is not None and is_address_param(p):
            out[p.name] = address_in(v, allowed, f"parameter {p.name!r}")
    return out


def check_addresses(parameters: Iterable[Any], values: dict[str, Any] | None) -> dict[str, Any]:
    """``values`` with every address parameter held to this context's :func:`addresses`
    (unchanged outside a server run)."""
    return check_values(parameters, values, None, addresses())


__all__ = [
    "ADDRESS_NAMES",
    "NOT_CONFIGURED",
    "PATH_NAMES",
    "address_in",
    "addresses",
    "check_addresses",
    "check_values",
    "is_address_param",
    "is_path_param",
    "normal_address",
    "server_run",
]
