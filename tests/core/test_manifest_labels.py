"""Unit labels once (issue 15: "exposure ms [ms]"): every built-in plugin's declared
parameters and every built-in device's settings get a form label whose words do not
already end in the unit the label then adds in brackets."""

from __future__ import annotations

import re

import pytest

from camcmm.host import default_host
from camcmm.numbers import unit_text
from camcmm.params import Param, form_schema, label


def _unit_spellings(unit: str) -> set[str]:
    """Ways a label's last words spell ``unit`` (written here independently of params.py)."""
    u = unit.lower().replace("µ", "u")
    parts = [w for w in re.split(r"[^a-z0-9%°]+", u) if w]
    out = {u, " ".join(parts), unit.lower()}
    if len(parts) == 2:
        out.add(f"{parts[0]} per {parts[1]}")
    return {s for s in out if s}


def _doubled(field: dict) -> str | None:
    """The reason a form field's label repeats its unit, or None."""
    unit = field.get("unit") or ""
    text = field["label"]
    if not unit:
        return None
    tail = f" [{unit_text(unit)}]"  # shown as a person writes it: µm, µrad, ° (issue 30)
    if not text.endswith(tail):
        return f"{text!r} does not end in {tail!r}"
    words = text[: -len(tail)].strip().lower()
    if words.count(f"[{unit.lower()}]") or words.count(tail.strip().lower()):
        return f"{text!r} names its unit twice"
    for spelled in _unit_spellings(unit):
        if words == spelled or words.endswith(" " + spelled):
            return f"{text!r}: the name already ends in its unit {unit!r}"
    return None


def _builtin_specs():
    host = default_host()
    return host, [s for s in host.plugins.values() if s.entry.startswith("camcmm_plugins.")]


def test_every_builtin_parameter_is_labelled_with_its_unit_once():
    _, specs = _builtin_specs()
    assert specs, "no built-in plugin found"
    bad = []
    n = 0
    for spec in specs:
        for field in form_schema(spec.parameters):
            n += 1
            why = _doubled(field)
            if why:
                bad.append(f"{spec.id}.{field['name']}: {why}")
    assert n > 100  # the walk reached the manifests
    assert not bad, bad


@pytest.mark.slow
def test_every_builtin_device_setting_is_labelled_with_its_unit_once():
    """The devices' settings (exposure_ms, gain_db, move_timeout_s ...) are declared in code."""
    host, specs = _builtin_specs()
    bad, seen = [], 0
    for spec in specs:
        if spec.kind != "device":
            continue
        cls = host.load(spec.id)
        for field in form_schema(list(getattr(cls, "settings_schema", ()))):
            seen += 1
            why = _doubled(field)
            if why:
                bad.append(f"{spec.id}.{field['name']}: {why}")
    assert seen >= 5
    assert not bad, bad


@pytest.mark.parametrize(
    ("name", "unit", "expected"),
    [
        ("exposure_ms", "ms", "exposure [ms]"),  # the case issue 15 saw
        ("gain_db", "dB", "gain [dB]"),
        ("travel_mm", "mm", "travel [mm]"),
        ("span_deg", "deg", "span [°]"),
        ("pitch_um", "um", "pitch [µm]"),  # the key's ASCII unit, written µm (issue 30)
        ("u_rotation", "urad", "u rotation [µrad]"),
        ("speed_mm_per_s", "mm/s", "speed [mm/s]"),
        ("sigma_um", "µm", "sigma [µm]"),
        ("voxel_size", "mm", "voxel size [mm]"),
        ("mm", "mm", "mm [mm]"),  # a name that is only its unit keeps it
        ("comms", "s", "comms [s]"),  # a word ending in the unit's letters is not the unit
        ("iterations", "", "iterations"),
    ],
)
def test_label_names_the_unit_once(name, unit, expected):
    field = {"label": label(Param(name, unit=unit)), "unit": unit}
    assert field["label"] == expected
    assert _doubled(field) is None or name == "mm"


def test_the_check_refuses_the_old_label():
    """The check itself fails on the label the form used to make."""
    assert _doubled({"label": "exposure ms [ms]", "unit": "ms"})
    assert _doubled({"label": "travel mm [mm]", "unit": "mm"})
    assert _doubled({"label": "speed mm per s [mm/s]", "unit": "mm/s"})


# -- words instead of keys (issue 30) ---------------------------------------------------------
def test_a_declared_label_and_choice_titles_are_what_the_form_shows():
    from camcmm.params import choice_title

    p = Param.from_dict(
        {
            "name": "camera_model",
            "type": "choice",
            "choices": ["SIMPLE_RADIAL", "OPENCV", "stereo_fringe", "um"],
            "choice_titles": {"SIMPLE_RADIAL": "simple radial (f, cx, cy, k)"},
            "default": "SIMPLE_RADIAL",
        }
    )
    (field,) = form_schema([p])
    assert field["choices"] == ["SIMPLE_RADIAL", "OPENCV", "stereo_fringe", "um"]  # the keys stay the values
    assert [i["title"] for i in field["items"]] == ["simple radial (f, cx, cy, k)", "OPENCV", "stereo fringe", "µm"]
    assert [i["value"] for i in field["items"]] == field["choices"]
    assert choice_title(p, "SIMPLE_RADIAL") == "simple radial (f, cx, cy, k)"
    assert Param.from_dict(p.to_dict()) == p  # the titles survive the manifest's JSON

    q = Param.from_dict({"name": "scheduler", "type": "address", "label": "compute cluster (Dask scheduler)"})
    assert form_schema([q])[0]["label"] == "compute cluster (Dask scheduler)" and q.label == q.declared_label
    r = Param.from_dict({"name": "pitch", "unit": "um", "label": "pixel pitch"})
    assert label(r) == "pixel pitch [µm]"


def test_choice_titles_must_name_declared_choices():
    from camcmm.errors import ParameterError

    with pytest.raises(ParameterError, match="choice_titles"):
        Param.from_dict({"name": "m", "type": "choice", "choices": ["a"], "choice_titles": {"b": "B"}})


def test_a_parameter_is_named_in_words_in_a_message():
    from camcmm.params import named

    p = Param("sigma_px", unit="px")
    assert named(p) == "sigma" and named(p, 6.0) == "sigma = 6 px"
    assert named(Param("u_rotation", unit="urad"), 25.0) == "u rotation = 25 µrad"
    assert named(Param("iterations", type="int"), 10) == "iterations = 10"
