"""Handing out a comparison of the "Compare with CAD" page: exported as a coloured PLY
(offered for download and added as an item), reported by the inspection plugin's own
report writer (HTML, PDF, JSON, added to the project), and the links to both, also after
the project is reopened. Storing and recording are the task's
(:mod:`camcmm.tasks.compare`); this module publishes them.

:class:`Export` is a part of :class:`.page.ComparePage`, made with the page it serves (its
``state``, ``session``, ``task``, ``job``, downloads and the comparison shown). Files are
written in the page's job (a worker thread); the state is touched from the loop.
"""

from __future__ import annotations

import logging
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ....errors import CamcmmError, InputError, one_line
from ....model import PointCloud
from ....tasks import compare as task
from ...downloads import REPORT_TITLES, safe_file_name, sort_links
from ...view import fmt_count
from .tables import band_colours, diverging_colours

log = logging.getLogger("camcmm.gui.inspect")


class Export:
    """Export, report and their links on ``page``."""

    def __init__(self, page: Any):
        self.page = page
        self.state = page.state
        self.session = page.session

    # -- export ----------------------------------------------------------------------------
    def cloud(self) -> Any:
        """The deviations cloud coloured as the view shows it (colour map or bands),
        with the field ``deviation`` (mm)."""
        page = self.page
        c = page.deviations
        dev = np.asarray(c.fields["deviation"], dtype=float)
        if self.state.ins_mode == "bands" and page.bands is not None:
            colours, what = band_colours(page.bands["codes"]), "tolerance bands"
        else:
            colours, what = diverging_colours(dev, float(page.outputs.get("colour_limit") or 1e-3)), "deviations"
        fields = dict(c.fields)
        units = dict(c.field_units)
        units["deviation"] = "mm"
        base = page.inputs.name(self.state.ins_measured) if self.state.ins_measured else c.name
        base = re.sub(r"\.(ply|pcd|xyz|txt|csv|e57)$", "", base, flags=re.I)
        return PointCloud(c.points, colours, c.normals, fields, units, f"{base} {what}", c.source_unit)

    def _write(self, cloud: Any) -> tuple[Path, str]:
        """Worker thread: the PLY in the downloads folder, added to the project."""
        name = safe_file_name(cloud.name, "inspection") + ".ply"
        return task.write_export(self.page.project, cloud, self.page.downloads, name)

    async def export_async(self) -> dict[str, Any] | None:
        """Export in the page's job; returns ``{"path", "hash", "item"}``, or None with
        the reason shown."""
        if not self._can("export"):
            return None
        self.state.ins_busy = "export"
        self.page.flush()
        try:
            cloud = self.cloud()
            path, h = await self.page.job.run(self._write, cloud)
        except Exception as exc:
            self.page.error(f"export: {one_line(exc)}")
            return None
        finally:
            self.state.ins_busy = ""
        out = self._exported(cloud, path, h)
        self.page.flush()
        return out

    def _exported(self, cloud: Any, path: Path, h: str) -> dict[str, Any]:
        page = self.page
        source = f"{page.task.spec.id} result #{page.result_id}"
        key = str(self.session.add_measurement(path.name, h, cloud, source=source))
        self.session.refresh_items()
        if page.comparison is not None:
            try:
                page.task.record_export(page.comparison, h)
            except Exception as exc:
                log.warning("cannot save %s: %s", task.STATE_KEY, exc)
        self.state.ins_export_links = [page.offered.offer(path.name, path, kind="ply")]
        self.session.info(
            f"exported {path.name} ({fmt_count(cloud.n_points)} points, field deviation in mm); added to the project"
        )
        return {"path": str(path), "hash": h, "item": key}

    def _can(self, what: str) -> bool:
        page = self.page
        if page.deviations is None or page.outputs is None or page.comparison is None:
            page.error(f"{what}: run a comparison first")
            return False
        if what == "export":
            try:
                task.refuse_failed(page.comparison, "export", "nothing is exported (the report records the failure)")
            except InputError as exc:
                page.error(exc)
                return False
        if self.state.ins_busy:
            page.error(f"{what}: wait for the {self.state.ins_busy} to finish")
            return False
        return True

    # -- report ----------------------------------------------------------------------------
    def _report_files(self, folder: Path) -> tuple[dict[str, str], dict[str, str]]:
        """Worker thread: the plugin's report in ``folder``, recorded in the project."""
        page, s = self.page, self.state
        comparison = page.comparison
        gdt = getattr(page, "gdt", None)  # the characteristics evaluated, as a section of the report
        paths = page.task.write_report(
            comparison,
            folder,
            s.ins_measured,
            s.ins_nominal,
            page.inputs.tolerance(quiet=True),
            extend=gdt.report_extension() if gdt is not None else None,
        )
        return paths, page.task.record_report(comparison, paths)

    async def report_async(self) -> dict[str, Any] | None:
        """The plugin's report (HTML, PDF, JSON) in the page's job, added to the project;
        returns ``{"paths", "files", "links"}``, or None with the reason shown."""
        if not self._can("report"):
            return None
        self.state.ins_busy = "report"
        self.page.flush()
        folder = Path(tempfile.mkdtemp(prefix="camcmm-report-"))
        try:
            paths, files = await self.page.job.run(self._report_files, folder)
        except Exception as exc:
            self.page.error(f"report: {one_line(exc)}")
            return None
        finally:
            shutil.rmtree(folder, ignore_errors=True)
            self.state.ins_busy = ""
        out = self._reported(files)
        self.page.flush()
        return out

    def _reported(self, files: dict[str, str]) -> dict[str, Any]:
        links = self.links(files, "report")
        self.state.ins_report_links = links
        self.session.refresh_results()
        self.session.info(f"report written: {', '.join(l['name'] for l in links)} (in the project)")
        project = self.page.project
        paths = {k.removeprefix("report_"): str(project.file_path(h)) for k, h in files.items()}
        return {"files": files, "paths": paths, "links": links}

    # -- links -----------------------------------------------------------------------------
    def links(self, files: dict[str, str], what: str) -> list[dict[str, str]]:
        """Download links of project files ``{name: hash}``: the report's or the export's."""
        page = self.page
        out = []
        for name, h in files.items():
            kind = name.removeprefix("report_")
            try:
                src = page.project.file_path(h)
            except CamcmmError as exc:
                log.warning("%s file %s: %s", what, name, exc)
                continue
            if what == "report":
                link = page.offered.offer(
                    f"inspection-{page.result_id}.{kind}", src, kind=kind, title=REPORT_TITLES.get(kind)
                )
            else:
                link = page.offered.offer(self._export_name(h), src, kind=kind)
            if link:
                out.append(link)
        return sort_links(out)

    def _export_name(self, h: str) -> str:
        try:
            for f in self.page.project.files():
                if f["hash"] == h:
                    return str(f["original_name"])
        except Exception:
            pass
        return f"deviations-{self.page.result_id}.ply"
