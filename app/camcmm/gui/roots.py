"""The folders a browser may reach on the server: the project folder and the data
roots the operator named at start (``camcmm serve --data-root DIR``, repeatable).

Every path that comes from the page — "import a file on the server", the Calibration
page's server folder, a plugin parameter that names a file or an output folder, an
input typed as a path — goes through :meth:`Roots.check` before the server touches
it. A path is resolved first (``~``, ``..`` and symlinks: a link inside a root that
points outside is outside), then it must lie in one of the roots. A refusal is one
line naming the path as typed; it never says whether the path exists, nor shows a
byte of it. A relative path is taken from the project folder.

The same object holds the network addresses the server may connect to: the Dask
schedulers named with ``camcmm serve --scheduler ADDRESS`` (:mod:`camcmm.reach`). A
parameter declared ``type: address`` must equal one of them.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from ..confine import within
from ..errors import InputError
from ..reach import PATH_NAMES, PATH_SUFFIXES, address_in, check_values, is_address_param, is_path_param

__all__ = ["PATH_NAMES", "PATH_SUFFIXES", "Roots", "is_address_param", "is_path_param", "redact"]


class Roots:
    """The folders a browser may reach, resolved once (``folders[0]`` is the project's),
    and the ``schedulers`` (network addresses) the server may connect to."""

    def __init__(self, project_dir: str | Path, data_roots: Iterable[str | Path] = (), schedulers: Iterable[str] = ()):
        folders = [Path(project_dir).expanduser().resolve()]
        for d in data_roots or ():
            p = Path(d).expanduser()
            if not p.is_dir():
                raise InputError(f"--data-root {d}: {'is not a folder' if p.exists() else 'no such folder'}")
            folders.append(p.resolve())
        self.folders: tuple[Path, ...] = tuple(dict.fromkeys(folders))
        self.schedulers: tuple[str, ...] = tuple(
            dict.fromkeys(str(s).strip() for s in schedulers or () if str(s).strip())
        )

    @property
    def project(self) -> Path:
        return self.folders[0]

    def allows(self, path: str | Path) -> bool:
        try:
            self.check(path)
        except InputError:
            return False
        return True

    def check(self, path: str | Path, what: str = "") -> Path:
        """``path`` resolved, if it lies in a root; else :class:`InputError` (one line).

        ``what`` names the field for the message (``"server folder"``, ``"parameter 'out'"``).
        """
        return within(path, self.folders, what)

    def check_address(self, address: Any, what: str = "scheduler") -> str:
        """``address`` if it is one of the configured schedulers; else one line, the same
        whatever listens there (nothing is connected to)."""
        return address_in(address, self.schedulers, what)

    def check_params(self, parameters: Iterable[Any], values: dict[str, Any] | None) -> dict[str, Any]:
        """``values`` (a copy) with every path parameter checked and made absolute and every
        address parameter held to the schedulers; InputError (one line) for the first refused."""
        return check_values(parameters, values, self.folders, self.schedulers)

    def check_run(
        self, spec: Any, params: dict[str, Any] | None, inputs: dict[str, Any] | None, item_types: Iterable[str] = ()
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """The form's ``params`` and ``inputs`` for plugin ``spec`` with every path
        checked and made absolute (``(params, inputs)`` copies); InputError for the first
        one outside the roots. An input whose type the form offers as a project item
        (``item_types``) holds an item id, not a path, and is left alone."""
        params, inputs = self.check_params(getattr(spec, "parameters", ()) or (), params), dict(inputs or {})
        items = set(item_types)
        for port in getattr(spec, "inputs", ()) or ():
            v = inputs.get(port.name)
            if port.type in items or v in (None, ""):
                continue
            if isinstance(v, str) and v.lstrip()[:1] in ("{", "["):
                continue  # inline JSON typed into the field, not a path
            if isinstance(v, str):
                inputs[port.name] = str(self.check(v, f"input {port.name!r}"))
            elif isinstance(v, (list, tuple)):
                inputs[port.name] = [str(self.check(x, f"input {port.name!r}")) for x in v]
        return params, inputs


_QUOTED = re.compile(r"""(?<![\w])(['"])(?:(?!\1).){1,400}?\1""")


def redact(message: str, keep: Iterable[str] = ()) -> str:
    """``message`` with quoted snippets (a reader quoting the line it could not parse)
    replaced by ``'…'``: the page names the file and the reason, not its content.
    Quoted strings equal to one of ``keep`` (the file's name) stay."""
    kept = {str(k) for k in keep if k}

    def sub(m: re.Match) -> str:
        return m.group(0) if m.group(0)[1:-1] in kept else "'…'"

    return _QUOTED.sub(sub, str(message))
