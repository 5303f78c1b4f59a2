"""capability.summarise (issue 28) on batch documents built here, every figure against a
direct computation: numpy for mean, s, Cp, Cpk, the moving ranges and the subgroup
statistics; scipy.stats.chi2 for Cp's interval and scipy.stats.norm for Bissell's; the
tabulated control-chart constants (Montgomery, Introduction to Statistical Quality
Control, Appendix VI: A₃, B₃, B₄, c₄) for the X̄/s chart."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from camcmm_plugins.gdt.capability import c4, summarise

Z95 = 1.959963984540054  # the standard normal's 0.975 quantile


def _char(cid, value, *, tolerance=None, lower=None, upper=None, nominal=None, verdict=None, guarded=None):
    """One characteristic of an evaluate JSON: a zone (tolerance) or a size (lower/upper
    about ``nominal``); the verdicts as the simple rule gives them unless stated."""
    if verdict is None and value is not None:
        if tolerance is not None:
            verdict = "conform" if value <= tolerance else "not conform"
        else:
            dev = value - nominal
            ok = (lower is None or dev >= lower) and (upper is None or dev <= upper)
            verdict = "conform" if ok else "not conform"
    return {
        "id": cid,
        "type": "flatness" if tolerance is not None else "diameter",
        "feature": "F",
        "datums": [],
        "value": value,
        "unit": "mm",
        "tolerance": tolerance,
        "lower": lower,
        "upper": upper,
        "U": 0.001,
        "verdict": verdict or "not evaluated",
        "verdict_guarded": guarded or verdict or "not evaluated",
        "details": {} if nominal is None else {"nominal": nominal},
    }


def _batch(columns, status=None):
    """A batch of parts p01… whose characteristic ``cid`` takes ``columns[cid][i]`` (a dict
    of _char keyword arguments per id: {'values': [...], ...})."""
    n = len(next(iter(columns.values()))["values"])
    parts = []
    for i in range(n):
        chars = []
        for cid, spec in columns.items():
            kw = {k: v for k, v in spec.items() if k not in ("values", "guarded")}
            guarded = (spec.get("guarded") or {}).get(i)
            chars.append(_char(cid, spec["values"][i], guarded=guarded, **kw))
        state = (status or {}).get(i, "evaluated")
        parts.append({"part": f"p{i + 1:02d}", "status": state, "evaluation": {"characteristics": chars}})
    return {"parts": parts}


def _by_id(summary):
    return {s["id"]: s for s in summary}


FLAT = [0.021, 0.025, 0.019, 0.032, 0.027, 0.048, 0.023, 0.056, 0.026, 0.022]
DIA = [10.004, 9.998, 10.001, 10.006, 9.995, 10.002, 10.000, 10.003, 9.997, 10.004]


def test_zone_and_size_against_direct_computation():
    doc = _batch(
        {
            "flat": {"values": FLAT, "tolerance": 0.05, "guarded": {5: "undecided", 7: "not conform"}},
            "dia": {"values": DIA, "lower": -0.01, "upper": 0.01, "nominal": 10.0},
        }
    )
    s = _by_id(summarise(doc))
    assert list(s) == ["flat", "dia"]
    # the zone: one-sided (natural bound 0), no Cp
    f, x = s["flat"], np.array(FLAT)
    n, mean, sd = len(x), x.mean(), x.std(ddof=1)
    assert f["n"] == 10 and f["mean"] == pytest.approx(mean, rel=1e-12) and f["s"] == pytest.approx(sd, rel=1e-12)
    assert f["limits"] == {"kind": "zone", "lsl": None, "usl": 0.05, "bound": 0.0, "nominal": None}
    assert f["cp"] is None and f["cp_ci"] is None and any("Cp not defined" in t for t in f["notes"])
    cpk = (0.05 - mean) / (3 * sd)
    assert f["cpk"] == pytest.approx(cpk, rel=1e-12)
    half = Z95 * math.sqrt(1 / (9 * n) + cpk**2 / (2 * (n - 1)))
    assert f["cpk_ci"] == pytest.approx([cpk - half, cpk + half], rel=1e-9)
    assert f["out"] == ["p08"] and f["undecided"] == ["p06"]  # 0.056 > 0.05; the stated guarded verdict
    # individuals / moving range
    mr = np.abs(np.diff(x)).mean()
    ctl = f["control"]
    assert ctl["kind"] == "individuals"
    assert ctl["centre"] == pytest.approx(mean, rel=1e-12) and ctl["mr_bar"] == pytest.approx(mr, rel=1e-12)
    assert ctl["ucl"] == pytest.approx(mean + 2.66 * mr, rel=1e-12)
    assert ctl["mr_ucl"] == pytest.approx(3.267 * mr, rel=1e-12)
    assert mean - 2.66 * mr < 0 and ctl["lcl"] is None  # below the natural bound: none, said
    assert any("below the natural bound 0" in t for t in f["notes"])
    assert ctl["beyond"] == [p for p, v in zip([f"p{i + 1:02d}" for i in range(n)], x) if v > mean + 2.66 * mr]
    # the size: two-sided, Cp with its chi-square interval
    d, y = s["dia"], np.array(DIA)
    mean, sd = y.mean(), y.std(ddof=1)
    assert d["limits"]["kind"] == "size"
    assert (d["limits"]["lsl"], d["limits"]["usl"]) == pytest.approx((9.99, 10.01), abs=1e-12)
    cp = 0.02 / (6 * sd)
    assert d["cp"] == pytest.approx(cp, rel=1e-9)
    lo = cp * math.sqrt(stats.chi2.ppf(0.025, n - 1) / (n - 1))
    hi = cp * math.sqrt(stats.chi2.ppf(0.975, n - 1) / (n - 1))
    assert d["cp_ci"] == pytest.approx([lo, hi], rel=1e-9)
    # the table's chi-square quantiles for 9 degrees of freedom: 2.700 and 19.023
    assert d["cp_ci"] == pytest.approx([cp * math.sqrt(2.700 / 9), cp * math.sqrt(19.023 / 9)], rel=2e-4)
    cpk = min(10.01 - mean, mean - 9.99) / (3 * sd)
    assert d["cpk"] == pytest.approx(cpk, rel=1e-9) and d["cpk"] < d["cp"]
    half = Z95 * math.sqrt(1 / (9 * n) + cpk**2 / (2 * (n - 1)))
    assert d["cpk_ci"] == pytest.approx([cpk - half, cpk + half], rel=1e-9)
    mr = np.abs(np.diff(y)).mean()
    assert d["control"]["lcl"] == pytest.approx(mean - 2.66 * mr, rel=1e-12)  # a size has no bound
    assert d["out"] == [] and d["undecided"] == []
    assert [p["value"] for p in d["points"]] == DIA  # the run chart's points, in order


def test_confidence_level_and_a_point_beyond_the_control_limits():
    x = [10.0, 10.1, 10.0, 10.1, 10.0, 10.1, 10.0, 10.1, 10.0, 12.0]
    s = summarise(_batch({"d": {"values": x, "lower": -5, "upper": 5, "nominal": 10.0}}), confidence=0.9)[0]
    a = np.array(x)
    ucl = a.mean() + 2.66 * np.abs(np.diff(a)).mean()
    assert s["control"]["ucl"] == pytest.approx(ucl, rel=1e-12) and s["control"]["beyond"] == ["p10"]
    n, cp = 10, 10 / (6 * a.std(ddof=1))
    assert s["confidence"] == 0.9
    assert s["cp_ci"][0] == pytest.approx(cp * math.sqrt(stats.chi2.ppf(0.05, n - 1) / (n - 1)), rel=1e-9)
    z = stats.norm.ppf(0.95)
    half = z * math.sqrt(1 / (9 * n) + s["cpk"] ** 2 / (2 * (n - 1)))
    assert s["cpk_ci"][1] - s["cpk"] == pytest.approx(half, rel=1e-9)


@pytest.mark.parametrize(
    "m, a3, b3, b4, c4_table",
    [(3, 1.954, 0.0, 2.568, 0.8862), (5, 1.427, 0.0, 2.089, 0.9400), (6, 1.287, 0.030, 1.970, 0.9515)],
)
def test_xbar_s_chart_of_subgroups(m, a3, b3, b4, c4_table):
    rng = np.random.default_rng(m)
    x = list(10 + 0.003 * rng.standard_normal(4 * m + 2))  # four subgroups and two left over
    s = summarise(_batch({"d": {"values": x, "lower": -0.01, "upper": 0.01, "nominal": 10.0}}), subgroup=m)[0]
    ctl = s["control"]
    g = np.array(x[: 4 * m]).reshape(4, m)
    means, sds = g.mean(axis=1), g.std(axis=1, ddof=1)
    assert ctl["kind"] == "xbar-s" and ctl["m"] == m and len(ctl["subgroups"]) == 4
    assert ctl["centre"] == pytest.approx(means.mean(), rel=1e-12)
    assert ctl["s_bar"] == pytest.approx(sds.mean(), rel=1e-12)
    assert c4(m) == pytest.approx(c4_table, abs=5e-5)
    assert ctl["ucl"] == pytest.approx(means.mean() + a3 * sds.mean(), abs=1e-3 * sds.mean())
    assert ctl["lcl"] == pytest.approx(means.mean() - a3 * sds.mean(), abs=1e-3 * sds.mean())
    assert ctl["s_ucl"] == pytest.approx(b4 * sds.mean(), abs=1e-3 * sds.mean())
    assert ctl["s_lcl"] == pytest.approx(b3 * sds.mean(), abs=1e-3 * sds.mean())
    assert ctl["subgroups"][1]["parts"] == [f"p{i + 1:02d}" for i in range(m, 2 * m)]
    assert any("left out of the chart" in t for t in s["notes"])
    # capability is over every value, not the subgroups
    assert s["n"] == 4 * m + 2 and s["s"] == pytest.approx(np.std(x, ddof=1), rel=1e-12)


def test_failed_and_missing_parts_and_degenerate_figures():
    values = [0.02, None, 0.03, 0.04, 0.10]
    doc = _batch({"z": {"values": values, "tolerance": 0.05}}, status={4: "failed"})
    s = summarise(doc)[0]
    # p05 failed: not counted, even with a value; p02 without a value is named
    assert s["n"] == 3 and s["mean"] == pytest.approx(0.03, rel=1e-12) and s["not_evaluated"] == ["p02"]
    assert s["out"] == [] and [p["part"] for p in s["points"]] == ["p01", "p02", "p03", "p04"]
    # every value equal: s = 0, Cp/Cpk not defined, said
    s = summarise(_batch({"z": {"values": [0.02] * 4, "tolerance": 0.05}}))[0]
    assert s["s"] == 0 and s["cpk"] is None and any("s = 0" in t for t in s["notes"])
    # one value: no s
    s = summarise(_batch({"z": {"values": [0.02], "tolerance": 0.05}}))[0]
    assert s["s"] is None and s["cpk"] is None and s["control"] is None
    # a size with an upper limit only: one-sided
    s = summarise(_batch({"d": {"values": [1.0, 1.2, 1.1], "upper": 0.5, "nominal": 1.0}}))[0]
    sd = np.std([1.0, 1.2, 1.1], ddof=1)
    assert s["cp"] is None and s["cpk"] == pytest.approx((1.5 - 1.1) / (3 * sd), rel=1e-12)
    # no limits at all: no capability, said
    s = summarise(_batch({"d": {"values": [1.0, 1.2], "lower": None, "upper": None, "verdict": "conform"}}))[0]
    assert s["limits"]["kind"] == "none" and s["cpk"] is None and s["notes"]


def test_bad_options_refused():
    doc = _batch({"z": {"values": [0.02, 0.03], "tolerance": 0.05}})
    with pytest.raises(ValueError, match="confidence"):
        summarise(doc, confidence=1.0)
    with pytest.raises(ValueError, match="subgroup"):
        summarise(doc, subgroup=0)
