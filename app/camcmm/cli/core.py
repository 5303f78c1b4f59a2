"""The core subcommands: serve, plugins, info, run, demo.

Each command is (summary, configure(parser), run(args) -> dict | None, text(result) -> str).
They are thin: the work happens in the host, the formats, the project store and the GUI.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..errors import CamcmmError, PluginError
from ..host import default_host
from ..numbers import significant
from ..params import add_cli_options, cli_values
from ..project.record import geometry_outputs, record_result
from . import cloud
from .options import add_declared_options
from .parser import Parser


def _json_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")


# -- serve ---------------------------------------------------------------------------
def _serve_args(p: argparse.ArgumentParser) -> None:
    from ..gui.app import add_serve_arguments, port_number  # light: trame and VTK load in build()

    p.add_argument("--project", default="camcmm-project", help="project folder (created if missing)")
    p.add_argument("--port", type=port_number, default=8080, help="port (0 picks a free one)")
    add_serve_arguments(p)  # --host, --data-root, --token-file, --no-token, --allow-origin, --certfile/--keyfile


def _serve(args: argparse.Namespace) -> None:
    from ..gui.app import serve_from_args  # lazy: trame and VTK are heavy

    serve_from_args(args.project, args, port=args.port)


# -- plugins -------------------------------------------------------------------------
def _plugins_args(p: argparse.ArgumentParser) -> None:
    _json_flag(p)


def _plugins(args: argparse.Namespace) -> dict[str, Any]:
    host = default_host()
    return {
        "plugins": [
            {
                k: v
                for k, v in s.to_dict().items()
                if k in ("id", "kind", "name", "version", "status", "distribution", "summary", "warnings")
            }
            for s in host.check()
        ],
        "commands": [
            {"name": c.name, "summary": c.summary, "distribution": c.distribution}
            for c in sorted(host.commands.values(), key=lambda c: c.name)
        ],
    }


def _plugins_text(result: dict[str, Any]) -> str:
    rows = [f"{'ID':24} {'KIND':10} {'VERSION':9} STATUS"]
    for p in result["plugins"]:
        rows.append(f"{p['id']:24} {p['kind']:10} {p['version']:9} {p['status']}")
        rows.extend(f"  warning: {w}" for w in p.get("warnings", []))  # e.g. a misspelt manifest key
    return "\n".join(rows)


# -- info ----------------------------------------------------------------------------
def _info_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="point cloud, mesh, height map or image file")
    p.add_argument(
        "--unit",
        help="length unit of the file's coordinates (m, cm, mm, um, in); without it: the file's own, else mm, "
        "with a warning when the size is implausible as mm (docs/units.md)",
    )
    _json_flag(p)


def _info(args: argparse.Namespace) -> dict[str, Any]:
    from ..io import info

    return info(args.file, unit=args.unit)


def _info_text(d: dict[str, Any]) -> str:
    lines = [f"{d['file']}: {d['kind']} ({d['format']})"]
    for key in ("n_points", "n_vertices", "n_faces", "width", "height", "channels"):
        if key in d:
            lines.append(f"  {key.replace('n_', '').replace('_', ' ')}: {d[key]}")
    if "bbox" in d:
        lo, hi = d["bbox"]["min"], d["bbox"]["max"]
        fmt = lambda v: "(" + ", ".join(f"{x:.4f}" for x in v) + ")"  # noqa: E731
        lines.append(f"  bounding box [mm]: {fmt(lo)} .. {fmt(hi)}")
        if d.get("source_unit", "mm") != "mm":
            lines.append(f"  converted from {d['source_unit']} to mm")
    if d.get("kind") == "heightmap":
        (nx, ny), (dx, dy), (w, h) = d["grid"], d["steps_mm"], d["size_mm"]
        lo, hi = d["height_range_mm"]
        step = f"{significant(dx * 1000, 4)} x {significant(dy * 1000, 4)}"
        lines.append(f"  grid: {nx} x {ny} points, steps {step} µm")
        lines.append(f"  size [mm]: {w:.4f} x {h:.4f}")
        if lo is not None:
            lines.append(f"  heights [µm]: {lo * 1000:.4f} .. {hi * 1000:.4f} (valid {d['valid_fraction']:.2%})")
        lines.append(f"  file unit: {d['source_unit']}; intensity: {'yes' if d['has_intensity'] else 'no'}")
        if d.get("instrument"):
            lines.append(f"  instrument: {d['instrument']}")
    if d.get("fields"):
        lines.append(f"  scalar fields: {', '.join(d['fields'])}")
    lines += [f"warning: {w}" for w in d.get("warnings", [])]  # e.g. no unit and an implausible size
    return "\n".join(lines)


# -- run -----------------------------------------------------------------------------
def _run_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("plugin", help="plugin id (see `camcmm plugins`)")
    p.add_argument("rest", nargs=argparse.REMAINDER, help="inputs (files, in declared order) and --PARAM VALUE options")


#: The options of `camcmm run` itself; a plugin parameter of one of these names is given as
#: ``--param-NAME`` so that these keep one meaning whatever the plugin.
_RUN_OPTIONS = ("project", "out", "json", "help")


def _plugin_parser(spec) -> argparse.ArgumentParser:
    clash = [q for q in spec.parameters if q.name in _RUN_OPTIONS]
    epilog = (
        (
            "The plugin's parameter"
            + ("s " if len(clash) > 1 else " ")
            + ", ".join(f"'{q.name}'" for q in clash)
            + " "
            + ("are" if len(clash) > 1 else "is")
            + " given as "
            + ", ".join(f"--param-{q.name}" for q in clash)
            + ": --project, --out and --json are camcmm run's own options."
        )
        if clash
        else None
    )
    p = Parser(prog=f"camcmm run {spec.id}", description=spec.summary, epilog=epilog)
    for port in spec.inputs:
        nargs = "+" if port.type in ("images", "files") else ("?" if port.optional else None)
        p.add_argument(port.name, nargs=nargs, help=f"{port.type} {port.help}".strip())
    add_cli_options(p, [q for q in spec.parameters if q.name not in _RUN_OPTIONS])
    add_declared_options(p, clash, prefix="--param-")
    p.add_argument("--project", help="record the result in this project folder")
    own_out = "; the plugin's own parameter 'out' is --param-out" if any(q.name == "out" for q in clash) else ""
    p.add_argument("--out", help="write the first cloud/mesh output to this file" + own_out)
    _json_flag(p)
    return p


def _run(args: argparse.Namespace) -> dict[str, Any]:
    host = default_host()
    spec = host.get(args.plugin)
    if spec.kind == "device":
        raise PluginError(f"plugin {spec.id!r} is a device; use it from the devices panel or a sequence")
    pa = _plugin_parser(spec).parse_args(args.rest)
    args.json = pa.json
    inputs = {port.name: getattr(pa, port.name) for port in spec.inputs if getattr(pa, port.name) is not None}
    result = host.run(spec.id, inputs, cli_values(pa))
    doc = result.to_json()
    geometry = geometry_outputs(result)
    if pa.out:
        if not geometry:
            hint = "; its own parameter 'out' is --param-out" if any(q.name == "out" for q in spec.parameters) else ""
            raise CamcmmError(f"plugin {spec.id!r} produced no cloud or mesh to write to {pa.out}{hint}")
        from ..io import write

        write(geometry[0][1], pa.out)
        doc["written"] = {geometry[0][0]: str(Path(pa.out))}
    if pa.project:
        doc["result_id"] = record_result(pa.project, result)
    return doc


# -- demo ----------------------------------------------------------------------------
def _demo_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("dir", nargs="?", default="camcmm-demo", help="folder for the demo project (default camcmm-demo)")
    _json_flag(p)


def _demo(args: argparse.Namespace) -> dict[str, Any]:
    from ..demo import create_demo

    return create_demo(args.dir)


def _demo_text(d: dict[str, Any]) -> str:
    lines = [f"demo project at {d['project']} with {len(d['measurements'])} measurements"]
    test = d.get("acceptance")
    if test:
        lines.append(
            f"finished {test['standard']} acceptance test: {test['verdict']}"
            f" (guarded acceptance: {test.get('verdict_guarded', '-')})"
        )
    lines += [f"note: {n}" for n in d.get("notes", [])]
    lines.append(f"open it with: camcmm serve --project {d['project']}")
    return "\n".join(lines)


COMMANDS = {
    "serve": ("Start the web GUI (prints its URL).", _serve_args, _serve, None),
    "plugins": ("List the plugins with kind, version and status.", _plugins_args, _plugins, _plugins_text),
    "info": ("Say what a file holds: kind, counts, bounding box, unit.", _info_args, _info, _info_text),
    "run": ("Run an algorithm plugin with its declared parameters.", _run_args, _run, None),
    "demo": ("Create the demo project.", _demo_args, _demo, _demo_text),
    "cloud": (cloud.SUMMARY, cloud.configure, cloud.run, cloud.text),  # big clouds out of core (issue 29)
}
