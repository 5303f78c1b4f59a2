"""The one number rule (camcmm.numbers) against hand-written expectations, kind by kind, and
its properties over a log-spaced sweep: no exponent ever for a length, time or percentage;
the written value read back lies within half a unit of its last digit."""

from __future__ import annotations

import math
import re

import pytest

from camcmm import numbers as n
from camcmm.api import numbers as api_numbers

M = "\u2212"


def test_the_module_is_reachable_through_the_api_and_the_inspect_page():
    from camcmm.gui.pages.inspect import numbers as old

    assert api_numbers is n
    assert old.length is n.length and old.mm is n.mm and set(old.__all__) == set(n.__all__)


def test_lengths_take_their_digits_from_the_uncertainty():
    assert n.length(25.400123, 8e-4) == "25.40012 mm"  # u = 0.80 µm -> 0.01 µm
    assert n.length(9.99998341, 1.89e-5) == "9.999983 mm"  # u = 0.019 µm -> 1 nm
    assert n.length(9.99998341, 0.004) == "10.0000 mm"  # u = 4.0 µm -> 0.1 µm
    assert n.length(25.4, None) == "25.4000 mm"  # no u: 0.1 µm
    assert n.length(-5.00000723, 2.7e-5) == f"{M}5.000007 mm"
    assert n.length(0.0123, None, "µm") == "12.3 µm"
    assert n.length(0.0123, 4e-4, "um") == "12.30 µm"
    assert n.length(-0.00000001, 1e-3) == "0 mm"  # rounds to zero: "0", never "−0.000"
    assert n.length(float("nan")) == "not defined" and n.length(None) == "not defined"
    with pytest.raises(ValueError):
        n.length(1.0, unit="in")


def test_deviations_and_form_in_micrometres():
    assert n.deviation(0.0123) == "+12.3 µm"
    assert n.deviation(-0.00399) == f"{M}3.99 µm"
    assert n.deviation(0.1234) == "+123 µm"
    assert n.deviation(2.5) == "+2500 µm"  # still µm: one unit for deviations
    assert n.deviation(0.0123, signed=False) == "12.3 µm"  # form
    assert n.deviation(-4e-7) == "0 µm" and n.deviation(4e-7) == "0 µm"
    assert n.deviation(0.01234, u_mm=2.1e-4) == "+12.34 µm"


def test_characteristics_a_size_in_mm_a_zone_in_micrometres():
    assert n.characteristic(20.0100123, size=True) == "20.0100 mm"
    assert n.characteristic(20.0100123, size=True, u_mm=2e-5) == "20.010012 mm"
    assert n.characteristic(0.0123) == "12.3 µm" and n.characteristic(1.5) == "1.5000 mm"
    assert n.characteristic(None) == "not defined"


def test_uncertainties_two_significant_digits_and_the_coverage_factor_in_words():
    assert n.uncertainty(1.89e-5) == "0.019 µm"
    assert n.uncertainty(0.01314) == "13 µm"  # not "13.14 µm"
    assert n.uncertainty(0.01314, k=2) == "13 µm (k = 2)"
    assert n.uncertainty(0.0042) == "4.2 µm" and n.uncertainty(2.5) == "2.5 mm"
    assert n.uncertainty(0.99974) == "1.0 mm"  # 999.7 µm rounds to 1000 µm
    assert n.uncertainty(0.0) == "0 µm" and n.uncertainty(1e-5) == "0.010 µm"
    assert n.uncertainty_parts(1.89e-5) == ("0.019", "µm")
    assert n.uncertainty_parts(float("nan")) == ("not defined", "")
    assert n.uncertainty_vector([2.7e-5, 3.8e-5]) == ("(0.027, 0.038)", "µm")
    assert n.measured(25.400123, 8e-4) == "25.40012 mm ± 0.80 µm"
    # U = 2 u: the value's digits follow the standard uncertainty, U is written as given
    assert n.measured(25.400123, 1.6e-3, k=2) == "25.40012 mm ± 1.6 µm (k = 2)"


def test_any_quantity_with_its_uncertainty():
    assert n.value_u(0.0123456, 2.1e-5, "mm λ⁻¹") == "0.012346 ± 0.000021 mm λ⁻¹"
    assert n.value_u(-1.23456, 0.0123) == f"{M}1.235 ± 0.012"
    assert n.value_u(2.5, None, "px") == "2.5 px" and n.value_u(0.0004, 0.01, signed=True) == "0 ± 0.010"
    assert n.value_u(None, 1) == "not defined"


def test_times():
    assert n.time(0.8) == "0.8 s" and n.time(4.24) == "4.2 s" and n.time(0.012) == "12 ms"
    assert n.time(42.4) == "42 s" and n.time(9.97) == "10 s" and n.time(119.4) == "119 s"
    assert n.time(170) == "2 min 50 s" and n.time(3599.4) == "59 min 59 s"
    assert n.time(3599.6) == "1 h 0 min" and n.time(3900) == "1 h 5 min"
    assert n.time(0) == "0 s" and n.time(-3) == f"{M}3.0 s" and n.time(None) == "not defined"


def test_percentages_and_percentiles():
    assert n.percent(0.632) == "63 %" and n.percent(0.004) == "0.4 %" and n.percent(1.0) == "100 %"
    assert n.percent(0.0004) == "0 %" and n.percent(-0.0004) == "0 %"
    assert n.percent(0.0995, decimals=2) == "9.95 %"
    assert [n.percentile_key(k) for k in ("p0_5", "p2_5", "p50", "p97_5", "p99_5")] == [
        "0.5 %",
        "2.5 %",
        "50 %",
        "97.5 %",
        "99.5 %",
    ]
    assert n.percentile_key("mean") == "mean"


def test_angles_in_microradians_or_degrees():
    assert n.angle(1.23e-5) == "12.3 µrad"
    assert n.angle(12.3, "urad") == "12.3 µrad"
    assert n.angle(-4.56e-6, "rad", 2e-7) == f"{M}4.56 µrad"
    assert n.angle(12.345, "deg") == "12.35°"  # 12.345 is 12.3449999… in binary
    assert n.angle(math.radians(30)) == "30.00°"
    assert n.angle(1e-12) == "0 µrad"
    with pytest.raises(ValueError):
        n.angle(1.0, "grad")


def test_counts_plain_numbers_and_units():
    assert n.count(59997) == "59 997" and n.count(1234567) == "1 234 567" and n.count(7) == "7"
    assert n.plain(0.8213) == "0.821" and n.plain(0.09999) == "0.100" and n.plain(1234567) == "1234567"
    assert n.plain(-1e-9) == f"{M}0.00000000100" and n.ratio(2.0318, 3) == "2.03"
    assert n.significant(0.1 + 0.2) == "0.3" and n.significant(1e6) == "1000000"
    assert n.mm(9.99998341, 1.89e-5) == "9.999983" and n.micro(0.0157) == "15.7"
    assert n.unit_text("um") == "µm" and n.unit_text("urad") == "µrad" and n.unit_text("deg") == "°"
    assert n.unit_text("mm") == "mm" and n.unit_text(None) == ""
    assert n.unit_text("lambda") == "λ"  # the light field's depth unit
    assert n.title("radial_deviation", "um") == "radial deviation [µm]" and n.words("n_points") == "n points"


def test_ticks_are_round_and_inside_the_range():
    # the Acceptance legend of the issue: 0.01899 / 0.009493 mm -> µm, round ticks
    unit, factor = n.legend_unit("mm", -0.01899, 0.009493)
    assert (unit, factor) == ("µm", 1000.0)
    t = n.ticks(-0.01899 * factor, 0.009493 * factor)
    assert t == [-15.0, -10.0, -5.0, 0.0, 5.0]
    assert n.tick_text(t) == [f"{M}15", f"{M}10", f"{M}5", "0", "5"]
    assert n.ticks(0, 1) == [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    assert n.tick_text([0.0, 0.2, 0.4, 1.0], "um") == ["0 µm", "0.2 µm", "0.4 µm", "1.0 µm"]
    assert n.ticks(3, 3) == [3.0] and n.ticks(None, 1) == []
    assert n.legend_unit("mm", 0, 12.5) == ("mm", 1.0) and n.legend_unit("urad", 0, 1) == ("µrad", 1.0)
    for lo, hi in [(-0.0137, 0.0211), (0.3, 97.0), (-1e-6, 3e-6), (12, 18), (1e3, 7e5)]:
        vals = n.ticks(lo, hi)
        assert 3 <= len(vals) <= 11 and lo <= vals[0] and vals[-1] <= hi, (lo, hi, vals)
        step = vals[1] - vals[0]
        mantissa = step / 10 ** math.floor(math.log10(step))
        assert min(abs(mantissa - m) for m in (1, 2, 5, 10)) < 1e-6, (lo, hi, step)
        assert all(abs(v / step - round(v / step)) < 1e-6 for v in vals)


# -- properties ------------------------------------------------------------------------------

SWEEP = [s * 10.0**e for e in range(-9, 7) for s in (1.0, 1.37, 2.5, 4.99, 7.3)] + [1e6]
_NUM = re.compile(r"^([+\u2212]?\d+(?:\.(\d+))?)\s*(.*)$")


def _read(text: str) -> tuple[float, float, str]:
    """(value, half a unit of the last digit, unit) of a written number."""
    m = _NUM.match(text)
    assert m, text
    value = float(m.group(1).replace(M, "-"))
    half = 0.5 * 10.0 ** -len(m.group(2) or "")
    return value, half, m.group(3)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_no_exponent_and_the_value_reads_back(sign):
    to_mm = {"mm": 1.0, "µm": 1e-3}
    for x in SWEEP:
        v = sign * x
        for text, unit_of in [
            (n.length(v), "mm"),
            (n.length(v, unit="µm"), "µm"),
            (n.length(v, abs(v) / 50), "mm"),
            (n.deviation(v), "µm"),
            (n.uncertainty(x), None),
            (n.percent(v), "%"),
            (n.plain(v), ""),
            (n.angle(v), None),
        ]:
            assert "e" not in text.replace("µ", "").replace("not defined", ""), (v, text)
            assert "-" not in text, (v, text)
            value, half, unit = _read(text)
            if unit_of is None:
                unit_of = unit
            if unit == "%":
                got, want = value, v * 100
            elif unit in ("µrad",):
                got, want = value, v * 1e6
            elif unit == "°":
                got, want, half = value, math.degrees(v), half
                unit = "°"
            elif unit_of == "":
                got, want = value, v
            else:
                assert unit == unit_of, (v, text)
                got, want = value * to_mm[unit], (abs(v) if text == n.uncertainty(x) else v)
                half *= to_mm[unit]
            # half a last digit, and a relative slack for float printing
            assert abs(got - want) <= half * (1 + 1e-9) + 1e-12 * abs(want), (v, text)
            assert not re.match(r"^[+\u2212]0(\.0*)?(\s|$)", text), (v, text)  # no "−0.000"


def test_times_never_have_an_exponent_and_read_back():
    unit_s = {"ms": 1e-3, "s": 1.0, "min": 60.0, "h": 3600.0}
    for t in SWEEP:
        text = n.time(t)
        assert "e" not in text, text
        parts = re.findall(r"([\d.]+) (ms|s|min|h)", text)
        assert parts and "".join(f"{a} {b}" for a, b in parts).replace(" ", "") == text.replace(" ", "")
        total = sum(float(a) * unit_s[b] for a, b in parts)
        last_num, last_unit = parts[-1]
        dec = len(last_num.split(".")[1]) if "." in last_num else 0
        half = 0.5 * 10.0**-dec * unit_s[last_unit]
        assert abs(total - t) <= half * (1 + 1e-9), (t, text)
