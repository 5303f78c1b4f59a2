"""Parameter declarations: one declaration gives CLI options, JSON validation, GUI form."""

import argparse

import pytest

from camcmm.errors import ParameterError
from camcmm.params import Param, add_cli_options, cli_values, form_schema, validate

DECL = [
    Param.from_dict({"name": "voxel_size", "type": "float", "unit": "mm", "default": 1.0, "min": 1e-6}),
    Param.from_dict({"name": "iterations", "type": "int", "default": 10, "min": 1, "max": 100}),
    Param.from_dict({"name": "robust", "type": "bool", "default": False}),
    Param.from_dict({"name": "method", "type": "choice", "choices": ["ls", "minzone"], "default": "ls"}),
    Param.from_dict({"name": "origin", "type": "vector", "length": 3, "unit": "mm"}),
]


def test_cli_and_json_share_one_set_of_rules():
    parser = argparse.ArgumentParser()
    add_cli_options(parser, DECL)
    args = parser.parse_args(["--voxel-size", "0.5", "--robust", "yes", "--origin", "1,2,3"])
    from_cli = validate(DECL, cli_values(args))
    from_json = validate(DECL, {"voxel_size": 0.5, "robust": True, "origin": [1, 2, 3]})
    assert (
        from_cli
        == from_json
        == {"voxel_size": 0.5, "iterations": 10, "robust": True, "method": "ls", "origin": [1.0, 2.0, 3.0]}
    )


@pytest.mark.parametrize(
    "values, message",
    [
        ({"voxel_size": 0}, "below its minimum"),
        ({"voxel_size": "nan"}, "not finite"),
        ({"iterations": 2.5}, "expected an integer"),
        ({"iterations": 101}, "above its maximum 100"),
        ({"robust": "maybe"}, "expected true or false"),
        ({"method": "cheb"}, "expected one of ls, minzone"),
        ({"origin": [1, 2]}, "expected 3 numbers"),
    ],
)
def test_bad_values_name_the_parameter(values, message):
    with pytest.raises(ParameterError, match=message) as err:
        validate(DECL, values)
    assert repr(next(iter(values))) in str(err.value)


def test_bad_declarations_are_refused():
    with pytest.raises(ParameterError, match="unknown type"):
        Param.from_dict({"name": "x", "type": "complex"})
    with pytest.raises(ParameterError, match="needs 'choices'"):
        Param.from_dict({"name": "x", "type": "choice"})
    with pytest.raises(ParameterError, match="below its minimum"):
        Param.from_dict({"name": "x", "type": "float", "default": -1, "min": 0})


def test_form_schema_carries_units_and_limits():
    form = {f["name"]: f for f in form_schema(DECL)}
    assert form["voxel_size"]["label"] == "voxel size [mm]" and form["voxel_size"]["widget"] == "number"
    assert form["method"]["widget"] == "select" and form["method"]["choices"] == ["ls", "minzone"]
    assert form["robust"]["widget"] == "switch"
    assert form["iterations"]["max"] == 100
