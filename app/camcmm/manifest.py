"""Plugin manifests, read without importing the plugin's code.

A plugin package registers one entry point in the group ``camcmm.plugins`` whose value
names a YAML file inside the package, npe2-style::

    [project.entry-points."camcmm.plugins"]
    my_lab = "my_lab_plugin:plugin.yaml"

The file declares what the package contributes::

    schema: 1                       # the manifest format (absent: 1)
    name: my-lab-plugin
    plugins:
      - id: mylab.flatness          # unique, dotted
        kind: algorithm             # algorithm | device | standard
        name: Flatness (lab method)
        summary: One line.          # the version is the distribution's
        entry: my_lab_plugin.flat:run   # imported only when the plugin is used
        inputs:  [{name: cloud, type: pointcloud}]
        parameters: [{name: tolerance, type: float, unit: mm, default: 0.01, min: 0}]
        outputs: [{name: flatness, type: float, unit: mm}]
    commands:                       # optional CLI subcommands: camcmm NAME ...
      - {name: flat, summary: One line., entry: my_lab_plugin.cli}

Every key, its type and meaning is in docs/manifest.md; the contract of a plugin's code
in docs/plugins.md. A wrong value is refused in one line naming the plugin and the key;
an unknown key is kept in ``PluginSpec.extra`` with a warning (``x-`` keys silently).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

from .errors import PluginError
from .params import Param
from .yamlfile import YamlError, load_yaml

#: The manifest format this camcmm reads; a manifest without ``schema`` is schema 1.
SCHEMA = 1
KINDS = ("algorithm", "device", "standard")
INPUT_TYPES = ("pointcloud", "mesh", "geometry", "image", "images", "file", "files", "json")
#: What an ``acquires`` plugin hands to the acceptance wizard's acquisition step.
ACQUIRES = ("pointcloud", "mesh", "image", "images")
#: The device roles camcmm's pages know; a lab may declare others (any lower-case name).
ROLES = ("camera", "stage", "projector", "interferometer", "speckle", "sequence")
_ID = re.compile(r"^[a-z0-9][a-z0-9_.-]*$")
_SLOT = re.compile(r"^[a-z_][a-z0-9_]*$")
_NEED = re.compile(r"^([a-z0-9][a-z0-9_.-]*)(\*?)(\??)$")
_ENTRY = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_][\w.]*$")
#: Keys of a plugin entry (docs/manifest.md); others go to ``extra`` with a warning.
KEYS = (
    "id",
    "kind",
    "name",
    "version",
    "summary",
    "entry",
    "parameters",
    "inputs",
    "outputs",
    "provides",
    "role",
    "simulated",
    "acquires",
    "needs",
    "report",
)


@dataclass
class Port:
    """A declared input or output: name, type, unit, help; ``optional`` inputs may be omitted;
    ``max`` (an ``images``/``files`` input) the most items one run takes, 0 for no limit
    (the host refuses more before reading any; the GUI's pages state the same one)."""

    name: str
    type: str
    unit: str = ""
    help: str = ""
    optional: bool = False
    max: int = 0

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"name": self.name, "type": self.type}
        d.update({k: v for k, v in (("unit", self.unit), ("help", self.help)) if v})
        if self.optional:
            d["optional"] = True
        if self.max:
            d["max"] = self.max
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
    role: str = ""
    simulated: bool = False
    acquires: str = ""
    needs: dict[str, str] = field(default_factory=dict)
    report: str = ""
    extra: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        declared = {
            "provides": self.provides,
            "role": self.role,
            "simulated": self.simulated,
            "acquires": self.acquires,
            "needs": self.needs,
            "report": self.report,
            "warnings": self.warnings,
        }
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
            **{k: v for k, v in declared.items() if v},  # only what the manifest says
        }


@dataclass(frozen=True)
class Need:
    """One slot of a sequence device's ``needs``: the ``role`` of the device(s) it takes,
    whether it takes several (``camera*``) and whether it may stay empty (``speckle?``)."""

    role: str
    many: bool = False
    optional: bool = False


def need(pattern: str) -> Need:
    """Parse a ``needs`` pattern: ``"stage"`` (exactly one), ``"camera*"`` (one or more),
    ``"speckle?"`` (none or one), ``"camera*?"`` (any number). ValueError otherwise."""
    m = _NEED.match(str(pattern))
    if not m:
        raise ValueError(f"{pattern!r} is not a role name followed by nothing, '*', '?' or '*?'")
    return Need(m.group(1), m.group(2) == "*", m.group(3) == "?")


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
    most = d.get("max", 0)
    if (
        not isinstance(most, int)
        or isinstance(most, bool)
        or most < 0
        or (most and d["type"] not in ("images", "files"))
    ):
        raise PluginError(
            f"{where}: input {d['name']!r}: max {most!r} must be a whole number >= 0, on images/files only"
        )
    return Port(
        str(d["name"]),
        str(d["type"]),
        str(d.get("unit", "")),
        str(d.get("help", "")),
        bool(d.get("optional", False)),
        most,
    )


def _declared(d: dict[str, Any], kind: str, fail: Any) -> dict[str, Any]:
    """The optional schema-1 fields of one entry, checked; ``fail(key, reason)`` raises."""
    provides = d.get("provides") or []
    if (
        isinstance(provides, str)
        or not isinstance(provides, list)
        or not all(isinstance(t, str) and _ID.match(t) for t in provides)
    ):
        fail("provides", f"must be a list of task names (lower-case letters, digits, '.', '_', '-'), got {provides!r}")
    role = d.get("role", "")
    if role != "" and (kind != "device" or not isinstance(role, str) or not _ID.match(role)):
        fail(
            "role",
            f"must be a lower-case name ({', '.join(ROLES)}, ...) on a device, got {role!r}"
            + (f" on a {kind}" if kind != "device" else ""),
        )
    simulated = d.get("simulated", False)
    if not isinstance(simulated, bool):
        fail("simulated", f"must be true or false, got {simulated!r}")
    acquires = d.get("acquires", "")
    if acquires != "" and acquires not in ACQUIRES:
        fail("acquires", f"must be one of {', '.join(ACQUIRES)}, got {acquires!r}")
    needs = d.get("needs") or {}
    if "needs" in d and (not isinstance(needs, dict) or kind != "device"):
        fail("needs", f"must be a mapping slot: role on a device, got {needs!r}")
    for slot, pattern in needs.items():
        if not isinstance(slot, str) or not _SLOT.match(slot):
            fail("needs", f"slot {slot!r} must be a lower-case identifier (it is passed as a keyword)")
        try:
            need(pattern)
        except ValueError as exc:
            fail("needs", f"slot {slot!r}: {exc}")
    report = d.get("report", "")
    if report != "" and (not isinstance(report, str) or not _ENTRY.match(report)):
        fail("report", f"must read 'module:function', got {report!r}")
    version = d.get("version")
    if version is not None and not isinstance(version, (str, int, float)):
        fail("version", f"must be a version string, got {version!r}")
    return {
        "provides": list(provides),
        "role": role,
        "simulated": simulated,
        "acquires": acquires,
        "needs": {str(k): str(v) for k, v in needs.items()},
        "report": report,
    }


def parse_plugin(d: Any, default_version: str, distribution: str, where: str) -> PluginSpec:
    """Build a PluginSpec from one manifest entry; raise PluginError naming the fault
    (``<where>: plugin 'x.y' field 'role': must be ...``)."""
    if not isinstance(d, dict):
        raise PluginError(f"{where}: a plugin entry must be a mapping, got {type(d).__name__}")
    missing = [k for k in ("id", "kind", "name", "entry") if not d.get(k)]
    if missing:
        raise PluginError(f"{where}: plugin {d.get('id', '?')!r} lacks {', '.join(missing)}")
    pid = str(d["id"])
    if not _ID.match(pid):
        raise PluginError(f"{where}: plugin id {pid!r} must be lower-case letters, digits, '.', '_' or '-'")

    def fail(key: str, reason: str) -> None:
        raise PluginError(f"{where}: plugin {pid!r} field {key!r}: {reason}")

    if d["kind"] not in KINDS:
        fail("kind", f"{d['kind']!r} is not one of {', '.join(KINDS)}")
    if ":" not in str(d["entry"]):
        fail("entry", f"{d['entry']!r} must read 'module:attribute'")
    try:
        params = [Param.from_dict(p) for p in d.get("parameters") or []]
    except Exception as exc:  # ParameterError or a malformed mapping
        raise PluginError(f"{where}: plugin {pid!r}: {exc}") from None
    declared = _declared(d, str(d["kind"]), fail)
    unknown = [k for k in d if k not in KEYS]
    warnings = [
        f"{where}: plugin {pid!r}: unknown key {k!r} (kept in extra; see docs/manifest.md)"
        for k in unknown
        if not str(k).startswith(("x-", "x_"))
    ]
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
        **declared,
        extra={k: v for k, v in d.items() if k in unknown},
        warnings=warnings,
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
    schema = doc.get("schema", 1)
    if not isinstance(schema, int) or isinstance(schema, bool) or schema < 1:
        raise PluginError(f"{where}: field 'schema' must be a whole number (1), got {schema!r}")
    if schema > SCHEMA:
        raise PluginError(
            f"{where}: manifest schema {schema} is newer than this camcmm reads ({SCHEMA}); update camcmm"
        )
    plugins: list[PluginSpec] = []
    errors: list[tuple[str, str]] = []
    for i, entry in enumerate(doc.get("plugins") or []):
        try:
            plugins.append(parse_plugin(entry, default_version, distribution, where))
        except PluginError as exc:
            pid = (entry.get("id") if isinstance(entry, dict) else None) or f"{distribution}[{i}]"
            errors.append((str(pid), str(exc)))
    commands: list[CommandSpec] = []
    for c in doc.get("commands") or []:
        if not isinstance(c, dict) or not c.get("name") or not c.get("entry"):
            errors.append((f"{distribution}:command", f"{where}: a command needs a name and an entry, got {c!r}"))
            continue
        commands.append(CommandSpec(str(c["name"]), str(c.get("summary", "")), str(c["entry"]), distribution))
    return plugins, commands, errors
