"""Acquiring a position from a measuring system on the page: the "Measure with" choice
and its settings form, one position or all of them, each run in the page's job.

Which systems there are, what a system is told about a position and the run itself
belong to the task (:mod:`camcmm.tasks.acceptance.acquire`); the cloud then goes
through exactly the import path of a file (:class:`.actions.PositionActions`).
"""

from __future__ import annotations

from typing import Any

from camcmm.errors import InputError, one_line

from ...widgets import declared_fields, form_values


class Acquisition:
    """The acquisition handlers of a :class:`~camcmm.gui.pages.acceptance.WizardPage`."""

    def __init__(self, page: Any):
        self.page = page
        self.state = page.state
        self.session = page.session

    @property
    def wizard(self) -> Any:
        return self.page.wizard

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
        """The settings form's values checked against the system's declaration, its paths and
        addresses against the session's roots (raises the one-line InputError naming the
        value). ``source`` must be a measuring system (a plugin that ``acquires`` a point
        cloud): the browser names it, and another plugin (one that renders a series into a
        folder) must not run from here."""
        spec = self.session.host.get(source)
        if getattr(spec, "acquires", "") != "pointcloud" or spec.kind != "algorithm":
            raise InputError(f"measuring system {source!r}: not a plugin that acquires a point cloud")
        return form_values(spec, self.state.wz_source_params, getattr(self.session, "roots", None))

    async def acquire_async(self, test: str, position: str, repeat: int | None = None) -> dict[str, Any] | None:
        page = self.page
        source = self.state.wz_source
        key = f"{test}/{position}"
        if not source:
            self.session.error("choose a measuring system under 'Measure with' first")
            return None
        if key in page.busy:
            self.session.error(f"{position}: a measurement is under way; wait for it")
            return None
        self.session.bind_loop()
        try:
            params = self.source_params(source)
        except Exception as exc:  # a setting the system's declaration refuses: before any work
            self.session.error(f"{position}: {source} could not measure: {one_line(exc)}")
            return None
        try:
            placement = self.wizard.placement(test, position)
            # which repeat this is (a simulated system draws a new speckle pattern per repeat)
            placement["repeat"] = self.wizard.prepare(test, position, repeat).repeat
        except Exception as exc:
            self.session.error(one_line(exc))
            return None
        page.set_busy(key, True)
        page.refresh_cards()
        page.flush()
        try:
            path = await page.job.call(self.wizard.acquire, source, params, placement)
        except Exception as exc:
            page.set_busy(key, False)
            page.refresh_cards()
            self.session.error(f"{position}: {source} could not measure: {one_line(exc)}")
            page.flush()
            return None
        page.set_busy(key, False)
        try:
            return await page.actions.import_async(test, position, path, path.name, repeat)
        finally:
            path.unlink(missing_ok=True)
            path.parent.rmdir()

    async def acquire_all_async(self) -> int:
        """Every position still to do, one after the other; stops at the first failure."""
        page = self.page
        done = 0
        self.state.wz_acquiring_all = True
        page.flush()
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
            page.flush()
        return done
