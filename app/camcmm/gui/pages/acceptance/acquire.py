"""Acquiring a position from a measuring system instead of importing a file.

A measuring system the wizard can drive is any algorithm plugin whose manifest says
``acquires: pointcloud``: it takes a ``placement`` (the test, the position as the
standard lays it out, the repeat, the measuring volume and the plan's artefacts) and returns a
``cloud``. A real system measures whatever the operator has put in front of it (the
placement tells it what to expect); a simulated one (``virtuallab.fringe-system``)
puts the artefact there itself. The cloud then goes through exactly the import path
of a file: evaluated in the worker, recorded on the loop.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from camcmm import worker
from camcmm.errors import one_line
from camcmm.io import write

from ...widgets import declared_fields, form_values


def acquisition_sources(host: Any) -> list[dict[str, Any]]:
    """The installed plugins that acquire a point cloud, for the "Measure with" list."""
    out = []
    try:
        specs = host.all()
    except Exception:
        return out
    for p in specs:
        if p.kind == "algorithm" and p.acquires == "pointcloud":
            out.append({"title": p.name, "value": p.id, "summary": p.summary})
    return out


class PageAcquire:
    """The acquisition handlers of :class:`~camcmm.gui.pages.acceptance.WizardPage`."""

    def set_source(self, plugin_id: str | None, params: dict[str, Any] | None = None) -> None:
        """Choose the measuring system; its declared parameters become the settings form
        (defaults, with ``params`` over them)."""
        fields: list[dict[str, Any]] = []
        values: dict[str, Any] = {}
        if plugin_id:
            try:
                fields, values = declared_fields(self.session.host.get(plugin_id).parameters)
            except Exception as exc:
                self.session.error(f"measuring system {plugin_id!r}: {one_line(exc)}")
                plugin_id = None
        values.update(dict(params or {}))
        self.state.wz_source = plugin_id or None
        self.state.wz_source_fields = fields
        self.state.wz_source_params = values

    def source_params(self, source: str) -> dict[str, Any]:
        """The settings form's values checked against the system's declaration (raises the
        one-line InputError naming the value)."""
        return form_values(self.session.host.get(source), self.state.wz_source_params)

    def placement(self, test: str, position: str) -> dict[str, Any]:
        w = self.wizard
        plan = w.plan
        req = next((r for r in w.requirements() if r["test"] == test), None)
        pos = next((p for p in (req or {}).get("positions", []) if p["id"] == position), None)
        if pos is None:
            raise KeyError(f"{test}/{position}: no such position in this test")
        return {
            "standard": w.state.get("standard"),
            "test": test,
            "position": dict(pos),
            "measuring_volume": list((plan.get("system") or {}).get("measuring_volume") or []),
            "artefacts": dict(plan.get("artefacts") or {}),
        }

    def _acquire(self, source: str, params: dict[str, Any], placement: dict[str, Any]) -> Path:
        """Worker: run the system, write its cloud to a temporary PLY for the import."""
        res = worker.run(self.session.host, source, {"placement": placement}, params)
        cloud = res.outputs["cloud"]
        folder = Path(tempfile.mkdtemp(prefix="camcmm-acquire-"))
        path = folder / f"{placement['test']}-{placement['position']['id']}.ply"
        write(cloud, path)
        return path

    async def acquire_async(self, test: str, position: str, repeat: int | None = None) -> dict[str, Any] | None:
        source = self.state.wz_source
        key = f"{test}/{position}"
        if not source:
            self.session.error("choose a measuring system under 'Measure with' first")
            return None
        if key in self._busy:
            self.session.error(f"{position}: a measurement is under way; wait for it")
            return None
        self.session.bind_loop()
        try:
            params = self.source_params(source)
        except Exception as exc:  # a setting the system's declaration refuses: before any work
            self.session.error(f"{position}: {source} could not measure: {one_line(exc)}")
            return None
        try:
            placement = self.placement(test, position)
            # which repeat this is (a simulated system draws a new speckle pattern per repeat)
            placement["repeat"] = self.wizard.prepare(test, position, repeat).repeat
        except Exception as exc:
            self.session.error(one_line(exc))
            return None
        self._set_busy(key, True)
        self.refresh_cards()
        self.flush()
        try:
            path = await self.job.call(self._acquire, source, params, placement)
        except Exception as exc:
            self._set_busy(key, False)
            self.refresh_cards()
            self.session.error(f"{position}: {source} could not measure: {one_line(exc)}")
            self.flush()
            return None
        self._set_busy(key, False)
        try:
            return await self.import_async(test, position, path, path.name, repeat)
        finally:
            path.unlink(missing_ok=True)
            path.parent.rmdir()

    async def acquire_all_async(self) -> int:
        """Every position still to do, one after the other; stops at the first failure."""
        done = 0
        self.state.wz_acquiring_all = True
        self.flush()
        try:
            for block in self.wizard.cards():
                for card in block["cards"]:
                    while card["status"] in ("pending", "partial", "error"):
                        if not self.state.wz_acquiring_all:
                            return done
                        if await self.acquire_async(card["test"], card["id"]) is None:
                            return done
                        done += 1
                        card = self.wizard.card(card["test"], card["id"])
        finally:
            self.state.wz_acquiring_all = False
            self.flush()
        return done
