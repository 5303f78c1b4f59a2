"""Keeping and handing out a comparison of the "Compare with CAD" page: stored in the
project (the result, its deviations cloud as a result file, the page's state under
``inspection.current``) and shown again when the project is reopened; exported as a
coloured PLY (offered for download and added as an item); reported by the inspection
plugin's own report writer (HTML, PDF, JSON, added to the project).

:class:`Export` is a mixin of :class:`.page.ComparePage`. Files are written in the
page's job (a worker thread); the state is touched from the loop.
"""

from __future__ import annotations

import importlib
import logging
import re
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .... import io as cio
from ....errors import CamcmmError, PluginError, one_line
from ....host import RunResult
from ....model import PointCloud
from ...downloads import REPORT_TITLES, safe_file_name, sort_links
from ...view import fmt_count
from .scene import prepare_cloud
from .tables import band_colours, diverging_colours

log = logging.getLogger("camcmm.gui.inspect")

STATE_KEY = "inspection.current"


def _safe_file_name(name: str) -> str:
    return safe_file_name(name, "inspection")


class Export:
    """Store, restore, export and report (mixin of ComparePage)."""

    # -- storing and restoring --------------------------------------------------------------
    def _store(self, result: RunResult, mids: list) -> dict[str, Any]:
        """Worker thread: the deviations cloud as a project file, the result, the state."""
        dev = result.outputs["deviations"]
        h = self.project.add_object(dev, _safe_file_name(dev.name) + ".ply")
        rid = self.project.add_result(
            result, measurement_ids=mids, files={"deviations": h}, label="inspection: compare with CAD"
        )
        saved = {
            "result": rid,
            "measured": self._mid(self.state.ins_measured),
            "nominal": self._mid(self.state.ins_nominal),
            "align": result.params.get("align"),
            "tolerance": result.params.get("tolerance"),
            "pairs": self.pairs(),
            "deviations": h,
            "report": None,
            "export": None,
        }
        self.project.set_state(STATE_KEY, saved)
        return saved

    def _mid(self, key: Any) -> Any:
        m = self.session.measurement(key)
        return m["id"] if m else None

    def _stored(self, saved: dict[str, Any]) -> None:
        self.saved = saved
        self.result_id = saved["result"]
        self.state.ins_result_id = saved["result"]
        self.state.ins_report_links = []
        self.state.ins_export_links = []
        self.session.refresh_results()
        c = "" if not self.state.ins_failed else " (the alignment failed)"
        self.session.info(f"comparison stored as result #{saved['result']}{c}")

    def restore(self) -> bool:
        """Show the last comparison stored in the project (``inspection.current``)."""
        try:
            saved = self.project.get_state(STATE_KEY)
        except Exception:
            return False
        if not isinstance(saved, dict) or saved.get("result") is None:
            return False
        s = self.state
        try:
            d = self.project.result(int(saved["result"]))
            h = (d.get("files") or {}).get("deviations") or saved.get("deviations")
            cloud = cio.read(self.project.file_path(h))
            outputs = dict(d.get("outputs") or {})
            outputs["deviations"] = cloud
            result = RunResult(
                d.get("plugin") or self._spec_of().id,
                d.get("version", ""),
                d.get("params") or {},
                d.get("input_hashes") or {},
                outputs,
                d.get("started", ""),
                d.get("finished", ""),
                list(d.get("warnings") or []),
            )
        except Exception as exc:
            s.ins_error = f"the last comparison (result {saved.get('result')}) cannot be shown: {one_line(exc)}"
            return False
        for key, attr in (("measured", "ins_measured"), ("nominal", "ins_nominal")):
            if saved.get(key) is not None and self.session.measurement(saved[key]) is not None:
                setattr(s, attr, str(saved[key]))
        if saved.get("align"):
            s.ins_align = saved["align"]
        if saved.get("tolerance") is not None:
            s.ins_tolerance = saved["tolerance"]
        pairs = saved.get("pairs") or {}
        self._pairs_measured = [list(map(float, p)) for p in pairs.get("measured") or []]
        self._pairs_nominal = [list(map(float, p)) for p in pairs.get("nominal") or []]
        self._publish_pairs()
        try:
            self.nominal = self.load(s.ins_nominal, "nominal") if s.ins_nominal else None
            self.measured = self.load(s.ins_measured, "measured cloud") if s.ins_measured else None
        except Exception:
            self.nominal = None
        prep = prepare_cloud(cloud.points, cloud.fields.get("deviation"), self.view.display_limit)
        self._show_result(result, prep)
        self.saved = saved
        self.result_id = int(saved["result"])
        s.ins_result_id = self.result_id
        s.ins_progress = 0.0
        s.ins_progress_message = ""
        self._auto_section()
        s.ins_report_links = self._links(saved.get("report") or {}, "report")
        s.ins_export_links = self._links({"ply": saved["export"]} if saved.get("export") else {}, "export")
        return True

    def _save_state(self) -> None:
        try:
            self.project.set_state(STATE_KEY, self.saved)
        except Exception as exc:
            log.warning("cannot save %s: %s", STATE_KEY, exc)

    # -- export ----------------------------------------------------------------------------
    def _export_cloud(self) -> Any:
        """The deviations cloud coloured as the view shows it (colour map or bands),
        with the field ``deviation`` (mm)."""
        c = self.deviations
        dev = np.asarray(c.fields["deviation"], dtype=float)
        if self.state.ins_mode == "bands" and self.bands is not None:
            colours, what = band_colours(self.bands["codes"]), "tolerance bands"
        else:
            colours, what = diverging_colours(dev, float(self.outputs.get("colour_limit") or 1e-3)), "deviations"
        fields = dict(c.fields)
        units = dict(c.field_units)
        units["deviation"] = "mm"
        base = self._name(self.state.ins_measured) if self.state.ins_measured else c.name
        base = re.sub(r"\.(ply|pcd|xyz|txt|csv|e57)$", "", base, flags=re.I)
        return PointCloud(c.points, colours, c.normals, fields, units, f"{base} {what}", c.source_unit)

    def _write_export(self, cloud: Any) -> tuple[Path, str]:
        """Worker thread: write the PLY into the downloads folder and add it to the project."""
        name = _safe_file_name(cloud.name) + ".ply"
        path = self.downloads / name
        cio.write(cloud, path)
        h = self.project.add_file(path)
        return path, h

    async def export_async(self) -> dict[str, Any] | None:
        """Export in the page's job; returns ``{"path", "hash", "item"}``, or None with
        the reason shown."""
        if not self._can("export"):
            return None
        self.state.ins_busy = "export"
        self.flush()
        try:
            cloud = self._export_cloud()
            path, h = await self.job.run(self._write_export, cloud)
        except Exception as exc:
            self._error(f"export: {one_line(exc)}")
            return None
        finally:
            self.state.ins_busy = ""
        out = self._exported(cloud, path, h)
        self.flush()
        return out

    def _exported(self, cloud: Any, path: Path, h: str) -> dict[str, Any]:
        mid = self.session.add_measurement(path.name, h, cloud, source=f"{self._spec_of().id} result #{self.result_id}")
        key = str(mid)
        self.session.refresh_items()
        if self.saved:
            self.saved["export"] = h
            self._save_state()
        self.state.ins_export_links = [self.offered.offer(path.name, path, kind="ply")]
        self.session.info(
            f"exported {path.name} ({fmt_count(cloud.n_points)} points, field deviation in mm); added to the project"
        )
        return {"path": str(path), "hash": h, "item": key}

    def _can(self, what: str) -> bool:
        if self.deviations is None or self.outputs is None:
            self._error(f"{what}: run a comparison first")
            return False
        if what == "export" and self.state.ins_failed:
            self._error(
                "export: the alignment failed, so the deviations are not valid; nothing is exported "
                "(the report records the failure)"
            )
            return False
        if self.state.ins_busy:
            self._error(f"{what}: wait for the {self.state.ins_busy} to finish")
            return False
        return True

    # -- report ----------------------------------------------------------------------------
    def _report_writer(self) -> Callable[..., Any]:
        """The report writer the comparison plugin's manifest declares (``report:
        module:function``)."""
        spec = self._spec_of()
        declared = spec.report
        if not declared:
            raise PluginError(f"plugin {spec.id!r} declares no report writer ('report: module:function')")
        module, _, name = str(declared).partition(":")
        try:
            return getattr(importlib.import_module(module), name)
        except (ImportError, AttributeError) as exc:
            raise PluginError(
                f"plugin {spec.id!r}: its report writer {declared!r} cannot be loaded: {one_line(exc)}"
            ) from None

    def _make_report(self, folder: Path) -> dict[str, str]:
        """Worker thread: the report files (html, pdf, json) in ``folder``."""
        build = self._report_writer()
        o = dict(self.outputs or {})
        tol = self._tolerance(quiet=True)
        if tol is None:
            tol = (o.get("stats") or {}).get("tolerance")
        mname, nname = self._name(self.state.ins_measured), self._name(self.state.ins_nominal)
        rep = build(o, cloud_file=mname, nominal_file=nname, run=self.result, tolerance=tol)
        inputs = []
        for key, role in ((self.state.ins_measured, "measured cloud"), (self.state.ins_nominal, "nominal")):
            m = self.session.measurement(key)
            if m and m.get("hash"):
                inputs.append({"file": str(m.get("name")), "sha256": m["hash"], "role": role})
        if inputs:
            rep.provenance(
                inputs=inputs, extra={"project": str(getattr(self.project, "path", "")), "result": self.result_id}
            )
        return rep.write(folder, basename=f"inspection-{self.result_id or 'new'}")

    def _report_files(self, folder: Path) -> tuple[dict[str, str], dict[str, str]]:
        """Worker thread: write the report and record it in the project."""
        paths = self._make_report(folder)
        return paths, self._record_report(paths)

    def _record_report(self, paths: dict[str, str]) -> dict[str, str]:
        files = {f"report_{k}": self.project.add_file(p) for k, p in paths.items()}
        res = self.result
        if res is not None:
            mids = [m for m in (self._mid(self.state.ins_measured), self._mid(self.state.ins_nominal)) if m is not None]
            run = {
                "plugin": res.plugin_id,
                "version": res.plugin_version,
                "params": res.params,
                "input_hashes": res.input_hashes,
                "outputs": {"report_of": self.result_id, "formats": sorted(paths)},
                "started": res.started,
                "finished": res.finished,
                "warnings": [],
            }
            try:
                self.project.add_result(
                    run, measurement_ids=mids, files=files, label=f"inspection report of result #{self.result_id}"
                )
            except Exception as exc:
                log.warning("report result: %s", exc)
        if self.saved is not None:
            self.saved["report"] = files
            self._save_state()
        return files

    def _links(self, files: dict[str, str], what: str) -> list[dict[str, str]]:
        out = []
        for name, h in files.items():
            kind = name.removeprefix("report_")
            try:
                src = self.project.file_path(h)
            except CamcmmError as exc:
                log.warning("%s file %s: %s", what, name, exc)
                continue
            if what == "report":
                link = self.offered.offer(
                    f"inspection-{self.result_id}.{kind}", src, kind=kind, title=REPORT_TITLES.get(kind)
                )
            else:
                link = self.offered.offer(self._export_name(h), src, kind=kind)
            if link:
                out.append(link)
        return sort_links(out)

    def _export_name(self, h: str) -> str:
        try:
            for f in self.project.files():
                if f["hash"] == h:
                    return str(f["original_name"])
        except Exception:
            pass
        return f"deviations-{self.result_id}.ply"

    async def report_async(self) -> dict[str, Any] | None:
        """The plugin's report (HTML, PDF, JSON) in the page's job, added to the project;
        returns ``{"paths", "files", "links"}``, or None with the reason shown."""
        if not self._can("report"):
            return None
        self.state.ins_busy = "report"
        self.flush()
        folder = Path(tempfile.mkdtemp(prefix="camcmm-report-"))
        try:
            paths, files = await self.job.run(self._report_files, folder)
        except Exception as exc:
            self._error(f"report: {one_line(exc)}")
            return None
        finally:
            shutil.rmtree(folder, ignore_errors=True)
            self.state.ins_busy = ""
        out = self._reported(files)
        self.flush()
        return out

    def _reported(self, files: dict[str, str]) -> dict[str, Any]:
        links = self._links(files, "report")
        self.state.ins_report_links = links
        self.session.refresh_results()
        self.session.info(f"report written: {', '.join(l['name'] for l in links)} (in the project)")
        paths = {k.removeprefix("report_"): str(self.project.file_path(h)) for k, h in files.items()}
        return {"files": files, "paths": paths, "links": links}
