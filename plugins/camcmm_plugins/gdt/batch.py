"""One plan over many parts: ``camcmm gdt batch PLAN CLOUD...`` and the GUI's Series view.

:func:`run_batch` evaluates the plan on each cloud in turn through the host as the
plugin ``gdt.evaluate`` (each part read, aligned and evaluated exactly as ``camcmm gdt
evaluate`` does it, :func:`evaluation_json` being that command's JSON) and writes one
JSON record per part into the batch's work ``folder``:

    <folder>/<stem>-<sha256[:12]>.json   {kind, schema, part, file, sha256, status, reason,
                                          key, provenance, started, finished, evaluation,
                                          project, result_id}
    <folder>/batch.json                  Batch.to_json() of the last run

The record's ``provenance`` holds the camcmm version, the plugin's id, version,
parameters and input hashes, and the run's start and end (UTC); ``sha256`` is the
cloud file's. A part **fails** — status ``failed`` with a one-line ``reason`` — when its
file does not read (or is missing), its alignment does not settle, or a feature or
characteristic is not evaluated (a feature without points); the evaluation is kept
where there is one, and the batch goes on. A failed part does not enter the capability
figures (:mod:`.capability`).

**Resume.** With ``resume`` (the default) a part whose record in ``folder`` has the same
file SHA-256 and the same run ``key`` (SHA-256 of the plan's content, the nominal's and
the plugin's parameters) is taken from its record, not evaluated again — whatever its
status (the same input fails the same way). A different plan or option re-evaluates,
overwriting the record. With a ``project``, a record with an evaluation is reused only when
it was recorded in that project.

Stable for the GUI (Q4's Series view): :func:`run_batch`, :class:`Batch` and
:meth:`Batch.to_json` (keys ``parts`` [{``part``, ``file``, ``status``, ``reason``,
``evaluation``, ``sha256``, ``resumed``, ``record``, ``result_id``, ``provenance``}],
``summary`` (:func:`.capability.summarise`), ``counts``, ``plan``, ``nominal``,
``folder``, ``params``, ``camcmm``, ``started``, ``finished``, ``warnings``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import threading
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import (
    API_VERSION,
    CamcmmError,
    Cancelled,
    InputError,
    RunResult,
    checked_path,
    declared_value,
    default_host,
    read,
    record_result,
    to_jsonable,
    utc_now,
)

from .capability import CONFIDENCE, summarise
from .model import Plan

#: The plugin each part runs through.
PLUGIN = "gdt.evaluate"
#: The id under which a batch's summary is recorded in a project.
BATCH_ID = "gdt.batch"
#: ``kind`` of a part's record, and the version of its layout.
RECORD_KIND = "camcmm gdt batch part"
RECORD_SCHEMA = 1
#: The batch's own document in its folder.
BATCH_FILE = "batch.json"
#: Parameters of ``gdt.evaluate`` a batch passes on, with the flags that name them.
PARAMS = ("align", "start", "k", "max_iterations", "seed")

Progress = Callable[[float, str], None]


def camcmm_version() -> str:
    """The installed camcmm's version (the distribution's), for provenance."""
    from importlib import metadata

    try:
        return metadata.version("camcmm")
    except metadata.PackageNotFoundError:  # a source tree run without installing
        return "unknown"


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes, hex (OSError when it cannot be read)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _json_sha256(doc: Any) -> str:
    text = json.dumps(to_jsonable(doc), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _object_sha256(obj: Any) -> str:
    """SHA-256 identifying a nominal given as an object: a CAD model's own content hash
    (its file's), else the bytes of its arrays (a mesh's vertices and faces, a cloud's
    points)."""
    if callable(getattr(obj, "content_hash", None)):
        return str(obj.content_hash())
    h = hashlib.sha256(type(obj).__name__.encode())
    for name in ("vertices", "faces", "points"):
        a = getattr(obj, name, None)
        if a is not None:
            arr = np.ascontiguousarray(a)
            h.update(f"{name}{arr.dtype.str}{arr.shape}".encode())
            h.update(arr.tobytes())
    return h.hexdigest()


def _line(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__


def evaluation_json(res: RunResult, *, plan: Any, cloud: Any, nominal: Any = None) -> dict[str, Any]:
    """The JSON of ``camcmm gdt evaluate`` (docs/gdt.md) for a run ``res`` of
    ``gdt.evaluate``; ``plan``, ``cloud``, ``nominal`` name the inputs (paths)."""
    o = res.outputs
    a = o["alignment"]
    chars = o["characteristics"]
    out: dict[str, Any] = {
        "plan": str(plan),
        "cloud": str(cloud),
        "nominal": str(nominal) if nominal else None,
        "n_points": o["aligned"].n_points,
        "unit": "mm",
        "features": o["features"],
        "datums": o["datums"],
        "alignment": a,
        "characteristics": chars,
        "labels": o["labels"],
        "summary": dict(Counter(c["verdict_guarded"] for c in chars)),
        "warnings": list(res.warnings),
        "plugin": res.provenance(),
        "aligned": bool(a.get("converged", True)),
    }
    if not out["aligned"]:
        out["failure"] = f"alignment {a['method']} did not settle in {a.get('iterations')} iterations"
    return out


def failure(evaluation: dict[str, Any]) -> str | None:
    """Why an evaluated part counts as failed (one line), or None: its alignment did not
    settle, or a feature or characteristic was not evaluated (the first named, with how
    many more)."""
    if evaluation.get("aligned") is False:
        return str(evaluation.get("failure") or "the alignment did not settle")
    missing = [
        f"feature {f['id']} not evaluated: {f.get('reason', '')}".rstrip(": ")
        for f in evaluation.get("features", [])
        if f.get("status") != "evaluated"
    ]
    missing += [
        f"{c['id']} not evaluated: {(c.get('details') or {}).get('reason', '')}".rstrip(": ")
        for c in evaluation.get("characteristics", [])
        if c.get("value") is None and not missing  # a value without limits ("value only") is evaluated
    ]
    if not missing:
        return None
    more = f" (+{len(missing) - 1} more)" if len(missing) > 1 else ""
    return missing[0] + more


@dataclass
class Batch:
    """A batch run: the plan's name, the work ``folder``, the ``parts`` in the order
    given (each the public part dict of :meth:`to_json`), the plugin ``params``, times,
    ``warnings``, the project and the batch's result id there."""

    plan: str
    folder: Path
    parts: list[dict[str, Any]]
    params: dict[str, Any]
    nominal: str | None = None
    started: str = ""
    finished: str = ""
    warnings: list[str] = field(default_factory=list)
    project: str | None = None
    result_id: int | None = None

    def counts(self) -> dict[str, int]:
        c = Counter(p["status"] for p in self.parts)
        return {
            "parts": len(self.parts),
            "evaluated": c.get("evaluated", 0),
            "failed": c.get("failed", 0),
            "resumed": sum(1 for p in self.parts if p.get("resumed")),
        }

    def to_json(self, *, confidence: float = CONFIDENCE, subgroup: int | None = None) -> dict[str, Any]:
        """The batch's document (module docstring); ``summary`` per characteristic from
        :func:`.capability.summarise` with ``confidence`` and ``subgroup``."""
        doc: dict[str, Any] = {
            "plan": self.plan,
            "nominal": self.nominal,
            "folder": str(self.folder),
            "params": self.params,
            "camcmm": camcmm_version(),
            "api": API_VERSION,
            "started": self.started,
            "finished": self.finished,
            "counts": self.counts(),
            "parts": self.parts,
            "warnings": list(self.warnings),
        }
        if self.project is not None:
            doc["project"] = self.project
            doc["result_id"] = self.result_id
        doc["summary"] = summarise(doc, confidence=confidence, subgroup=subgroup)
        return doc


def _plan_of(plan: Any) -> tuple[Plan, str, str]:
    """(the plan, its name for messages and documents, the SHA-256 of its content)."""
    from .alignment import options
    from .plugin import load_plan

    if isinstance(plan, (str, Path)) and not Path(plan).is_file():
        raise InputError(f"{plan}: no such file (plan)")
    p = load_plan(plan)  # a bad plan is refused here, before any part
    options(p)
    if isinstance(plan, (str, Path)):
        return p, str(plan), file_sha256(plan)
    name = p.source or "plan"
    return p, name, _json_sha256(plan if isinstance(plan, dict) else dataclasses.asdict(p))


def _names(files: Sequence[Path]) -> list[str]:
    """A part's name: its file's stem; a stem met again gets the path as given."""
    stems = Counter(f.stem for f in files)
    return [f.stem if stems[f.stem] == 1 else str(f) for f in files]


def _write_json(path: Path, doc: Any) -> None:
    """Written whole or not at all (a killed run leaves the previous record)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(to_jsonable(doc), indent=1), "utf-8")
    os.replace(tmp, path)


def _valid_record(rec: dict[str, Any]) -> bool:
    """A record one can resume from: its hashes, a status, an evaluation or none."""
    ev = rec.get("evaluation")
    return (
        all(isinstance(rec.get(k), str) and rec[k] for k in ("sha256", "key", "part", "file"))
        and rec.get("status") in ("evaluated", "failed")
        and (ev is None or (isinstance(ev, dict) and isinstance(ev.get("characteristics"), list)))
        and all(isinstance(c, dict) and isinstance(c.get("id"), str) for c in (ev or {}).get("characteristics", []))
    )


def _records(folder: Path, warnings: list[str]) -> dict[tuple[str, str], dict[str, Any]]:
    """The part records in ``folder`` by (file SHA-256, run key)."""
    out: dict[tuple[str, str], dict[str, Any]] = {}
    for f in sorted(folder.glob("*.json")):
        if f.name == BATCH_FILE:
            continue
        try:
            rec = json.loads(f.read_text("utf-8"))
        except (OSError, ValueError) as exc:
            warnings.append(f"{f}: not a part record ({_line(exc)}): ignored")
            continue
        if not (isinstance(rec, dict) and rec.get("kind") == RECORD_KIND):
            continue  # another file in the folder: not ours
        if not _valid_record(rec):
            warnings.append(f"{f}: a part record without its keys (sha256, key, status, evaluation): ignored")
            continue
        out[(rec["sha256"], rec["key"])] = {**rec, "_path": str(f)}
    return out


def _public(rec: dict[str, Any], path: Path | None, resumed: bool) -> dict[str, Any]:
    """A part as Batch.to_json gives it."""
    return {
        "part": rec["part"],
        "file": rec["file"],
        "status": rec["status"],
        "reason": rec.get("reason"),
        "evaluation": rec.get("evaluation"),
        "sha256": rec.get("sha256"),
        "resumed": resumed,
        "record": None if path is None else str(path),
        "result_id": rec.get("result_id"),
        "provenance": rec.get("provenance"),
    }


def run_batch(
    plan: Any,
    clouds: Sequence[str | Path],
    *,
    align: str = "best-fit",
    nominal: Any = None,
    folder: str | Path,
    resume: bool = True,
    start: str = "auto",
    k: float | None = None,
    max_iterations: int = 50,
    seed: int = 0,
    project: str | Path | None = None,
    progress: Progress | None = None,
    cancel: threading.Event | None = None,
    names: Sequence[str] | None = None,
) -> Batch:
    """Evaluate ``plan`` (a YAML/JSON file, a plan document or a Plan) on every cloud of
    ``clouds`` (paths, in production order) and return the :class:`Batch` (module
    docstring). ``align``, ``start``, ``k``, ``max_iterations``, ``seed``: as ``camcmm gdt
    evaluate`` (checked first, one line naming the option); ``nominal``: a CAD/mesh/cloud
    file or object in plan coordinates, read once; ``folder``: the work folder of the
    records (created); ``resume``: reuse records of the same file and run; ``project``:
    record each evaluated part's run there (``camcmm.api.record_result``) and the batch
    summary as a result ``gdt.batch``; ``progress(fraction, message)``, ``cancel``: for a
    GUI (a cancel raises ``Cancelled`` between or inside parts; the records written so
    far stay, so a new run resumes); ``names``: the parts' names, one a cloud, unique
    (default the file's stem, the path as given for a stem met twice). Raises
    InputError/ParameterError for a bad plan, option, name or nominal and for no clouds,
    before any part; a part's own failure is recorded instead."""
    given = {"align": align, "start": start, "k": k, "max_iterations": max_iterations, "seed": seed}
    params = {n: declared_value(PLUGIN, n, v) for n, v in given.items() if v is not None}
    if not clouds:
        raise InputError("gdt batch: no cloud given")
    # every path checked first (in a confined run, refused when outside the folders)
    if isinstance(plan, (str, Path)):
        plan = checked_path(plan, "plan")
    files = [checked_path(c, "cloud") for c in clouds]
    if names is None:
        names = _names(files)
    else:
        names = [str(x) for x in names]
        if len(names) != len(files):
            raise InputError(f"names: {len(names)} names for {len(files)} clouds")
        if len(set(names)) != len(names):
            raise InputError("names: two parts have the same name")
    out = checked_path(folder, "batch folder")
    if isinstance(nominal, (str, Path)):
        nominal = checked_path(nominal, "nominal")
    if project is not None:
        project = checked_path(project, "project")
        if Path(out).resolve().is_relative_to(Path(project).resolve()):  # the store owns its folder
            raise InputError(f"{folder}: the batch folder must lie outside the project folder {project}")
    p, plan_name, plan_sha = _plan_of(plan)
    if params.get("align") == "rps":
        from .alignment import rps_points

        rps_points(p)
    nominal_name, nominal_sha, nominal_obj = None, None, nominal
    if isinstance(nominal, (str, Path)):
        nominal_name = str(nominal)
        if not Path(nominal).is_file():
            raise InputError(f"{nominal}: no such file (nominal)")
        nominal_obj = read(nominal)  # once for every part; InputError names the file
        nominal_sha = file_sha256(nominal)
    elif nominal is not None:
        nominal_sha = _object_sha256(nominal)
    key = _json_sha256({"plan": plan_sha, "nominal": nominal_sha, "params": params})
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{folder}: cannot be made a batch folder ({exc.strerror or _line(exc)})") from None
    warnings: list[str] = []
    done = _records(out, warnings) if resume else {}
    n = len(files)
    runner = _Runner(default_host(), p, plan_name, nominal_obj, nominal_name, params, project, progress, cancel, n)
    batch = Batch(plan_name, out, [], to_jsonable(params), nominal_name, utc_now())
    batch.project = None if project is None else str(project)
    project_key = None if project is None else str(Path(project).resolve())  # where a record was recorded
    seen: dict[str, str] = {}
    for i, (f, name) in enumerate(zip(files, names, strict=True)):
        if cancel is not None and cancel.is_set():
            raise Cancelled("gdt batch cancelled")
        if progress is not None:
            progress(i / n, f"part {i + 1}/{n}: {name}")
        rec: dict[str, Any] = {
            "kind": RECORD_KIND,
            "schema": RECORD_SCHEMA,
            "part": name,
            "file": str(f),
            "sha256": None,
            "key": key,
            "started": utc_now(),
        }
        try:
            rec["sha256"] = file_sha256(f)
        except OSError as exc:
            rec.update(status="failed", reason=f"{f}: cannot be read ({exc.strerror or _line(exc)})")
        sha = rec["sha256"]
        if sha is not None and sha in seen:
            rec.update(status="failed", reason=f"{f}: the same file as part {seen[sha]} (SHA-256 {sha[:12]}…)")
            batch.parts.append(_public(rec, None, False))
            warnings.append(f"part {name}: {rec['reason']}")
            continue
        if sha is not None:
            seen[sha] = name
        old = done.get((sha, key)) if sha is not None else None
        recorded = old is not None and (old.get("evaluation") is None or old.get("project") == project_key)
        if old is not None and (project is None or recorded):
            old = {**old, "part": name, "file": str(f)}
            batch.parts.append(_public(old, Path(old["_path"]), True))
            if old["status"] == "failed":
                warnings.append(f"part {name} failed (recorded earlier): {old.get('reason')}")
            continue
        if "status" not in rec:
            runner.evaluate(rec, f, i)
            if project_key is not None and rec.get("result_id") is not None:
                rec["project"] = project_key
        rec["finished"] = utc_now()
        path = out / f"{f.stem}-{(sha or 'unread')[:12]}.json"
        _write_json(path, rec)
        if rec["status"] == "failed":
            warnings.append(f"part {name} failed: {rec['reason']}")
        batch.parts.append(_public(rec, path, False))
    batch.finished = utc_now()
    batch.warnings = warnings
    if project is not None:
        batch.result_id = _record_batch(project, batch, params, nominal_sha, plan_sha)
    _write_json(out / BATCH_FILE, batch.to_json())
    if progress is not None:
        progress(1.0, "done")
    return batch


@dataclass
class _Runner:
    """What every part of one batch run shares (the plan parsed once, the nominal read
    once, the checked parameters, where to report)."""

    host: Any
    plan: Plan
    plan_name: str
    nominal: Any
    nominal_name: str | None
    params: dict[str, Any]
    project: str | Path | None
    progress: Progress | None
    cancel: threading.Event | None
    n: int

    def evaluate(self, rec: dict[str, Any], f: Path, i: int) -> None:
        """Part ``i`` (file ``f``) through ``gdt.evaluate``: ``rec`` completed with
        status, reason, evaluation, provenance (and result_id with a project)."""
        progress, n = self.progress, self.n
        sub = None if progress is None else (lambda fr, msg: progress((i + fr) / n, f"part {i + 1}/{n}: {msg}"))
        inputs: dict[str, Any] = {"cloud": f, "plan": self.plan}
        if self.nominal is not None:
            inputs["nominal"] = self.nominal
        try:
            res = self.host.run(PLUGIN, inputs, self.params, progress=sub, cancel=self.cancel)
        except Cancelled:
            raise
        except CamcmmError as exc:  # the file is not a cloud, the alignment refused, ...: this part only
            rec.update(status="failed", reason=_line(exc), evaluation=None, provenance={"camcmm": camcmm_version()})
            return
        ev = evaluation_json(res, plan=self.plan_name, cloud=f, nominal=self.nominal_name)
        why = failure(ev)
        rec.update(
            status="evaluated" if why is None else "failed",
            reason=why,
            evaluation=ev,
            provenance={"camcmm": camcmm_version(), **res.provenance()},
        )
        if self.project is not None:
            rec["result_id"] = record_result(self.project, res)


def _record_batch(
    project: str | Path, batch: Batch, params: dict[str, Any], nominal_sha: str | None, plan_sha: str
) -> int:
    """The batch's summary as a result ``gdt.batch`` in the project: inputs the parts'
    file hashes, the plan's and the nominal's; outputs the parts (without their
    evaluations, which are results of their own) and the summary."""
    doc = batch.to_json()
    hashes = {"plan": plan_sha, **({"nominal": nominal_sha} if nominal_sha else {})}
    hashes.update({f"part {p['part']}": p["sha256"] for p in batch.parts if p.get("sha256")})
    parts = [{k: v for k, v in p.items() if k not in ("evaluation", "provenance")} for p in batch.parts]
    run = RunResult(
        BATCH_ID,
        camcmm_version(),
        {**params, "folder": str(batch.folder)},
        hashes,
        {"parts": parts, "counts": doc["counts"], "summary": doc["summary"]},
        batch.started,
        batch.finished,
        list(batch.warnings),
    )
    return record_result(project, run)
