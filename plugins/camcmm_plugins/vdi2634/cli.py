"""``camcmm verify PLAN.yaml [--json] [--report DIR] [--workers N]``.

The plan names its standard (``standard: vdi2634-2``); the command runs that standard
plugin through the host and, with ``--report``, writes the HTML/PDF/JSON report. The core
adds ``--json``. The run's record is in ``run`` (``plugin``, ``version``, ``params``,
``input_hashes``, ``started``, ``finished``, ``warnings``: RunResult.to_json without the
outputs) and, as in every command's JSON, ``plugin`` (RunResult.provenance). The options
are the parameters the standard plugins declare (``--workers``), with their help, limits
and default; a value the plan's standard does not declare is refused in one line.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path
from typing import Any

from camcmm.api import (
    InputError,
    Param,
    PluginError,
    add_declared_options,
    declared_values,
    default_host,
    read_yaml,
)


def parameters() -> list[Param]:
    """Every parameter a standard plugin declares, once (the plan names the standard only
    when the command runs; each standard takes only its own)."""
    seen: dict[str, Param] = {}
    for spec in sorted(default_host().plugins.values(), key=lambda s: s.id):
        if spec.kind == "standard":
            for p in spec.parameters:
                seen.setdefault(p.name, p)
    return list(seen.values())


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("plan", help="test plan (YAML); measurement paths are relative to it")
    parser.add_argument("--report", metavar="DIR", help="write the report (HTML, PDF, JSON) into this folder")
    # --workers ...: the standards' declared parameters, with their help, limits and default
    add_declared_options(parser, parameters())


def _standard_of(path: Path) -> str:
    if not path.is_file():
        raise InputError(f"{path}: plan file not found")
    doc = read_yaml(path, name=path.name)
    std = doc.get("standard") if isinstance(doc, dict) else None
    if not isinstance(std, str) or not std:
        raise InputError(f"{path.name}: standard is missing; say which standard the plan is for (e.g. vdi2634-2)")
    return std


def run(args: argparse.Namespace) -> dict[str, Any]:
    path = Path(args.plan)
    std = _standard_of(path)
    host = default_host()
    spec = host.get(std)
    if spec.kind != "standard":
        raise PluginError(f"{path.name}: standard {std!r} is a {spec.kind} plugin, not a standard")
    # through the standard's declaration (min 1, max 64), so --workers 0 is refused, not the default
    params = declared_values(args, parameters(), plugin=spec)
    res = host.run(std, {"plan": path}, params)
    result = res.outputs
    # the run's record without its outputs: they are the document itself
    result["run"] = {k: v for k, v in replace(res, outputs={}).to_json().items() if k != "outputs"}
    result["plugin"] = res.provenance()
    if args.report:
        result["report"] = {k: str(v) for k, v in host.load(std).write_report(result, args.report, path).items()}
    return result


def text(result: dict[str, Any]) -> str:
    lines = [
        f"{result.get('standard_name', result['standard'])}: {result['verdict'].upper()} "
        f"(guarded acceptance: {result.get('verdict_guarded', '-')})"
    ]
    lines.append(f"{'':3}{'parameter':34}{'value/mm':>10}{'MPE/mm':>9}{'U/mm':>9}  verdict / guarded")
    for key, p in result["parameters"].items():
        v = "-" if p["value"] is None else f"{p['value']:+.4f}"
        lines.append(
            f"{'':3}{p.get('name', key):34}{v:>10}{p['mpe']:>9.4f}{p.get('U', 0):>9.4f}  "
            f"{p['verdict']} / {p.get('verdict_guarded', '-')}"
        )
    for w in result.get("warnings", []):
        lines.append(f"warning: {w}")
    if result.get("report"):
        lines.append("report: " + ", ".join(result["report"].values()))
    return "\n".join(lines)
