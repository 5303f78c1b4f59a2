"""Plugin manifests, read without importing the plugin's code.

A plugin package registers one entry point in the group ``camcmm.plugins`` whose value
names a YAML file inside the package, npe2-style::

    [project.entry-points."camcmm.plugins"]
    my_lab = "my_lab_plugin:plugin.yaml"

The file declares what the package contributes::

    name: my-lab-plugin
    plugins:
      - id: mylab.flatness          # unique, dotted
        kind: algorithm             # algorithm | device | standard
        name: Flatness (lab method)
        version: 1.2.0              # optional; defaults to the distribution's version
        summary: One line.
        entry: my_lab_plugin.flat:run   # imported only when the plugin is used
        inputs:  [{name: cloud, type: pointcloud}]
        parameters: [{name: tolerance, type: float, unit: mm, default: 0.01, min: 0}]
        outputs: [{name: flatness, type: float, unit: mm}]
    commands:                       # optional CLI subcommands: camcmm NAME ...
      - {name: flat, summary: One line., entry: my_lab_plugin.cli}

See docs/plugins.md for the full contract.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

from .errors import PluginError
from .params import Param
from .yamlfile import YamlError, load_yaml

KINDS = ("algorithm", "device", "standard")
INPUT_TYPES = ("pointcloud", "mesh", "geometry", "image", "images", "file", "files", "json")
_ID = re.compile(r"^[a-z0-9][a-z0-9_.-]*$")


@dataclass
class Port:
    """A declared input or output: name, type, unit, help; ``optional`` inputs may be omitted."""

    name: str
    type: str
    unit: str = ""
    help: str = ""
    optional: bool = False

    def to_dict(self) -> dict[str, Any]:
        d = {"name": self.name, "type": self.type}
        d.update({k: v for k, v in (("unit", self.unit), ("help", self.help)) if v})
        if self.optional:
            d["optional"] = True
        return d


@dataclass
class PluginSpec:
    """One plugin as its manifest declares it. ``status`` is ``"ok"`` or the reason it
    cannot be used (bad manifest, failed import)."""

    id: str
    kind: str
    name: str
    version: str
    summary: str
    entry: str
    parameters: list[Param] = field(default_factory=list)
    inputs: list[Port] = field(default_factory=list)
    outputs: list[Port] = field(default_factory=list)
    distribution: str = ""
    status: str = "ok"
    provides: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "kind": self.kind,
            "name": self.name,
            "version": self.version,
            "summary": self.summary,
            "status": self.status,
            "distribution": self.distribution,
            "entry": self.entry,
            "parameters": [p.to_dict() for p in self.parameters],
            "inputs": [p.to_dict() for p in self.inputs],
            "outputs": [p.to_dict() for p in self.outputs],
        }


@dataclass
class CommandSpec:
    """A CLI subcommand a plugin package contributes; ``entry`` is a module with
    ``configure(parser)`` and ``run(args) -> dict`` (and optionally ``text(result) -> str``)."""

    name: str
    summary: str
    entry: str
    distribution: str = ""


def _port(d: Any, where: str) -> Port:
    if not isinstance(d, dict) or "name" not in d or "type" not in d:
        raise PluginError(f"{where}: each input/output needs a name and a type, got {d!r}")
    return Port(str(d["name"]), str(d["type"]), str(d.get("unit", "")), str(d.get("help", "")),
                bool(d.get("optional", False)))


def parse_plugin(d: Any, default_version: str, distribution: str, where: str) -> PluginSpec:
    """Build a PluginSpec from one manifest entry; raise PluginError naming the fault."""
    if not isinstance(d, dict):
        raise PluginError(f"{where}: a plugin entry must be a mapping, got {type(d).__name__}")
    missing = [k for k in ("id", "kind", "name", "entry") if not d.get(k)]
    if missing:
        raise PluginError(f"{where}: plugin {d.get('id', '?')!r} lacks {', '.join(missing)}")
    pid = str(d["id"])
    if not _ID.match(pid):
        raise PluginError(f"{where}: plugin id {pid!r} must be lower-case letters, digits, '.', '_' or '-'")
    if d["kind"] not in KINDS:
        raise PluginError(f"{where}: plugin {pid!r} has kind {d['kind']!r}; use one of {', '.join(KINDS)}")
    if ":" not in str(d["entry"]):
        raise PluginError(f"{where}: plugin {pid!r} entry {d['entry']!r} must read 'module:attribute'")
    try:
        params = [Param.from_dict(p) for p in d.get("parameters") or []]
    except Exception as exc:  # ParameterError or a malformed mapping
        raise PluginError(f"{where}: plugin {pid!r}: {exc}") from None
    provides = d.get("provides") or []
    if isinstance(provides, str) or not all(isinstance(t, str) and _ID.match(t) for t in provides):
        raise PluginError(f"{where}: plugin {pid!r}: 'provides' must be a list of task names "
                          f"(lower-case letters, digits, '.', '_', '-'), got {provides!r}")
    known = {"id", "kind", "name", "version", "summary", "entry", "parameters", "inputs", "outputs", "provides"}
    return PluginSpec(
        id=pid,
        kind=str(d["kind"]),
        name=str(d["name"]),
        version=str(d.get("version") or default_version),
        summary=str(d.get("summary", "")),
        entry=str(d["entry"]),
        parameters=params,
        inputs=[_port(p, where) for p in d.get("inputs") or []],
        outputs=[_port(p, where) for p in d.get("outputs") or []],
        distribution=distribution,
        provides=list(provides),
        extra={k: v for k, v in d.items() if k not in known},
    )


def parse_manifest(text: str, default_version: str, distribution: str, where: str):
    """Parse a manifest's YAML text. Returns (plugins, commands, errors): one bad plugin
    entry does not hide its good neighbours; each error is a one-line reason."""
    try:
        doc = load_yaml(text, name=where)
    except YamlError as exc:
        raise PluginError(str(exc)) from None
    if not isinstance(doc, dict):
        raise PluginError(f"{where}: manifest must be a mapping with a 'plugins' list")
    plugins, errors = [], []
    for i, entry in enumerate(doc.get("plugins") or []):
        try:
            plugins.append(parse_plugin(entry, default_version, distribution, where))
        except PluginError as exc:
            pid = (entry.get("id") if isinstance(entry, dict) else None) or f"{distribution}[{i}]"
            errors.append((str(pid), str(exc)))
    commands = []
    for c in doc.get("commands") or []:
        if not isinstance(c, dict) or not c.get("name") or not c.get("entry"):
            errors.append((f"{distribution}:command", f"{where}: a command needs a name and an entry, got {c!r}"))
            continue
        commands.append(CommandSpec(str(c["name"]), str(c.get("summary", "")), str(c["entry"]), distribution))
    return plugins, commands, errors
