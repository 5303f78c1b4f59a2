"""Read back the QIF 3.0 Results camcmm writes (:mod:`.write`).

:func:`read_results` follows the document's ids: each ``…CharacteristicMeasurement`` ->
its ``CharacteristicItem`` (whose ``Name`` is the plan's characteristic id) -> its type
(the element's stem, e.g. ``Position``); each ``…FeatureMeasurement`` -> its
``FeatureItem`` (``FeatureName`` the plan's feature id). Lengths are converted to mm with
the file's ``FileUnits`` (:func:`.common.file_units`), so a re-read of a written file
gives the evaluation's values. The file is parsed safely (:func:`.common.parse`: no DTD,
size checked first); every refusal is one line naming the file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from camcmm.api import InputError

from .common import file_units, local, number, numbers, parse, tag
from .write import ATTR, STATUS

#: QIF status -> camcmm's guarded verdict (the inverse of :data:`.write.STATUS`).
VERDICTS = {v: k for k, v in STATUS.items()}


def _attributes(el: Any, where: str) -> dict[str, Any]:
    a = el.find(tag("Attributes"))
    out: dict[str, Any] = {}
    if a is None:
        return out
    for x in a:
        name = x.get("name") or ""
        value = x.get("value")
        out[name] = number(value, f"{where}: attribute {name}") if local(x.tag) == "AttributeD1" else value
    return out


def _camcmm(attrs: dict[str, Any]) -> dict[str, Any]:
    return {k.removeprefix(ATTR): v for k, v in attrs.items() if k.startswith(ATTR)}


def read_results(path: str | Path) -> dict[str, Any]:
    """The Results of a QIF file: ``characteristics`` {id: {``type`` (QIF element stem),
    ``value`` (mm; None when not reported), ``status`` (QIF CharacteristicStatusEnum),
    ``verdict_guarded`` (camcmm's, from the status), + camcmm's attributes ``verdict``,
    ``u``, ``U``, ``k``, ``u_method``, ``reason`` where written}}, ``features`` {id: {``type``,
    + the measured ``location``/``normal``/``axis_point``/``direction``/``diameter`` (mm)}},
    ``status`` (the part's InspectionStatusEnum), ``part`` (the actual component's
    serial number), ``provenance`` (the measurement's attributes), ``unit`` "mm". An item
    measured more than once (QIF allows it; camcmm writes one) keeps the first ``value``
    and lists them all in ``values``. A file without Results is refused."""
    p = Path(path)
    name = p.name
    root = parse(p)
    units = file_units(root, name)
    mm = units.mm_factor()
    by_id: dict[str, Any] = {}
    for el in root.iter():
        i = el.get("id")
        if i is not None:
            by_id[i] = el
    results = root.find(f"{tag('Results')}/{tag('MeasurementResultsSet')}/{tag('MeasurementResults')}")
    if results is None:
        raise InputError(f"{name}: no Results/MeasurementResultsSet/MeasurementResults (not a QIF Results file)")

    features: dict[str, dict[str, Any]] = {}
    mf = results.find(tag("MeasuredFeatures"))
    for m in [] if mf is None else list(mf):
        item = by_id.get((m.findtext(tag("FeatureItemId")) or "").strip())
        fid = (item.findtext(tag("FeatureName")) or "").strip() if item is not None else ""
        if not fid:
            raise InputError(f"{name}: {local(m.tag)} id {m.get('id')}: its FeatureItemId names no feature item")
        f: dict[str, Any] = {"type": local(m.tag).removesuffix("FeatureMeasurement")}
        for key, path_ in (("location", "Location"), ("normal", "Normal"), ("direction", "Direction"),
                           ("axis_point", f"{tag('Axis')}/{tag('AxisPoint')}"),
                           ("axis", f"{tag('Axis')}/{tag('Direction')}")):  # fmt: skip
            e = m.find(path_ if "/" in path_ else tag(path_))
            if e is not None and e.text:
                v = numbers(e.text, 3, f"{name}: {fid}.{key}")
                f[key] = [x * mm for x in v] if key in ("location", "axis_point") else v
        for key, tg in (("diameter", "Diameter"), ("length", "Length")):
            e = m.find(tag(tg))
            if e is not None and e.text:
                f[key] = units.mm(e, f"{fid}.{tg}")
        features[fid] = f

    chars: dict[str, dict[str, Any]] = {}
    cm = results.find(f"{tag('MeasuredCharacteristics')}/{tag('CharacteristicMeasurements')}")
    for m in [] if cm is None else list(cm):
        item = by_id.get((m.findtext(tag("CharacteristicItemId")) or "").strip())
        cid = (item.findtext(tag("Name")) or "").strip() if item is not None else ""
        if not cid:
            raise InputError(f"{name}: {local(m.tag)} id {m.get('id')}: its CharacteristicItemId names no item")
        status = (m.findtext(f"{tag('Status')}/{tag('CharacteristicStatusEnum')}") or "").strip()
        ve = m.find(tag("Value"))
        c: dict[str, Any] = {
            "type": local(m.tag).removesuffix("CharacteristicMeasurement"),
            "value": None if ve is None else units.mm(ve, f"{cid}.Value", pmi=True),
            "status": status,
            "verdict_guarded": VERDICTS.get(status, status),
        }
        c.update(_camcmm(_attributes(m, f"{name}: {cid}")))
        if cid in chars:  # QIF allows several measurements of one item: the first, and all values
            chars[cid].setdefault("values", [chars[cid]["value"]]).append(c["value"])
            continue
        chars[cid] = c

    serial = root.findtext(f".//{tag('ActualComponent')}/{tag('SerialNumber')}")
    return {
        "unit": "mm",
        "characteristics": chars,
        "features": features,
        "status": (results.findtext(f"{tag('InspectionStatus')}/{tag('InspectionStatusEnum')}") or "").strip(),
        "part": (serial or "").strip(),
        "provenance": _camcmm(_attributes(results, f"{name}: MeasurementResults")),
    }
