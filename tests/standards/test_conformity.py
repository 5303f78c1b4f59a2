"""ISO 14253-1 decision rules, on values placed exactly at and around the zone limits."""

import math

import pytest

from camcmm.conformity import combine, guarded_verdict, simple_verdict


@pytest.mark.parametrize(
    "value, expected",
    [(0.1, "pass"), (-0.1, "pass"), (0.186, "pass"), (-0.1861, "fail"), (None, "incomplete"), (math.nan, "incomplete")],
)
def test_simple_rule(value, expected):
    assert simple_verdict(value, 0.186) == expected


@pytest.mark.parametrize(
    "value, expected",
    [
        (0.14, "pass"),
        (0.15, "pass"),
        (0.151, "inconclusive"),
        (-0.2, "inconclusive"),
        (0.25, "inconclusive"),
        (0.2501, "fail"),
        (None, "incomplete"),
    ],
)
def test_guarded_rule_shrinks_and_widens_by_U(value, expected):
    assert guarded_verdict(value, mpe=0.2, expanded_uncertainty=0.05) == expected


def test_guarded_rule_with_zero_uncertainty_is_the_simple_rule():
    for v in (0.0, 0.1, 0.2, 0.2000001, -0.3):
        assert guarded_verdict(v, 0.2, 0.0) == simple_verdict(v, 0.2)


def test_missing_measurement_never_passes():
    assert combine(["pass", "pass", "incomplete"]) == "incomplete"
    assert combine(["pass", "fail", "incomplete"]) == "incomplete"
    assert combine([]) == "incomplete"
    assert combine(["pass", "inconclusive"]) == "inconclusive"
    assert combine(["pass", "fail", "inconclusive"]) == "fail"
    assert combine(["pass", "pass"]) == "pass"
