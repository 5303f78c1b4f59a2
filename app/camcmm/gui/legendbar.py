"""The colour legend of a 3-D view, written by the number rule (:mod:`camcmm.numbers`).

One place decides what a scalar bar says, for the server-rendered view (VTK draws it) and
the browser-drawn one (:func:`camcmm.gui.clientview.export.bar_legend` reads it back):

- the title in words with the unit people write: ``radial_deviation`` in mm ->
  ``"radial deviation [µm]"`` (a length field spanning less than 1 mm reads in µm, a
  deviation always does);
- ticks on round values (1, 2 or 5 × 10^k of the shown unit) written with one number of
  decimals, a real minus and ``0`` for zero; the scalars themselves stay in the field's
  unit (mm), only the labels are converted. VTK's own tick labels (a printf format, ASCII
  minus, the field's unit) are switched off and the ticks are the lookup table's
  annotations, which VTK draws at their values;
- a field of a few whole values — two at most, or up to :data:`MAX_CATEGORIES` integers
  such as fusion's ``source`` (0 photogrammetry, k the k-th CSI map) — is a set of labelled
  swatches (an indexed lookup table), not a ramp.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import numbers as num

#: a field of at most this many distinct whole values is shown as categories
MAX_CATEGORIES = 6
#: words for the values of known categorical fields
_CATEGORY_WORDS = {
    "source": lambda v: "photogrammetry" if v == 0 else f"CSI map {int(v)}",
}
#: field names that hold signed deviations (always µm when the field is in mm)
_DEVIATION = ("deviation", "residual", "distance", "error", "diff")
#: categorical colours (tab10's first ones: told apart in print and by most colour-blind eyes)
CATEGORY_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")


@dataclass
class Legend:
    """What a legend shows. ``ticks`` are in the field's own unit (where VTK places them),
    ``texts`` in the shown unit; ``categories`` ``[(value, text), …]`` for a categorical field
    (then ``ticks``/``texts`` are empty)."""

    title: str
    unit: str = ""
    factor: float = 1.0
    ticks: list[float] = field(default_factory=list)
    texts: list[str] = field(default_factory=list)
    categories: list[tuple[float, str]] = field(default_factory=list)


def categories(name: str, values: Any) -> list[tuple[float, str]]:
    """``[(value, words), …]`` when ``values`` is categorical (see the module), else ``[]``."""
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return []
    distinct = np.unique(v)
    whole = bool(np.all(distinct == np.round(distinct)))
    if len(distinct) > 2 and not (whole and len(distinct) <= MAX_CATEGORIES and name in _CATEGORY_WORDS):
        return []
    words = _CATEGORY_WORDS.get(name)
    out = []
    for x in distinct:
        text = words(float(x)) if words else f"{num.words(name)} {num.significant(x, 6)}"
        out.append((float(x), text))
    return out


def legend(name: str, unit: str, lo: float, hi: float, values: Any = None, n: int = 5) -> Legend:
    """The legend of field ``name`` (values in ``unit``) coloured over [lo, hi]."""
    cats = categories(name, values) if values is not None else []
    if cats:
        return Legend(num.words(name), categories=cats)
    shown, factor = num.legend_unit(unit, lo, hi)
    if num.unit_text(unit) == "mm" and any(s in name.lower() for s in _DEVIATION):
        shown, factor = num.MICRO, 1000.0
    ticks = num.ticks(lo * factor, hi * factor, n)
    return Legend(
        num.title(name, shown),
        shown,
        factor,
        [t / factor for t in ticks],
        num.tick_text(ticks),
    )


def value_text(spec: Legend, value: Any) -> str:
    """One value of the field as the legend reads it (a picked point): ``"radial deviation
    = +12.3 µm"``, ``"source = photogrammetry"``; ``value`` in the field's own unit."""
    name = spec.title.split(" [")[0]
    if not num.finite(value):
        return f"{name} = {num.UNDEFINED}"
    v = float(value)
    for x, text in spec.categories:
        if x == v:
            return f"{name} = {text}"
    # the field's own unit: mm when shown in mm, or in µm by a factor 1000; µm when shown as it is
    field_unit = "µm" if spec.unit == num.MICRO and spec.factor == 1.0 else "mm"
    if spec.unit in ("mm", num.MICRO):
        v_mm = v / 1000.0 if field_unit == "µm" else v
        return f"{name} = {num.length(v_mm, unit=spec.unit, signed=spec.unit == num.MICRO)}"
    text = num.plain(v * spec.factor, 4)
    return f"{name} = {text} {spec.unit}".rstrip()


def dress(bar: Any, spec: Legend) -> None:
    """Write ``spec`` onto a VTK scalar bar (``vtkScalarBarActor``) and its lookup table:
    the title, the round ticks as annotations (VTK's printf labels off), or, for categories,
    an indexed table of labelled swatches."""
    lut = bar.GetLookupTable()
    bar.SetTitle(spec.title)
    if lut is None:
        return
    lut.ResetAnnotations()
    if spec.categories:
        lut.IndexedLookupOn()
        lut.SetNumberOfTableValues(len(spec.categories))
        for i, (value, text) in enumerate(spec.categories):
            rgb = _rgb(CATEGORY_COLOURS[i % len(CATEGORY_COLOURS)])
            lut.SetTableValue(i, *rgb, 1.0)
            lut.SetAnnotation(float(value), text)
        lut.Build()
    else:
        for value, text in zip(spec.ticks, spec.texts):
            lut.SetAnnotation(float(value), text)
    _annotated(bar)


def _annotated(bar: Any) -> None:
    """Ticks drawn from the annotations only (VTK's printf labels write "-" and the raw unit)."""
    bar.SetDrawTickLabels(False)
    bar.SetDrawAnnotations(True)
    bar.SetDrawNanAnnotation(False)
    bar.SetAnnotationLeaderPadding(4)
    bar.SetFixedAnnotationLeaderLineColor(True)


def label(bar: Any, values: Any, unit: str = "") -> None:
    """Label a scalar bar's ticks at ``values`` (in the scalars' own unit) by the number
    rule (:func:`camcmm.numbers.tick_text`) as lookup-table annotations, VTK's printf tick
    labels off; a bar whose values are already in the shown unit (the Compare page's µm)."""
    lut = bar.GetLookupTable()
    if lut is None:
        return
    vals = [float(v) for v in values]
    lut.ResetAnnotations()
    for value, text in zip(vals, num.tick_text(vals, unit)):
        lut.SetAnnotation(value, text)
    _annotated(bar)


def lut_annotations(lut: Any) -> list[tuple[float, str]]:
    """The ``(value, text)`` annotations of a VTK lookup table (empty when none)."""
    out = []
    for i in range(int(lut.GetNumberOfAnnotatedValues() or 0)):
        value = lut.GetAnnotatedValue(i)
        try:
            x = float(value.ToDouble())
        except AttributeError:
            x = float(value)
        out.append((x, str(lut.GetAnnotation(i))))
    return out


def _rgb(hex_colour: str) -> tuple[float, float, float]:
    h = hex_colour.lstrip("#")
    return (int(h[0:2], 16) / 255.0, int(h[2:4], 16) / 255.0, int(h[4:6], 16) / 255.0)
