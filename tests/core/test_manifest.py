"""The manifest's declared fields (docs/manifest.md): each is validated, and a wrong
value is refused in one line naming the plugin and the field."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from camcmm.errors import PluginError
from camcmm.host import default_host
from camcmm.manifest import KEYS, SCHEMA, need, parse_manifest, parse_plugin

ROOT = Path(__file__).resolve().parents[2]
BASE = {"id": "lab.thing", "kind": "device", "name": "Thing", "entry": "lab_thing:Thing"}


def spec(**fields):
    return parse_plugin({**BASE, **fields}, "2.3.4", "lab-thing", "lab-thing plugin.yaml")


def refused(**fields) -> str:
    with pytest.raises(PluginError) as err:
        spec(**fields)
    text = str(err.value)
    assert "\n" not in text and "'lab.thing'" in text
    return text


def test_declared_fields_become_attributes():
    s = spec(
        role="sequence",
        simulated=True,
        needs={"stage": "stage", "cameras": "camera*", "speckle": "speckle?"},
        report="lab_thing.report:build",
        provides=["turning"],
    )
    assert (s.role, s.simulated, s.report, s.provides) == ("sequence", True, "lab_thing.report:build", ["turning"])
    assert s.needs == {"stage": "stage", "cameras": "camera*", "speckle": "speckle?"}
    assert s.version == "2.3.4" and not s.warnings
    a = parse_plugin({**BASE, "kind": "algorithm", "acquires": "pointcloud"}, "1", "d", "w")
    assert a.acquires == "pointcloud" and a.role == "" and a.simulated is False


@pytest.mark.parametrize(
    "field, value",
    [
        ("role", "Camera!"),
        ("role", 3),
        ("simulated", "yes"),
        ("acquires", "photo"),
        ("needs", ["stage"]),
        ("needs", {"Cameras": "camera"}),
        ("needs", {"cameras": "camera+"}),
        ("report", "lab_thing.report"),
        ("report", 5),
        ("provides", "turning"),
        ("provides", ["Turning"]),
        ("kind", "widget"),
        ("entry", "lab_thing"),
        ("version", {"major": 1}),
    ],
)
def test_each_field_is_validated_in_one_line_naming_plugin_and_field(field, value):
    assert f"field {field!r}" in refused(**{field: value})


def test_role_and_needs_belong_to_devices():
    with pytest.raises(PluginError, match="field 'role'"):
        parse_plugin({**BASE, "kind": "algorithm", "role": "camera"}, "1", "d", "w")
    with pytest.raises(PluginError, match="field 'needs'"):
        parse_plugin({**BASE, "kind": "algorithm", "needs": {"stage": "stage"}}, "1", "d", "w")


def test_need_patterns():
    assert need("stage") == need("stage")
    assert (need("camera*").many, need("camera*").optional) == (True, False)
    assert (need("speckle?").many, need("speckle?").optional) == (False, True)
    assert (need("camera*?").role, need("camera*?").many, need("camera*?").optional) == ("camera", True, True)
    with pytest.raises(ValueError):
        need("camera?*")


def test_unknown_keys_are_kept_with_a_warning_and_x_keys_silently():
    s = spec(simualted=True, **{"x-lab-note": "ours"})
    assert s.extra == {"simualted": True, "x-lab-note": "ours"}
    assert len(s.warnings) == 1 and "'simualted'" in s.warnings[0] and "'lab.thing'" in s.warnings[0]


def test_schema_absent_is_1_and_a_newer_schema_is_refused():
    doc = "name: d\nplugins:\n  - {id: a.b, kind: algorithm, name: A, entry: 'm:f'}\n"
    plugins, _, errors = parse_manifest(doc, "1", "d", "w")
    assert [p.id for p in plugins] == ["a.b"] and not errors
    plugins, _, errors = parse_manifest(f"schema: {SCHEMA}\n" + doc, "1", "d", "w")
    assert [p.id for p in plugins] == ["a.b"]
    with pytest.raises(PluginError, match=f"schema {SCHEMA + 1} is newer"):
        parse_manifest(f"schema: {SCHEMA + 1}\n" + doc, "1", "d", "w")
    with pytest.raises(PluginError, match="field 'schema'"):
        parse_manifest("schema: one\n" + doc, "1", "d", "w")


def test_builtin_manifests_declare_schema_1_and_no_version():
    # a plugin's version is its distribution's (one number to bump at a release)
    for path in sorted((ROOT / "plugins" / "camcmm_plugins").glob("*/plugin.yaml")):
        doc = yaml.safe_load(path.read_text())
        assert doc.get("schema") == 1, path
        assert not [p["id"] for p in doc["plugins"] if "version" in p], path


def test_builtin_plugins_use_only_declared_keys():
    host = default_host()
    assert not host.errors, [e.status for e in host.errors]
    assert not [w for s in host.plugins.values() for w in s.warnings]
    assert all(set(k for k in s.extra if not k.startswith("x")) <= set(KEYS) for s in host.plugins.values())


def test_manifest_doc_names_every_key():
    doc = (ROOT / "docs" / "manifest.md").read_text()
    missing = [k for k in (*KEYS, "schema", "commands") if f"`{k}`" not in doc]
    assert not missing, f"docs/manifest.md does not document {missing}"


def test_a_default_written_in_both_manifest_and_signature_agrees():
    # The manifest's default is the one the host passes; a different default in the entry
    # function's signature would be what a direct Python call gets - the same plugin
    # answering differently by the way it is called.
    import inspect

    host = default_host()
    differ = []
    for spec in host.plugins.values():
        obj = host.load(spec.id)
        sig = inspect.signature(obj.__init__ if inspect.isclass(obj) else obj)
        for p in spec.parameters:
            arg = sig.parameters.get(p.name)
            if p.default is None or arg is None or arg.default is inspect.Parameter.empty:
                continue
            if arg.default is None and p.type == "str" and p.default == "":
                continue  # both say "not given"
            if p.coerce(arg.default) != p.coerce(p.default):
                differ.append(f"{spec.id} {p.name}: manifest {p.default!r}, signature {arg.default!r}")
    assert not differ, "\n".join(differ)
