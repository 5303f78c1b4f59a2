"""QIF 3.0 Results of a GD&T evaluation (``camcmm gdt evaluate … --qif results.qif``).

:func:`write_results` turns the evaluate JSON (:meth:`..evaluate.Evaluation.to_json` plus the
command's ``plugin`` provenance) and its :class:`..model.Plan` into one QIF document
(ISO 23952:2020 = ANSI/DMSC QIF 3.0-2018, schema QIFApplications/QIFDocument.xsd):

- ``Version``, ``Header`` (camcmm as the application), ``FileUnits`` (mm, degrees);
- ``DatumDefinitions`` (the plan's labels) and one ``DatumReferenceFrame`` per datum list;
- ``Product``: the part (``ModelNumber`` the plan's name);
- ``Features``: per plan feature its Definition (size, internal/external), Nominal (the
  plan's geometry, mm) and Item; its actual as a ``…FeatureMeasurement`` from the
  evaluation's ``features[].params`` (a feature not evaluated has no measurement);
- ``Characteristics``: per characteristic its Definition (``ToleranceValue`` of a zone, or
  ``Tolerance`` Max/Min deviations of a size, ``DefinedAsLimit`` false), Nominal (a size's
  ``TargetValue``) and Item; its actual as a ``…CharacteristicMeasurement`` with ``Status``
  and ``Value`` (mm) — see :data:`STATUS` and :data:`CHARACTERISTIC_ELEMENTS`;
- ``Results/MeasurementResults``: the provenance (camcmm version, plugin id and version,
  parameters, input hashes, times) as ``Attributes``, the measured points as
  ``MeasuredPointSets`` when given, the overall ``InspectionStatus``, and the actual part
  (``ActualComponent/SerialNumber`` = ``part``).

Every camcmm characteristic type has a QIF element; camcmm's numbers that QIF has no element
for (u, U, k, how u was obtained, the simple and the guarded verdict, a reason) are
``AttributeStr``/``AttributeD1`` entries of the measurement, named ``camcmm:…`` so a reader
tells them from the standard's. Identity constraints: the schema's keyrefs from
``FeatureItemId`` to ``FeatureItemIdKey`` report errors on the official samples too
(``../shared/data/qif3/SOURCE.txt``); the file uses the same constructs as those samples.
"""

from __future__ import annotations

import math
import os
import uuid
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError

from ..model import Plan
from .common import FILE_UNITS, NS, VERSION

#: camcmm characteristic type -> the QIF element stem (``<stem>CharacteristicDefinition`` …).
#: ``roundness`` is QIF's Circularity; ``profile`` (with datums) and ``surface-profile`` are
#: both SurfaceProfile, told apart by the datum frame; a diameter of a sphere is written as
#: SphericalDiameter (:func:`_element`).
CHARACTERISTIC_ELEMENTS: dict[str, str] = {
    "straightness": "Straightness",
    "flatness": "Flatness",
    "roundness": "Circularity",
    "cylindricity": "Cylindricity",
    "line-profile": "LineProfile",
    "surface-profile": "SurfaceProfile",
    "parallelism": "Parallelism",
    "perpendicularity": "Perpendicularity",
    "angularity": "Angularity",
    "position": "Position",
    "coaxiality": "Coaxiality",
    "concentricity": "Concentricity",
    "symmetry": "Symmetry",
    "profile": "SurfaceProfile",
    "circular-runout": "CircularRunout",
    "total-runout": "TotalRunout",
    "diameter": "Diameter",
    "width": "Width",
    "distance": "DistanceBetween",
}
#: Sizes: a tolerance as Max/Min deviations from a nominal (QIF ``Tolerance``), not a zone.
SIZES = ("diameter", "width", "distance")
#: camcmm's guarded verdict (ISO 14253-1) -> QIF ``CharacteristicStatusEnum``. "undecided"
#: (within the limits but not by the guard band U) is QIF's INDETERMINATE; the simple and
#: guarded verdicts themselves are kept as attributes.
STATUS = {"conform": "PASS", "not conform": "FAIL", "undecided": "INDETERMINATE", "not evaluated": "NOT_ANALYZED"}
#: camcmm feature type -> QIF feature element stem (a CAD ``face`` left free-form: OtherSurface).
FEATURE_ELEMENTS = {
    "plane": "Plane",
    "line": "Line",
    "point": "Point",
    "circle": "Circle",
    "cylinder": "Cylinder",
    "sphere": "Sphere",
    "cone": "Cone",
    "torus": "Torus",
    "face": "OtherSurface",
}
#: Prefix of the attributes camcmm adds (QIF has no element for them).
ATTR = "camcmm:"
_PRECEDENCE = ("PRIMARY", "SECONDARY", "TERTIARY")
#: The order of QIF's PrimaryUnitsType (a sequence) for the units written.
_UNIT_ORDER = ("AngularUnit", "LinearUnit")


def _num(x: Any) -> str:
    """A number as XML text: the shortest positional text that reads back to the same
    float (no exponent: QIF's values are xs:decimal, which has none)."""
    v = float(x)
    if not math.isfinite(v):
        raise InputError(f"qif: a non-finite number ({v}) cannot be written")
    return np.format_float_positional(v, unique=True, trim="-")


def _vec(v: Iterable[Any]) -> str:
    return " ".join(_num(x) for x in v)


def _unit(v: Iterable[Any]) -> str:
    a = np.asarray(list(v), float)
    n = float(np.linalg.norm(a))
    return _vec(a / n if n > 0 else a)


class _Doc:
    """The document being built: elements in the QIF namespace and the running id."""

    def __init__(self) -> None:
        ET.register_namespace("", NS)
        self.root = ET.Element(self.q("QIFDocument"), {"versionQIF": VERSION})
        self.last = 0

    @staticmethod
    def q(tag: str) -> str:
        return f"{{{NS}}}{tag}"

    def el(self, parent: ET.Element, tag: str, text: Any = None, **attrs: Any) -> ET.Element:
        e = ET.SubElement(parent, self.q(tag), {k: str(v) for k, v in attrs.items()})
        if text is not None:
            e.text = str(text)
        return e

    def new_id(self) -> int:
        self.last += 1
        return self.last

    def with_id(self, parent: ET.Element, tag: str) -> tuple[ET.Element, int]:
        i = self.new_id()
        return self.el(parent, tag, id=i), i

    def ids(self, parent: ET.Element, tag: str, ids: list[int]) -> ET.Element:
        e = self.el(parent, tag, n=len(ids))
        for i in ids:
            self.el(e, "Id", i)
        return e

    def attributes(self, parent: ET.Element, items: list[tuple[str, Any]]) -> None:
        """``Attributes``: numbers as AttributeD1, the rest as AttributeStr (None left out)."""
        items = [(k, v) for k, v in items if v is not None]
        if not items:
            return
        a = self.el(parent, "Attributes", n=len(items))
        for k, v in items:
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v)):
                self.el(a, "AttributeD1", name=k, value=_num(v))
            else:
                self.el(a, "AttributeStr", name=k, value=str(v))


def _camcmm_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("camcmm")
    except PackageNotFoundError:  # a source tree that is not installed
        return "unknown"


def _provenance_items(evaluation: Mapping[str, Any], provenance: Mapping[str, Any] | None) -> list[tuple[str, Any]]:
    """The measurement's provenance as (name, value): camcmm, the plugin, its parameters,
    the input files' hashes, the inputs and the times; ``provenance`` adds or overrides."""
    plug = evaluation.get("plugin") or {}
    items: dict[str, Any] = {f"{ATTR}version": _camcmm_version()}
    if plug:
        items[f"{ATTR}plugin"] = f"{plug.get('id', '')} {plug.get('version', '')}".strip()
        for k, v in sorted((plug.get("params") or {}).items()):
            items[f"{ATTR}param.{k}"] = v if isinstance(v, (int, float, str)) else str(v)
        for k, v in sorted((plug.get("input_hashes") or {}).items()):
            items[f"{ATTR}input_hash.{k}"] = str(v)
        for k in ("started", "finished"):
            if plug.get(k):
                items[f"{ATTR}{k}"] = str(plug[k])
    for k in ("plan", "cloud", "nominal"):
        if evaluation.get(k):
            items[f"{ATTR}{k}"] = str(evaluation[k])
    a = evaluation.get("alignment") or {}
    if a.get("method"):
        items[f"{ATTR}alignment"] = str(a["method"])
    for k, v in (provenance or {}).items():
        items[k if k.startswith(ATTR) else f"{ATTR}{k}"] = v if isinstance(v, (int, float, str)) else str(v)
    return list(items.items())


# ----------------------------------------------------------------------------- features
def _feature_definition(d: _Doc, parent: ET.Element, stem: str, nom: Mapping[str, Any], internal: bool) -> int:
    e, i = d.with_id(parent, f"{stem}FeatureDefinition")
    inex = "INTERNAL" if internal else "EXTERNAL"
    if stem in ("Circle", "Cylinder", "Sphere"):
        d.el(e, "InternalExternal", inex)
        d.el(e, "Diameter", _num(nom["diameter"]))
        if stem == "Cylinder" and nom.get("length") is not None:
            d.el(e, "Length", _num(nom["length"]))
    elif stem == "Cone":  # the diameter at the axis point, which is the apex
        d.el(e, "InternalExternal", inex)
        d.el(e, "Diameter", _num(0.0))
        d.el(e, "FullAngle", _num(nom["angle"]))
    elif stem == "Torus":
        d.el(e, "InternalExternal", inex)
        d.el(e, "MinorDiameter", _num(nom["minor_diameter"]))
        d.el(e, "MajorDiameter", _num(nom["major_diameter"]))
    return i


def _axis(d: _Doc, parent: ET.Element, point: Any, direction: Any) -> None:
    ax = d.el(parent, "Axis")
    d.el(ax, "AxisPoint", _vec(point))
    d.el(ax, "Direction", _unit(direction))


def _feature_geometry(d: _Doc, e: ET.Element, stem: str, p: Mapping[str, Any], measured: bool) -> None:
    """The geometry of a Nominal (plan) or Measurement (``params``) of one feature (mm)."""
    if stem == "Plane":
        d.el(e, "Location", _vec(p["point"]))
        d.el(e, "Normal", _unit(p["normal"]))
    elif stem == "Line":
        d.el(e, "Location", _vec(p["point"]))
        d.el(e, "Direction", _unit(p["direction"]))
        if p.get("length") is not None:
            d.el(e, "Length", _num(p["length"]))
        elif not measured:  # a nominal line needs a length; 0 says "not stated"
            d.el(e, "Length", _num(0.0))
    elif stem == "Point":
        d.el(e, "Location", _vec(p.get("point", p.get("centre", (0, 0, 0)))))
    elif stem == "Circle":
        d.el(e, "Location", _vec(p["centre"]))
        d.el(e, "Normal", _unit(p["normal"]))
        if measured:
            d.el(e, "Diameter", _num(p["diameter"]))
    elif stem == "Cylinder":
        _axis(d, e, p["point"], p["axis"])
        if measured:
            d.el(e, "Diameter", _num(p["diameter"]))
            if p.get("length") is not None:
                d.el(e, "Length", _num(p["length"]))
    elif stem == "Sphere":
        d.el(e, "Location", _vec(p["centre"]))
        if measured:
            d.el(e, "Diameter", _num(p["diameter"]))
    elif stem == "Cone":
        _axis(d, e, p["apex"], p["axis"])
        if measured:
            d.el(e, "Diameter", _num(0.0))
            d.el(e, "FullAngle", _num(p["angle"]))
    elif stem == "Torus":
        d.el(e, "Location", _vec(p["centre"]))
        d.el(e, "AxisVector", _unit(p["axis"]))
        if measured:
            d.el(e, "MinorDiameter", _num(p["minor_diameter"]))
            d.el(e, "MajorDiameter", _num(p["major_diameter"]))


# ----------------------------------------------------------------------------- writer
def _element(ctype: str, feature_type: str) -> str:
    stem = CHARACTERISTIC_ELEMENTS.get(ctype)
    if stem is None:
        raise InputError(f"qif: characteristic type {ctype!r} has no QIF element")
    if ctype == "diameter" and feature_type == "sphere":
        return "SphericalDiameter"
    return stem


def _overall(statuses: list[str]) -> str:
    """QIF ``InspectionStatusEnum`` of the part: FAIL if any characteristic fails, UNKNOWN
    if any is undecided, NOT_CALCULATED if any was not evaluated, else PASS."""
    for s, overall in (("FAIL", "FAIL"), ("INDETERMINATE", "UNKNOWN"), ("NOT_ANALYZED", "NOT_CALCULATED")):
        if s in statuses:
            return overall
    return "PASS"


def build(
    evaluation: Mapping[str, Any],
    plan: Plan,
    *,
    part: str = "",
    provenance: Mapping[str, Any] | None = None,
    points: Mapping[str, Any] | None = None,
) -> ET.ElementTree:
    """The QIF Results document of :func:`write_results` as an element tree."""
    d = _Doc()
    root = d.root
    d.el(root, "QPId", str(uuid.uuid4()))
    ver = d.el(root, "Version")
    d.el(ver, "TimeCreated", datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"))
    app = d.el(d.el(root, "Header"), "Application")
    d.el(app, "Name", f"camcmm {_camcmm_version()}")
    d.el(app, "Organization", "camcmm")
    sd, std_id = d.with_id(d.el(root, "StandardsDefinitions", n=1), "Standard")
    d.el(d.el(sd, "Organization"), "StandardsOrganizationEnum", "ISO")
    d.el(sd, "Designator", "1101")
    d.el(sd, "Year", "2017")
    units = d.el(d.el(root, "FileUnits"), "PrimaryUnits")
    # PrimaryUnitsType is a sequence: AngularUnit comes before LinearUnit
    for tag, si, name, factor in sorted(FILE_UNITS, key=lambda u: _UNIT_ORDER.index(u[0])):
        u = d.el(units, tag)
        d.el(u, "SIUnitName", si)
        d.el(u, "UnitName", name)
        d.el(d.el(u, "UnitConversion"), "Factor", _num(factor))

    chars = list(evaluation.get("characteristics") or [])
    feats = {f["id"]: f for f in evaluation.get("features") or []}

    # datums and their frames (one per distinct datum list, in first use order)
    datum_ids: dict[str, int] = {}
    labels = list(plan.datums) + [lab for c in chars for lab in c.get("datums") or [] if lab not in plan.datums]
    if labels:
        dd = d.el(root, "DatumDefinitions", n=len(dict.fromkeys(labels)))
        for lab in dict.fromkeys(labels):
            e, datum_ids[lab] = d.with_id(dd, "DatumDefinition")
            d.el(e, "DatumLabel", lab)
    frames: dict[tuple[str, ...], int] = {}
    lists = list(dict.fromkeys(tuple(c.get("datums") or ()) for c in chars if c.get("datums")))
    if lists:
        drfs = d.el(root, "DatumReferenceFrames", n=len(lists))
        for labs in lists:
            drf, frames[labs] = d.with_id(drfs, "DatumReferenceFrame")
            ds = d.el(drf, "Datums", n=len(labs))
            for j, lab in enumerate(labs):
                dt = d.el(ds, "Datum")
                sd = d.el(dt, "SimpleDatum")
                d.el(sd, "DatumDefinitionId", datum_ids[lab])
                d.el(sd, "MaterialModifier", "NONE")  # camcmm evaluates datums RMB
                d.el(sd, "ReferencedComponent", "ACTUAL")  # the datums of the measured part
                pr = d.el(dt, "Precedence")
                if j < len(_PRECEDENCE):
                    d.el(pr, "PrecedenceEnum", _PRECEDENCE[j])
                else:
                    d.el(pr, "OtherPrecedence", str(j + 1))

    product = d.el(root, "Product")
    pset = d.el(product, "PartSet", n=1)
    pe, _ = d.with_id(pset, "Part")
    plan_name = Path(plan.source).stem if plan.source else str(evaluation.get("plan") or "plan")
    d.el(pe, "ModelNumber", Path(plan_name).stem or "plan")

    # features: definitions, nominals, items (the plan's), measurements (the evaluation's)
    fdef, fnom, fitem = {}, {}, {}
    fx = d.el(root, "Features")
    defs = d.el(fx, "FeatureDefinitions", n=len(plan.features))
    noms = d.el(fx, "FeatureNominals", n=len(plan.features))
    items = d.el(fx, "FeatureItems", n=len(plan.features))
    for fid, spec in plan.features.items():
        stem = FEATURE_ELEMENTS[spec.type]
        internal = bool(spec.nominal.get("internal", False))
        fdef[fid] = _feature_definition(d, defs, stem, spec.nominal, internal)
        e, fnom[fid] = d.with_id(noms, f"{stem}FeatureNominal")
        d.el(e, "FeatureDefinitionId", fdef[fid])
        _feature_geometry(d, e, stem, spec.nominal, measured=False)
        e, fitem[fid] = d.with_id(items, f"{stem}FeatureItem")
        d.el(e, "FeatureNominalId", fnom[fid])
        d.el(e, "FeatureName", fid)
        d.el(d.el(d.el(d.el(e, "DeterminationMode"), "Checked"), "CheckDetails"), "Measured")

    # characteristics: definitions, nominals, items
    cdef, cnom, citem = {}, {}, {}
    cx = d.el(root, "Characteristics")
    d.el(cx, "FormalStandardId", std_id)
    defs = d.el(cx, "CharacteristicDefinitions", n=len(chars))
    noms = d.el(cx, "CharacteristicNominals", n=len(chars))
    items = d.el(cx, "CharacteristicItems", n=len(chars))
    for c in chars:
        ftype = plan.features[c["feature"]].type if c["feature"] in plan.features else ""
        stem = _element(c["type"], ftype)
        e, cdef[c["id"]] = d.with_id(defs, f"{stem}CharacteristicDefinition")
        if c["type"] in SIZES:
            t = d.el(e, "Tolerance")
            d.el(t, "MaxValue", _num(c.get("upper") if c.get("upper") is not None else 0.0))
            d.el(t, "MinValue", _num(c.get("lower") if c.get("lower") is not None else 0.0))
            d.el(t, "DefinedAsLimit", "false")
        else:
            d.el(e, "ToleranceValue", _num(c["tolerance"]))
            if c.get("datums"):
                d.el(e, "DatumReferenceFrameId", frames[tuple(c["datums"])])
            _zone(d, e, c, ftype, _spec(c, plan))
        e, cnom[c["id"]] = d.with_id(noms, f"{stem}CharacteristicNominal")
        d.el(e, "CharacteristicDefinitionId", cdef[c["id"]])
        target = (c.get("details") or {}).get("nominal")
        if c["type"] in SIZES and target is not None:
            d.el(e, "TargetValue", _num(target))
        if stem == "LineProfile":  # the normal of the section planes
            d.el(e, "Vector", _unit(_section_normal(plan, c)))
        elif stem == "DistanceBetween":  # camcmm's distance is the 3-D distance
            d.el(e, "AnalysisMode", "THREEDIMENSIONAL")
        e, citem[c["id"]] = d.with_id(items, f"{stem}CharacteristicItem")
        d.el(e, "Name", c["id"])
        fids = [c["feature"], *[f for f in _others(c, plan) if f in fitem]]
        d.ids(e, "FeatureItemIds", [fitem[f] for f in fids if f in fitem])
        d.el(e, "CharacteristicNominalId", cnom[c["id"]])

    # results
    res = d.el(root, "Results")
    mrs = d.el(res, "MeasurementResultsSet", n=1)
    mr, _ = d.with_id(mrs, "MeasurementResults")
    d.attributes(mr, _provenance_items(evaluation, provenance))
    fmeas: dict[str, int] = {}
    measured = [fid for fid in plan.features if (feats.get(fid) or {}).get("params")]
    point_sets: dict[str, np.ndarray] = {}
    for fid, pts in (points or {}).items():
        a = np.asarray(pts, float).reshape(-1, 3)
        if fid in plan.features and len(a):
            point_sets[fid] = a
    set_ids = {fid: d.new_id() for fid in point_sets}
    if measured:
        mf = d.el(mr, "MeasuredFeatures", n=len(measured))
        for fid in measured:
            stem = FEATURE_ELEMENTS[plan.features[fid].type]
            e, fmeas[fid] = d.with_id(mf, f"{stem}FeatureMeasurement")
            d.el(e, "FeatureItemId", fitem[fid])
            if fid in set_ids:
                d.el(d.el(e, "PointList", n=1), "WholePointSetId", set_ids[fid])
            try:
                _feature_geometry(d, e, stem, feats[fid]["params"], measured=True)
            except KeyError as exc:  # an evaluation JSON edited by hand or of another version
                raise InputError(f"qif: features.{fid}.params: no {exc.args[0]!r} for a {stem.lower()}") from None
    if point_sets:
        ps = d.el(mr, "MeasuredPointSets", n=len(point_sets))
        for fid, a in point_sets.items():
            e = d.el(ps, "MeasuredPointSet", id=set_ids[fid], count=len(a))
            d.el(e, "Points", " ".join(_vec(p) for p in a))
            d.el(e, "Compensated", "false")  # surface points as the scanner gave them
    statuses = []
    if chars:
        mc = d.el(d.el(mr, "MeasuredCharacteristics"), "CharacteristicMeasurements", n=len(chars))
        for c in chars:
            ftype = plan.features[c["feature"]].type if c["feature"] in plan.features else ""
            stem = _element(c["type"], ftype)
            e, _ = d.with_id(mc, f"{stem}CharacteristicMeasurement")
            status = STATUS.get(c["verdict_guarded"], "UNDEFINED")
            statuses.append(status)
            d.attributes(
                e,
                [
                    (f"{ATTR}verdict", c.get("verdict")),
                    (f"{ATTR}verdict_guarded", c.get("verdict_guarded")),
                    (f"{ATTR}u", c.get("u")),
                    (f"{ATTR}U", c.get("U")),
                    (f"{ATTR}k", c.get("k")),
                    (f"{ATTR}u_method", c.get("u_method") or None),
                    (f"{ATTR}reason", (c.get("details") or {}).get("reason")),
                ],
            )
            d.el(d.el(e, "Status"), "CharacteristicStatusEnum", status)
            d.el(e, "CharacteristicItemId", citem[c["id"]])
            fm = [fmeas[f] for f in [c["feature"], *_others(c, plan)] if f in fmeas]
            if fm:
                d.ids(e, "FeatureMeasurementIds", fm)
            if c.get("value") is not None:
                d.el(e, "Value", _num(c["value"]))
    d.el(d.el(mr, "InspectionStatus"), "InspectionStatusEnum", _overall(statuses))
    comp_id = d.new_id()
    d.ids(mr, "ActualComponentIds", [comp_id])
    acs = d.el(d.el(res, "ActualComponentSets", n=1), "ActualComponentSet", n=1)
    ac = d.el(acs, "ActualComponent", id=comp_id)
    if part:
        d.el(ac, "SerialNumber", part)
    d.el(d.el(ac, "Status"), "InspectionStatusEnum", _overall(statuses))
    root.set("idMax", str(d.last))
    ET.indent(root)
    return ET.ElementTree(root)


#: Features of size (ISO 14405-1): a material condition applies to them (else NONE).
_OF_SIZE = ("cylinder", "circle", "sphere")
#: Features whose orientation/position zone is a cylinder about an axis (diametrical).
_AXES = ("cylinder", "circle", "line", "cone")
_MODIFIERS = {"MMC": "MAXIMUM", "LMC": "LEAST", "RFS": "REGARDLESS"}
#: Which elements take a material condition and which zone shape, after the schema
#: (Characteristics.xsd): position, orientation, straightness.
_WITH_CONDITION = ("Position", "Perpendicularity", "Parallelism", "Angularity", "Straightness")


def _zone(d: _Doc, e: ET.Element, c: Mapping[str, Any], ftype: str, spec: Any) -> None:
    """``MaterialCondition`` and ``ZoneShape`` of a geometric definition, where the schema
    asks for them: the plan's modifier (camcmm evaluates RFS and says so), the zone
    diametrical about an axis, spherical about a centre, planar otherwise."""
    stem = e.tag.split("}")[-1].removesuffix("CharacteristicDefinition")
    centre = ftype in ("sphere", "point")
    if stem in ("Coaxiality", "Concentricity"):  # a zone, no material condition
        d.el(d.el(e, "ZoneShape"), "SphericalZone" if centre and stem == "Concentricity" else "DiametricalZone")
        return
    if stem not in _WITH_CONDITION:
        return
    mod = (getattr(spec, "modifier", None) or "").upper()
    d.el(e, "MaterialCondition", _MODIFIERS.get(mod, "REGARDLESS" if ftype in _OF_SIZE else "NONE"))
    zs = d.el(e, "ZoneShape")
    if stem == "Position":
        d.el(
            zs,
            "SphericalZone"
            if ftype in ("sphere", "point")
            else "DiametricalZone"
            if ftype in _AXES
            else "NonDiametricalZone",
        )
    elif stem == "Straightness":
        d.el(zs, "DiametricalZone" if ftype in _AXES else "NonDiametricalZone")
    else:
        d.el(zs, "DiametricalZone" if ftype in _AXES else "PlanarZone")


def _section_normal(plan: Plan, c: Mapping[str, Any]) -> Any:
    """A line profile's section-plane normal: the plan's ``direction`` option, else the
    feature's nominal normal, axis or direction, else z."""
    spec = _spec(c, plan)
    if spec is not None and spec.options.get("direction") is not None:
        return spec.options["direction"]
    nom = plan.features[c["feature"]].nominal if c["feature"] in plan.features else {}
    for key in ("normal", "axis", "direction"):
        if key in nom:
            return nom[key]
    return (0.0, 0.0, 1.0)


def _spec(c: Mapping[str, Any], plan: Plan) -> Any:
    return next((s for s in plan.characteristics if s.id == c["id"]), None)


def _others(c: Mapping[str, Any], plan: Plan) -> list[str]:
    """The further features a characteristic names in the plan (``other`` of a width,
    distance or symmetry, ``features``, ``to``), in order."""
    spec = _spec(c, plan)
    out: list[str] = []
    for key in ("other", "features", "to"):
        v = spec.options.get(key) if spec is not None else None
        if v:
            out += [str(x) for x in (v if isinstance(v, (list, tuple)) else [v]) if str(x) != c["feature"]]
    return list(dict.fromkeys(out))


def feature_points(points: Any, feature: Any, plan: Plan) -> dict[str, np.ndarray]:
    """Feature id -> its points, from an (N, 3) cloud (plan coordinates, mm) and the (N,)
    per-point index into ``plan.features`` the evaluation gives (-1: no feature; the
    aligned cloud's ``feature`` field)."""
    P = np.asarray(points, float)
    f = np.asarray(feature).astype(np.int64)
    return {fid: P[f == i] for i, fid in enumerate(plan.features) if np.any(f == i)}


def write_results(
    evaluation: Mapping[str, Any],
    plan: Plan,
    path: str | Path,
    *,
    part: str = "",
    provenance: Mapping[str, Any] | None = None,
    points: Mapping[str, Any] | None = None,
) -> Path:
    """Write the QIF 3.0 Results of ``evaluation`` (the evaluate JSON, mm) on ``plan`` to
    ``path``; ``part`` the measured part's name/serial number; ``provenance`` extra
    (name, value) items for the measurement's attributes; ``points`` feature id -> (n, 3)
    points (plan coordinates, mm) written as measured point sets. The document is built in
    memory first: a failure writes nothing. Returns the path."""
    tree = build(evaluation, plan, part=part, provenance=provenance, points=points)
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{p}: is a folder (--qif expects a file)")
    tmp = p.with_name(f".{p.name}.partial")  # then renamed: a failed write leaves no half file
    try:
        tree.write(tmp, encoding="UTF-8", xml_declaration=True)
        os.replace(tmp, p)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError(f"{p}: cannot be written ({exc.strerror or exc})") from None
    return p
