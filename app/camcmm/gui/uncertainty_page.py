"""The "Uncertainty" page's logic: a GUM budget editor and a Monte Carlo study of a
stereo system, published through the trame state (``unc_*`` keys).

Both call the uncertainty plugins through the host by id (``uncertainty.budget``,
``uncertainty.montecarlo``), as the CLI does, so the page shows the CLI's numbers.
The budget is evaluated as the operator types (it is cheap); a draft is kept in the
project's state so an edited table survives a restart. A Monte Carlo run goes to a
worker thread with progress and cancel; its result is stored in the project (the
summary in the result row, every array in a JSON file) and shown again on reopen.

Threading as in the other pages: state, store and VTK on the server loop; the plugin
run and the file writing in the page's one worker.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from .. import worker
from ..errors import CamcmmError, InputError
from ..host import to_jsonable
from ..yamlfile import load_yaml, read_yaml
from . import uncertainty_figures as figs
from .downloads import Downloads, table_csv
from .uncertainty_view import UncertaintyView, map_options

log = logging.getLogger("camcmm.gui.uncertainty")

BUDGET, MONTECARLO = "uncertainty.budget", "uncertainty.montecarlo"
DRAFT_KEY, MC_KEY = "uncertainty.budget.draft", "uncertainty.montecarlo.current"
DISTRIBUTIONS = ["normal", "rectangular", "triangular", "u-shaped", "student-t"]
STUDIES = ["convergence", "sweep", "volume_maps", "spatial"]


def _one_line(exc: BaseException | str) -> str:
    msg = str(exc) if isinstance(exc, (CamcmmError, str)) else f"{type(exc).__name__}: {exc}"
    return " ".join(msg.split()) or "unknown error"


def _resource(name: str) -> Path:
    from .wizard import resources_dir

    return resources_dir() / "uncertainty" / name


def _fmt(x: Any, digits: int = 4) -> str:
    if x is None:
        return "∞"
    x = float(x)
    return "∞" if math.isinf(x) else f"{x:.{digits}g}"


def budget_rows_from_doc(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """Editor rows (strings, as typed) from a budget document."""
    rows = []
    for c in doc.get("contributions") or []:
        dof = c.get("dof", "inf")
        rows.append({"name": str(c.get("name", "")), "u": str(c.get("u", "")), "c": str(c.get("c", 1)),
                     "dof": "inf" if dof is None or (isinstance(dof, float) and math.isinf(dof)) else str(dof),
                     "distribution": str(c.get("distribution", "normal"))})
    return rows


def budget_doc(quantity: str, unit: str, p: Any, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The budget file's form (the contract of ``camcmm uncertainty budget``) from the editor."""
    contributions = []
    for r in rows:
        c = {"name": str(r.get("name") or "").strip(), "u": r.get("u"), "dof": r.get("dof") or "inf",
             "distribution": r.get("distribution") or "normal"}
        if str(r.get("c", "")).strip() not in ("", "1"):
            c["c"] = r.get("c")
        contributions.append(c)
    return {"quantity": quantity, "unit": unit, "coverage_probability": p, "contributions": contributions}


class UncertaintyPage:
    def __init__(self, session: Any, downloads: str | Path | None = None):
        self.session = session
        self.state = session.state
        self.project = session.project
        self.host = session.host
        self.offered = Downloads("camcmm-uncertainty-downloads", "camcmm-uncertainty-", downloads)
        self.view = UncertaintyView()
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="camcmm-uncertainty")
        self._cancel: threading.Event | None = None
        self._last_progress = 0.0
        self.budget: dict[str, Any] | None = None
        self.mc: dict[str, Any] | None = None
        self.mc_result_id: int | None = None
        self._init_state()
        self.restore()

    # -- state ---------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.unc_tab = "budget"
        s.unc_error = ""
        s.unc_b_error = ""
        s.unc_b_distributions = DISTRIBUTIONS
        s.unc_b_result = None
        s.unc_b_fig = figs.empty("the budget's contributions appear here")
        s.unc_b_links = []
        s.unc_mc_spec = ""
        s.unc_mc_iterations = 2000
        s.unc_mc_seed = 1
        s.unc_mc_method = "linear"
        s.unc_mc_studies = ["convergence", "volume_maps"]
        s.unc_mc_study_options = STUDIES
        s.unc_mc_scheduler = ""
        s.unc_mc_running = False
        s.unc_mc_progress = 0.0
        s.unc_mc_message = ""
        s.unc_mc_rows = []
        s.unc_mc_summary = None
        s.unc_mc_axis = "x"
        s.unc_mc_fig_contrib = figs.contributions_figure({})
        s.unc_mc_fig_conv = figs.convergence_figure({}, "um")
        s.unc_mc_fig_sweep = figs.sweep_figure({}, "um")
        s.unc_mc_fig_spatial = figs.spatial_figure({}, "um")
        s.unc_mc_maps = []
        s.unc_mc_map = None
        s.unc_mc_map_note = ""
        s.unc_mc_links = []

    def flush(self) -> None:
        self.session.flush()

    def _error(self, msg: Any) -> None:
        line = _one_line(msg) if not isinstance(msg, str) else " ".join(msg.split())
        self.state.unc_error = line
        self.session.error(line)

    # -- the budget --------------------------------------------------------------------------
    def set_budget(self, quantity: str, unit: str, p: Any, rows: list[dict[str, Any]], save_draft: bool = True) -> dict | None:
        """Evaluate the editor's budget; the result (or the one-line reason) is shown at once."""
        s = self.state
        s.unc_b_quantity, s.unc_b_unit, s.unc_b_p, s.unc_b_rows = quantity, unit, p, [dict(r) for r in rows]
        doc = budget_doc(quantity, unit, p, rows)
        if save_draft:
            try:
                self.project.set_state(DRAFT_KEY, doc)
            except Exception as exc:  # the editor keeps working; the reason is shown
                s.unc_b_error = f"the draft could not be kept in the project: {_one_line(exc)}"
        try:
            res = self.host.run(BUDGET, inputs={"spec": doc}).outputs
        except Exception as exc:
            self.budget = None
            s.unc_b_result, s.unc_b_error = None, _one_line(exc)
            s.unc_b_fig = figs.empty("fix the table to see the contributions")
            return None
        self.budget = res
        s.unc_b_error = ""
        s.unc_b_result = {
            "combined": _fmt(res["combined"]), "dof_eff": _fmt(res["dof_eff"], 3), "k": _fmt(res["k"], 3),
            "expanded": _fmt(res["expanded"]), "p": f"{100 * float(res['coverage_probability']):g} %",
            "unit": figs.shown_unit(res.get("unit")),
            "shares": [{"name": c["name"], "contribution": _fmt(c["contribution"]),
                        "share": f"{100 * float(c['share']):.1f} %"} for c in res["contributions"]],
        }
        s.unc_b_fig = figs.budget_figure(res)
        return res

    def add_row(self) -> None:
        rows = list(self.state.unc_b_rows or []) + [{"name": "", "u": "", "c": "1", "dof": "inf",
                                                     "distribution": "normal"}]
        self.state.unc_b_rows = rows
        self.state.unc_b_error = "a new row: give its name and u"

    def remove_row(self, i: int) -> None:
        rows = [r for j, r in enumerate(self.state.unc_b_rows or []) if j != int(i)]
        s = self.state
        self.set_budget(s.unc_b_quantity, s.unc_b_unit, s.unc_b_p, rows)

    def load_budget(self, text: str | bytes, name: str = "budget.yaml") -> bool:
        """Replace the editor's budget by a YAML/JSON budget file's."""
        try:
            doc = load_yaml(text, name=name)
        except InputError as exc:
            self._error(str(exc))
            return False
        if not isinstance(doc, dict) or not isinstance(doc.get("contributions"), list):
            self._error(f"{name}: expected a mapping with a 'contributions' list")
            return False
        self.set_budget(str(doc.get("quantity", "")), str(doc.get("unit", "")),
                        doc.get("coverage_probability", 0.95), budget_rows_from_doc(doc))
        return True

    def save_budget(self) -> dict[str, Any] | None:
        """Store the evaluated budget as a result and offer YAML, CSV, JSON and PNG."""
        import yaml

        if self.budget is None:
            self._error("the budget has errors: fix the table first")
            return None
        s = self.state
        doc = budget_doc(s.unc_b_quantity, s.unc_b_unit, s.unc_b_p, s.unc_b_rows)
        try:
            run = self.host.run(BUDGET, inputs={"spec": doc})
            rid = self.project.add_result(run, label=f"GUM budget: {doc['quantity']}")
        except Exception as exc:
            self._error(f"budget: {_one_line(exc)}")
            return None
        res = run.outputs
        rows = [[c["name"], c["u"], c["c"], c["dof"], c["distribution"], c["contribution"], c["share"]]
                for c in res["contributions"]]
        rows.append(["combined", None, None, res["dof_eff"], None, res["combined"], 1.0])
        rows.append([f"expanded (k = {res['k']:.3g}, p = {res['coverage_probability']:g})", None, None, None, None,
                     res["expanded"], None])
        name = f"budget-{rid}"
        links = [
            self.offered.offer(f"{name}.yaml", data=yaml.safe_dump(doc, sort_keys=False, allow_unicode=True).encode()),
            self.offered.offer(f"{name}.csv", data=table_csv(
                ["name", f"u ({res.get('unit', '')})", "c", "dof", "distribution", "|c·u|", "share"], rows)),
            self.offered.offer(f"{name}.json", data=json.dumps(to_jsonable(res), indent=1, default=str).encode()),
            self.offered.offer(f"{name}.png", data=figs.figure_png(figs.budget_figure(res))),
        ]
        s.unc_b_links = [l for l in links if l]
        self.session.refresh_results()
        self.session.info(f"budget stored as result #{rid}")
        return {"result_id": rid, "links": s.unc_b_links}

    # -- the Monte Carlo study -------------------------------------------------------------
    def _mc_inputs(self, spec_text: str, params: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
        doc = load_yaml(spec_text or "", name="system description")
        if not isinstance(doc, dict):
            raise InputError("system description: expected a mapping (cameras, stereo, grid, uncertainties)")
        values: dict[str, Any] = {}
        for key in ("iterations", "seed"):
            v = params.get(key)
            if v not in (None, ""):
                try:
                    values[key] = int(float(v))
                except (TypeError, ValueError):
                    raise InputError(f"{key}: {v!r} is not a whole number") from None
        if params.get("method"):
            values["method"] = str(params["method"])
        if str(params.get("scheduler") or "").strip():
            values["scheduler"] = str(params["scheduler"]).strip()
        values["studies"] = ",".join(str(x) for x in (params.get("studies") or []))
        return doc, values

    def _begin(self) -> threading.Event:
        s = self.state
        self._cancel = threading.Event()
        self._last_progress = 0.0
        s.unc_mc_running, s.unc_mc_progress, s.unc_mc_message, s.unc_error = True, 0.0, "starting …", ""
        return self._cancel

    def _progress_cb(self, fraction: float, message: str) -> None:
        now = time.monotonic()
        if fraction < 1.0 and now - self._last_progress < 0.2:
            return
        self._last_progress = now

        def show() -> None:
            self.state.unc_mc_progress = round(100.0 * float(fraction), 1)
            self.state.unc_mc_message = message or "Monte Carlo"
        self.session.post(show)

    def cancel(self) -> None:
        if self._cancel is not None:
            self._cancel.set()
            self.state.unc_mc_message = "cancelling …"

    def _compute(self, doc: dict[str, Any], values: dict[str, Any], cancel: threading.Event) -> Any:
        return worker.run(self.host, MONTECARLO, {"spec": doc}, values, progress=self._progress_cb, cancel=cancel)

    def _store(self, run: Any, doc: dict[str, Any]) -> tuple[int, str]:
        """Worker: the summary as the result row, everything (arrays too) as a JSON file."""
        full = to_jsonable({"system": doc, **run.outputs})
        folder = Path(tempfile.mkdtemp(prefix="camcmm-mc-"))
        try:
            path = folder / "montecarlo.json"
            path.write_text(json.dumps(full), encoding="utf-8")
            h = self.project.add_file(path)
        finally:
            for p in folder.iterdir():
                p.unlink()
            folder.rmdir()
        summary = {k: v for k, v in run.to_json().items()}
        summary["outputs"] = {k: v for k, v in full.items() if k not in ("per_point", "studies", "system")}
        rid = self.project.add_result(summary, files={"montecarlo": h}, label="Monte Carlo of a stereo system")
        self.project.set_state(MC_KEY, {"result": rid, "file": h})
        return rid, h

    def run_montecarlo(self, spec_text: str, params: dict[str, Any]) -> dict[str, Any] | None:
        """The study in the calling thread (tests, scripts)."""
        try:
            doc, values = self._mc_inputs(spec_text, params)
        except Exception as exc:
            self._error(exc)
            return None
        cancel = self._begin()
        try:
            run = self._compute(doc, values, cancel)
            rid, h = self._store(run, doc)
        except Exception as exc:
            return self._failed(exc)
        return self._finished(json.loads(self.project.file_path(h).read_text("utf-8")), rid)

    async def run_montecarlo_async(self, spec_text: str, params: dict[str, Any]) -> dict[str, Any] | None:
        if self.state.unc_mc_running:
            self._error("a Monte Carlo run is going on; wait for it or cancel it")
            return None
        if self.session._loop is None:
            self.session.bind_loop()
        try:
            doc, values = self._mc_inputs(spec_text, params)
        except Exception as exc:
            self._error(exc)
            return None
        cancel = self._begin()
        self.flush()
        loop = asyncio.get_running_loop()
        try:
            run = await loop.run_in_executor(self._executor, self._compute, doc, values, cancel)
            self.state.unc_mc_message = "storing the result in the project …"
            self.flush()
            rid, h = await loop.run_in_executor(self._executor, self._store, run, doc)
            full = await loop.run_in_executor(self._executor, self._read_json, h)
        except Exception as exc:
            out = self._failed(exc)
            self.flush()
            return out
        out = self._finished(full, rid)
        self.flush()
        return out

    def _read_json(self, h: str) -> dict[str, Any]:
        return json.loads(self.project.file_path(h).read_text("utf-8"))

    def _failed(self, exc: BaseException) -> None:
        s = self.state
        s.unc_mc_running = False
        s.unc_mc_message = "cancelled" if "cancelled" in str(exc) else "failed"
        self._error(exc)
        return None

    def _finished(self, full: dict[str, Any], rid: int | None) -> dict[str, Any]:
        s = self.state
        s.unc_mc_running = False
        s.unc_mc_progress = 100.0
        elapsed = full.get("elapsed_s")
        s.unc_mc_message = (f"done: {full.get('iterations')} iterations × {full.get('n_points')} points"
                            + (f" in {elapsed:.1f} s" if isinstance(elapsed, (int, float)) else "")
                            + (f" ({full.get('executor')})" if full.get("executor") else ""))
        self.show_montecarlo(full, rid)
        self.session.refresh_results()
        return full

    def show_montecarlo(self, full: dict[str, Any], rid: int | None = None) -> None:
        """Publish a Monte Carlo result (fresh, or read back from the project)."""
        s = self.state
        self.mc, self.mc_result_id = full, rid
        unit = full.get("unit", "um")
        shown = figs.shown_unit(unit)
        rows = []
        for f, u in (full.get("contributions") or {}).items():
            rows.append({"factor": figs.factor_title(f), "x": _fmt(u[0], 3), "y": _fmt(u[1], 3), "z": _fmt(u[2], 3),
                         "dof": _fmt((full.get("factor_dof") or {}).get(f), 4),
                         "distribution": (full.get("factor_distribution") or {}).get(f, "")})
        for key, title in (("combined", "combined u"), ("dof_eff", "effective dof"), ("k", "k"),
                           ("expanded", f"U ({100 * float(full.get('coverage_probability', 0.95)):g} %)")):
            v = full.get(key) or [None] * 3
            rows.append({"factor": title, "x": _fmt(v[0], 3), "y": _fmt(v[1], 3), "z": _fmt(v[2], 3),
                         "dof": "", "distribution": "", "total": True})
        s.unc_mc_rows = rows
        s.unc_mc_summary = {"unit": shown, "iterations": full.get("iterations"), "result_id": rid,
                            "method": full.get("method"), "n_points": full.get("n_points")}
        self._draw_figures()
        s.unc_mc_maps = map_options(full)
        s.unc_mc_map = s.unc_mc_maps[0]["value"] if s.unc_mc_maps else None
        self.show_map(s.unc_mc_map)
        s.unc_mc_links = self._mc_links()

    def _draw_figures(self) -> None:
        s, full = self.state, self.mc or {}
        studies = full.get("studies") or {}
        unit = full.get("unit", "um")
        s.unc_mc_fig_contrib = figs.contributions_figure(full)
        s.unc_mc_fig_conv = figs.convergence_figure(studies.get("convergence") or {}, unit, s.unc_mc_axis or "x")
        s.unc_mc_fig_sweep = figs.sweep_figure(studies.get("sweep") or {}, unit)
        s.unc_mc_fig_spatial = figs.spatial_figure(studies.get("spatial") or {}, unit)

    def set_axis(self, axis: str) -> None:
        self.state.unc_mc_axis = axis if axis in figs.AXES else "x"
        self._draw_figures()

    def show_map(self, choice: str | None) -> None:
        s = self.state
        s.unc_mc_map = choice
        if not choice or self.mc is None:
            self.view.clear()
            s.unc_mc_map_note = "tick 'volume_maps' under Studies and run to see the measuring volume" if self.mc else ""
            return
        try:
            s.unc_mc_map_note = self.view.show(self.mc, choice, self.mc.get("unit", "um"))
        except Exception as exc:
            s.unc_mc_map_note = f"cannot show {choice}: {_one_line(exc)}"

    def _mc_links(self) -> list[dict[str, str]]:
        full, rid = self.mc or {}, self.mc_result_id
        name = f"montecarlo-{rid if rid is not None else 'unsaved'}"
        header = ["factor", "u_x", "u_y", "u_z", "dof", "distribution"]
        rows = [[r["factor"], r["x"], r["y"], r["z"], r["dof"], r["distribution"]] for r in self.state.unc_mc_rows]
        unit = full.get("unit", "um")
        studies = full.get("studies") or {}
        links = [self.offered.offer(f"{name}.csv", data=table_csv([header[0]] + [f"{h} ({unit})" for h in header[1:4]]
                                                                       + header[4:], rows), replace=True),
                 self.offered.offer(f"{name}.json", data=json.dumps(full).encode(), replace=True),
                 self.offered.offer(f"{name}-contributions.png", data=figs.figure_png(figs.contributions_figure(full)),
                                    replace=True)]
        if studies.get("convergence"):
            links.append(self.offered.offer(f"{name}-convergence.png", replace=True, data=figs.figure_png(
                figs.convergence_figure(studies["convergence"], unit, self.state.unc_mc_axis or "x"))))
        if studies.get("sweep"):
            links.append(self.offered.offer(f"{name}-sweep.png", replace=True,
                                            data=figs.figure_png(figs.sweep_figure(studies["sweep"], unit))))
        if studies.get("spatial"):
            links.append(self.offered.offer(f"{name}-spatial.png", replace=True,
                                            data=figs.figure_png(figs.spatial_figure(studies["spatial"], unit))))
        return [l for l in links if l]

    # -- restore -----------------------------------------------------------------------------
    def restore(self) -> None:
        """The draft budget (or the shipped example) and the last stored Monte Carlo run."""
        import yaml

        s = self.state
        try:
            draft = self.project.get_state(DRAFT_KEY)
        except Exception:
            draft = None
        if not isinstance(draft, dict):
            try:
                draft = read_yaml(_resource("budget.yaml"))
            except InputError:
                draft = {"quantity": "", "unit": "um", "coverage_probability": 0.95, "contributions": []}
        self.set_budget(str(draft.get("quantity", "")), str(draft.get("unit", "")),
                        draft.get("coverage_probability", 0.95), budget_rows_from_doc(draft), save_draft=False)
        try:
            s.unc_mc_spec = _resource("stereo_system.yaml").read_text("utf-8")
        except OSError:
            s.unc_mc_spec = ""
        try:
            cur = self.project.get_state(MC_KEY)
            if isinstance(cur, dict) and self.project.has_file(str(cur.get("file"))):
                full = self._read_json(str(cur["file"]))
                if isinstance(full.get("system"), dict):
                    s.unc_mc_spec = yaml.safe_dump(full["system"], sort_keys=False)
                s.unc_mc_message = f"result #{cur.get('result')} from the project"
                self.show_montecarlo(full, cur.get("result"))
        except Exception as exc:  # a damaged file must not keep the page from opening
            log.warning("cannot restore the Monte Carlo result: %s", exc)
            s.unc_mc_message = f"the stored Monte Carlo result could not be read: {_one_line(exc)}"

    def close(self) -> None:
        if self._cancel is not None:
            self._cancel.set()
        self._executor.shutdown(wait=False, cancel_futures=True)
        self.offered.close()
        self.view.close()


def mount(server: Any, session: Any) -> UncertaintyPage:
    """Create the page for a session and serve its downloads (before the server starts)."""
    page = UncertaintyPage(session)
    page.offered.mount(server)
    return page
