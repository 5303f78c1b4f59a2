"""Declared limits: every int parameter of every installed manifest has a max, floats are
finite, declarations are checked, and the CLI says what is wrong in one line."""

from __future__ import annotations

import math

import pytest

from camcmm.errors import ParameterError
from camcmm.host import default_host
from camcmm.params import INT_LIMIT, MAX_VECTOR, Param, validate
from helpers.cli import main_run

# Words in a parameter name that say it sizes, counts or repeats work; a float or vector
# in pixels or without a unit (a count) named so needs a max just as an int does. (A length
# in mm, e.g. voxel_size, sizes nothing in memory.)
SIZE_WORDS = {
    "size",
    "width",
    "height",
    "count",
    "iterations",
    "samples",
    "points",
    "frames",
    "steps",
    "workers",
    "images",
    "repeats",
    "bins",
    "columns",
    "rows",
}


def _sizes_work(p: Param) -> bool:
    words = set(p.name.split("_"))
    return p.unit in ("", "px") and (bool(words & SIZE_WORDS) or p.name.startswith("n_"))


def _specs():
    host = default_host()
    assert not host.errors, [(s.id, s.status) for s in host.errors]
    return host.plugins.values()


def test_every_int_and_size_parameter_of_every_manifest_declares_a_max():
    missing = [
        f"{spec.id}:{p.name}"
        for spec in _specs()
        for p in spec.parameters
        if p.maximum is None and (p.type == "int" or (p.type in ("float", "vector") and _sizes_work(p)))
    ]
    assert not missing, f"declare 'max' for: {', '.join(missing)}"


def test_every_int_device_setting_declares_a_max():
    host = default_host()
    missing = []
    for spec in _specs():
        if spec.kind == "device":
            for p in getattr(host.load(spec.id), "settings_schema", None) or ():
                if p.type == "int" and p.maximum is None:
                    missing.append(f"{spec.id}:{p.name}")
    assert not missing, f"declare 'max' for: {', '.join(missing)}"


def test_defaults_are_inside_their_limits_and_limits_are_finite():
    for spec in _specs():
        for p in spec.parameters:
            for lim in (p.minimum, p.maximum, p.exclusive_minimum):
                assert lim is None or math.isfinite(lim), (spec.id, p.name)
            if p.default is not None:
                p.coerce(p.default)  # raises ParameterError naming the parameter


def test_seeds_are_non_negative_or_the_declared_sentinel():
    for spec in _specs():
        for p in spec.parameters:
            if p.name == "seed":
                assert p.minimum is not None and p.minimum >= -1, (spec.id, p.minimum)


def test_the_host_refuses_beyond_max_with_one_line():
    host = default_host()
    spec = host.get("uncertainty.montecarlo")
    iterations = next(p for p in spec.parameters if p.name == "iterations")
    assert iterations.maximum == 10**8
    with pytest.raises(ParameterError) as err:
        validate(spec.parameters, {"iterations": 10**12}, owner=spec.id)
    assert str(err.value) == "parameter 'iterations' = 1000000000000 is above its maximum 100000000"


@pytest.mark.parametrize("value", [float("nan"), float("inf"), "-inf", "nan", "1e400"])
def test_floats_must_be_finite_unless_declared(value):
    p = Param.from_dict({"name": "gap", "type": "float", "unit": "mm"})
    with pytest.raises(ParameterError, match="not finite"):
        p.coerce(value)
    free = Param.from_dict({"name": "gap", "type": "float", "finite": False})
    assert not math.isfinite(free.coerce(value))


def test_vector_numbers_must_be_finite():
    p = Param.from_dict({"name": "v", "type": "vector", "length": 3})
    with pytest.raises(ParameterError, match="not finite"):
        p.coerce("1, nan, 3")


def test_exclusive_minimum():
    p = Param.from_dict({"name": "radius", "type": "float", "unit": "mm", "exclusive_min": 0})
    assert p.coerce("0.001") == 0.001
    with pytest.raises(ParameterError, match=r"'radius' = 0.0 must be above 0 mm"):
        p.coerce(0)
    assert p.to_dict()["exclusive_min"] == 0 and "min" not in p.to_dict()


@pytest.mark.parametrize(
    "value, reason",
    [
        ("1e400", "expected an integer"),
        (float("inf"), "cannot convert"),
        (2.5, "expected an integer"),
        (True, "expected an integer"),
        (str(10**20), "beyond"),
        ("9" * 5000, "too long"),
    ],
)
def test_int_values_that_are_no_ints(value, reason):
    p = Param.from_dict({"name": "n", "type": "int"})
    with pytest.raises(ParameterError, match=reason) as err:
        p.coerce(value)
    assert len(str(err.value)) < 200


def test_ints_parse_exactly():
    p = Param.from_dict({"name": "n", "type": "int"})
    assert p.coerce("9007199254740993"[:-1] + "1") == 9007199254740991 == INT_LIMIT - 1  # not via float
    assert p.coerce("1e3") == 1000 and p.coerce(" 7 ") == 7 and p.coerce(4.0) == 4


def test_unbounded_vectors_and_strings_are_capped():
    v = Param.from_dict({"name": "at", "type": "vector"})
    assert len(v.coerce(list(range(MAX_VECTOR)))) == MAX_VECTOR
    with pytest.raises(ParameterError, match=f"more than {MAX_VECTOR} numbers"):
        v.coerce(list(range(MAX_VECTOR + 1)))
    s = Param.from_dict({"name": "label", "type": "str"})
    with pytest.raises(ParameterError, match="longer than"):
        s.coerce("x" * 100_000)


@pytest.mark.parametrize(
    "decl, reason",
    [
        ({"name": "n", "type": "int", "maximum": 5}, "unknown key 'maximum'"),
        ({"name": "n", "type": "int", "min": 5, "max": 3}, "min 5 is above max 3"),
        ({"name": "n", "type": "int", "max": float("inf")}, "max must be a finite number"),
        ({"name": "n", "type": "int", "max": "10"}, "max must be a finite number"),
        ({"name": "n", "type": "int", "max": 10, "default": 11}, "above its maximum"),
    ],
)
def test_bad_declarations_are_refused(decl, reason):
    with pytest.raises(ParameterError, match=reason):
        Param.from_dict(decl)


def test_a_manifest_with_a_bad_limit_names_plugin_and_parameter():
    from camcmm.manifest import parse_manifest

    text = (
        "plugins:\n  - {id: lab.x, kind: algorithm, name: X, entry: 'm:f',\n"
        "     parameters: [{name: n, type: int, maximum: 3}]}\n"
    )
    plugins, _, errors = parse_manifest(text, "1.0", "lab", "lab/plugin.yaml")
    assert not plugins and len(errors) == 1
    assert "lab.x" in errors[0][1] and "'n'" in errors[0][1] and "maximum" in errors[0][1]


def test_cli_help_shows_limits_and_the_refusal_is_one_line(capfd):
    # in-process (main_run: the CLI's main with capfd), not a subprocess: only the output counts
    run = ["run", "cloud.denoise"]
    rc, out, err = main_run(capfd, *run, "--help")
    assert rc == 0, err
    assert "2 <= x <= 1000" in " ".join(out.split())
    rc, _, err = main_run(capfd, *run, "nothere.ply", "--neighbours", "100000")
    assert rc != 0
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "neighbours" in lines[0] and "maximum 1000" in lines[0], err


def test_cli_help_with_a_percent_unit_does_not_crash(capfd):
    rc, out, err = main_run(capfd, "run", "inspect.material-ratio", "--help")
    assert rc == 0, err
    assert "[%]" in out
