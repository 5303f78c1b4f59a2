"""The standard plugins a test can run: which are installed, each loaded through the host
and checked to speak the standard protocol (docs/standards.md), and what each declares."""

from __future__ import annotations

from typing import Any

from camcmm.errors import CamcmmError, InputError
from camcmm.standard import StandardDeclaration

from .declared import declaration_of
from .options import PlanOption, declared_options

#: What a standard object must offer the wizard (docs/standards.md).
PROTOCOL = ("requirements", "evaluate_measurement", "summarize", "write_report")


class Standards:
    """The installed standards of a host; each standard object and its declaration are
    loaded once (a test evaluates many measurements with the same one)."""

    def __init__(self, host: Any):
        self.host = host
        self._loaded: dict[str, Any] = {}
        self._decls: dict[str, StandardDeclaration] = {}
        self._options: dict[str, list[PlanOption]] = {}

    def installed(self) -> list[dict[str, Any]]:
        """Installed standard plugins that load: ``{"id", "name", "version", "summary"}``."""
        out = []
        for spec in self.host.all():
            if spec.kind != "standard":
                continue
            if spec.status != "ok":
                try:
                    self.host.load(spec.id)
                except CamcmmError:
                    continue
            out.append({"id": spec.id, "name": spec.name, "version": spec.version, "summary": spec.summary})
        return out

    def load(self, sid: str | None) -> Any:
        """The standard object of ``sid`` (``host.load``), checked to speak the protocol."""
        if not sid:
            raise InputError("no standard chosen yet")
        if sid in self._loaded:
            return self._loaded[sid]
        obj = self.host.load(sid)
        for attr in PROTOCOL:
            if not callable(getattr(obj, attr, None)):
                raise InputError(
                    f"standard plugin {sid!r} lacks {attr}(); it does not speak the standard protocol "
                    "of docs/standards.md"
                )
        self._loaded[sid] = obj
        return obj

    def declaration(self, sid: str | None) -> StandardDeclaration:
        """What standard ``sid`` declares (parameters, artefact fields, tests, positions)."""
        if not sid:
            raise InputError("no standard chosen yet")
        if sid not in self._decls:
            self._decls[sid] = declaration_of(self.load(sid), sid)
        return self._decls[sid]

    def plan_options(self, sid: str | None) -> list[PlanOption]:
        """The plan keys standard ``sid`` declares besides the form's (:mod:`.options`)."""
        if not sid:
            raise InputError("no standard chosen yet")
        if sid not in self._options:
            self._options[sid] = declared_options(self.load(sid), sid)
        return self._options[sid]

    def version(self, sid: str) -> str:
        """The installed version of ``sid`` (for the run record)."""
        return str(self.host.get(sid).version)
