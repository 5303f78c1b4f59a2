"""A QIF 3.0 model-based definition into a camcmm GD&T plan: :func:`import_qif`.

What is read (element names of the QIF 3.0 schema, ``QIFLibrary/Features.xsd`` and
``Characteristics.xsd``), everything converted to mm and degrees from ``FileUnits``
(:mod:`.common`):

* **Feature nominals** with their definitions (``FeatureDefinitionId``): ``Plane``
  (Location, Normal), ``Cylinder`` and ``CylindricalSegment`` (Axis, definition's Diameter,
  Length, InternalExternal), ``Circle`` (Location, Normal, Diameter), ``Line`` (Location,
  Direction, Length), ``Point`` (Location), ``Sphere`` and ``SphericalSegment`` (Location,
  Diameter), ``Cone`` (Axis, the definition's Diameter at the axis point, HalfAngle or
  FullAngle, Small/LargeEndDistance → apex, axis into the cone, full angle), ``Torus``
  and ``ToroidalSegment`` (Location, AxisVector, Major/MinorDiameter). A pair of planes
  (``OppositeParallelPlanes``, ``OppositeAngledPlanes``: a width, a slot, a tab) becomes
  two plane features ``<id>-1`` and ``<id>-2`` from the two B-rep faces it names; a
  characteristic on the pair names the first as ``feature`` and the second as option
  ``other``. Anything else (a set of faces, ``OtherNonShape``) is skipped with the reason.
* **Extents**, what the evaluation selects points by: a plane's ``box`` from its own
  ``PolyLine`` (its boundary, QIF: "the extent and boundary of the plane"), else from the
  trimmed domain rectangles (``Plane23Core`` domainU × domainV) of its faces; a cylinder's
  start and length from its faces' ``Cylinder23`` (their axis extents projected onto the
  nominal axis), else the definition's ``Length`` from the axis point; a line its
  ``Length``; a cone the box of its two end circles (Small/LargeEndDistance). Boxes are
  padded by the feature's band along the surface normal. A feature without any of these
  is unlimited (the evaluation warns so).
* **Datums**: ``DatumDefinition`` (label → its feature nominal); a datum defined by datum
  targets, or on a feature not imported, is skipped. **Datum reference frames**: the
  labels in precedence order; a compound datum (``A-B``) becomes the common datum "A-B".
* **Characteristics** (nominal → definition): zone tolerances (``ToleranceValue``) and size
  limits (``Tolerance`` Min/MaxValue; ``DefinedAsLimit`` true: absolute limits less the
  target value), the frame, ``MaterialCondition`` (MMC/LMC: evaluated RFS by camcmm, it
  warns). Mapped: Diameter, SphericalDiameter → diameter; Flatness, Straightness,
  Circularity (roundness), Cylindricity, Parallelism, Perpendicularity, Angularity (with
  its angle), Position, Coaxiality, Concentricity, Symmetry, CircularRunout, TotalRunout,
  SurfaceProfile, LineProfile, Width, DistanceBetween. Skipped with the reason: the types
  camcmm does not evaluate (angle and radius sizes …), a characteristic on a feature or
  frame that was skipped, on several features (a pattern), a position of a width (camcmm
  locates a plane, not the median plane of two), a position whose zone is not diametral
  on an axis.

The report lists every imported item and every skipped one with its reason: nothing
is dropped silently. Reference: ANSI/DMSC QIF 3.0-2018 (ISO 23952:2020).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError

from ..plan import DEFAULT_BAND_MM
from .common import Units, file_units, id_map, ids, local, number, numbers, parse, tag

#: QIF characteristic stem -> camcmm characteristic type.
CHARACTERISTIC_TYPES: dict[str, str] = {
    "Diameter": "diameter",
    "SphericalDiameter": "diameter",
    "Flatness": "flatness",
    "Straightness": "straightness",
    "Circularity": "roundness",
    "Cylindricity": "cylindricity",
    "Parallelism": "parallelism",
    "Perpendicularity": "perpendicularity",
    "Angularity": "angularity",
    "Position": "position",
    "Coaxiality": "coaxiality",
    "Concentricity": "concentricity",
    "Symmetry": "symmetry",
    "CircularRunout": "circular-runout",
    "TotalRunout": "total-runout",
    "SurfaceProfile": "surface-profile",
    "LineProfile": "line-profile",
    "Width": "width",
    "DistanceBetween": "distance",
}
#: Why a QIF characteristic type is not imported.
NOT_EVALUATED = {
    "Angle": "an angle size (degrees between two features) is not a camcmm characteristic",
    "AngleBetween": "an angle between two features is not a camcmm characteristic",
    "AngleFromTo": "an angle between two features is not a camcmm characteristic",
    "Radius": "a radius size is not a camcmm characteristic (camcmm evaluates the diameter)",
    "SphericalRadius": "a radius size is not a camcmm characteristic (camcmm evaluates the diameter)",
}
_PAIRS = ("OppositeParallelPlanes", "OppositeAngledPlanes")
_MATERIAL = {"MAXIMUM": "MMC", "LEAST": "LMC"}


def _v(x: Any) -> list[float]:
    return [float(c) for c in np.asarray(x, dtype=float)]


def _rounded(x: Any) -> Any:
    """Numbers rounded to 1e-9 (mm, or unit-vector components): the files' values carry
    binary noise (174.999999999999, 35.0000000000002) far below any instrument's."""
    if isinstance(x, float):
        return round(x, 9) + 0.0  # + 0.0: no -0.0 in the plan
    if isinstance(x, list):
        return [_rounded(v) for v in x]
    if isinstance(x, dict):
        return {k: _rounded(v) for k, v in x.items()}
    return x


def _unit(v: np.ndarray, where: str) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if not n > 0:
        raise InputError(f"{where}: a direction of zero length")
    return v / n


class Skip(Exception):
    """An item not imported; the message is the reason."""


class _Reader:
    def __init__(self, path: Path) -> None:
        self.name = path.name
        self.root = parse(path)
        self.units: Units = file_units(self.root, self.name)
        self.ids = id_map(self.root, self.name)
        self.band = DEFAULT_BAND_MM
        self.features: dict[str, dict[str, Any]] = {}
        self.by_qif: dict[str, tuple[str, ...]] = {}  # QIF feature nominal id -> plan feature ids
        self.feature_ids: dict[str, str] = {}  # plan feature id -> QIF id
        self.datums: dict[str, str] = {}  # label -> plan feature id
        self.datum_defs: dict[str, str] = {}  # QIF DatumDefinition id -> label
        self.chars: list[dict[str, Any]] = []
        self.skipped: list[dict[str, str]] = []
        self.imported: list[dict[str, Any]] = []
        self.notes: list[str] = []
        self.why: dict[str, str] = {}  # QIF feature id -> why it was skipped
        self.char_qif: dict[str, str] = {}  # plan characteristic id -> QIF characteristic nominal id

    # ---------------------------------------------------------------- helpers
    def at(self, el: ET.Element, what: str = "") -> str:
        """Where an element is, for a refusal: ``Tag id N.what``."""
        i = el.get("id")
        return f"{local(el.tag)}{f' id {i}' if i else ''}{f'.{what}' if what else ''}"

    def where(self, el: ET.Element, what: str = "") -> str:
        return f"{self.name}: {self.at(el, what)}"

    def child(self, el: ET.Element | None, *path: str) -> ET.Element | None:
        for p in path:
            if el is None:
                return None
            el = el.find(tag(p))
        return el

    def point(self, el: ET.Element, what: str) -> np.ndarray:
        f = self.units.linear_factor(el.get("linearUnit"), False, self.at(el))
        return np.array(numbers(el.text, 3, self.where(el))) * f

    def direction(self, el: ET.Element, what: str) -> np.ndarray:
        return _unit(np.array(numbers(el.text, 3, self.where(el))), self.where(el))

    def need(self, el: ET.Element, *path: str) -> ET.Element:
        e = self.child(el, *path)
        if e is None:
            raise Skip(f"no {'/'.join(path)}")
        return e

    def length(self, el: ET.Element | None, what: str, pmi: bool = False) -> float | None:
        return None if el is None else self.units.mm(el, self.at(el), pmi)

    def lookup(self, i: str, what: str) -> ET.Element:
        el = self.ids.get(i)
        if el is None:
            raise InputError(f"{self.name}: {what}: id {i!r} refers to no element (broken reference)")
        return el

    def definition(self, nom: ET.Element) -> ET.Element:
        e = self.child(nom, "FeatureDefinitionId")
        if e is None:
            raise InputError(f"{self.where(nom, 'FeatureDefinitionId')}: missing")
        return self.lookup((e.text or "").strip(), f"{local(nom.tag)} id {nom.get('id')}.FeatureDefinitionId")

    def surfaces(self, nom: ET.Element) -> list[tuple[ET.Element, bool]]:
        """The B-rep surfaces of the nominal's faces (``EntityInternalIds``), each with
        the face's ``turned`` flag; faces not found are left out."""
        out = []
        for fid in ids(self.child(nom, "EntityInternalIds")):
            face = self.ids.get(fid)
            if face is None or local(face.tag) != "Face":
                continue
            sid = (face.findtext(f"{tag('Surface')}/{tag('Id')}") or "").strip()
            surf = self.ids.get(sid)
            if surf is not None:
                out.append((surf, face.get("turned") == "true"))
        return out

    def pad(self, lo: np.ndarray, hi: np.ndarray, normal: np.ndarray | None) -> list[list[float]]:
        d = self.band * (np.abs(normal) if normal is not None else np.ones(3))
        return [_v(lo - d), _v(hi + d)]

    # ---------------------------------------------------------------- features
    def plane_face(self, surf: ET.Element, turned: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """(point, outward normal, corners or None) of a ``Plane23`` face."""
        if local(surf.tag) != "Plane23":
            raise Skip(f"its face is a {local(surf.tag)}, not a plane")
        core = self.need(surf, "Plane23Core")
        o = self.point(self.need(core, "Origin"), "Origin")
        u = self.direction(self.need(core, "DirU"), "DirU")
        v = self.direction(self.need(core, "DirV"), "DirV")
        n = _unit(np.cross(u, v), self.where(core, "DirU x DirV"))
        if turned:
            n = -n
        corners = None
        du, dv = core.get("domainU"), core.get("domainV")
        if du and dv:
            f = self.units.mm_factor()
            (u0, u1), (v0, v1) = (
                numbers(du, 2, self.where(core, "domainU")),
                numbers(dv, 2, self.where(core, "domainV")),
            )
            corners = np.array([o + f * (a * u + b * v) for a in (u0, u1) for b in (v0, v1)])
        return o, n, corners

    def box_of(self, pts: np.ndarray, normal: np.ndarray | None) -> list[list[float]]:
        return self.pad(pts.min(axis=0), pts.max(axis=0), normal)

    def feature(self, nom: ET.Element) -> dict[str, dict[str, Any]]:
        kind = local(nom.tag).removesuffix("FeatureNominal")
        qid = nom.get("id") or "?"
        if kind in _PAIRS:
            faces = self.surfaces(nom)
            if len(faces) != 2:
                raise Skip(f"a pair of planes whose B-rep gives {len(faces)} face(s), not 2")
            defn = self.definition(nom)
            out = {}
            for j, (surf, turned) in enumerate(faces, 1):
                o, n, corners = self.plane_face(surf, turned)
                d: dict[str, Any] = {"type": "plane", "point": _v(o), "normal": _v(n)}
                if corners is not None:
                    d["box"] = self.box_of(corners, n)
                out[f"{'width' if kind == _PAIRS[0] else 'angled'}-{qid}-{j}"] = d
            ie = (defn.findtext(tag("InternalExternal")) or "").strip()
            if ie not in ("INTERNAL", "EXTERNAL", ""):
                self.notes.append(f"{qid}: InternalExternal {ie}")
            return out
        defn = self.definition(nom)
        internal = (defn.findtext(tag("InternalExternal")) or "").strip() == "INTERNAL"
        fid = f"{kind.lower()}-{qid}"
        d = {}
        if kind == "Plane":
            p = self.point(self.need(nom, "Location"), "Location")
            n = self.direction(self.need(nom, "Normal"), "Normal")
            d = {"type": "plane", "point": _v(p), "normal": _v(n)}
            poly = self.child(nom, "PolyLine")
            if poly is not None and (poly.text or "").split():
                vals = (poly.text or "").split()
                if len(vals) % 3:
                    raise InputError(f"{self.where(poly, 'PolyLine')}: {len(vals)} numbers, not triples")
                pts = np.array([number(s, self.where(poly, "PolyLine")) for s in vals]).reshape(-1, 3)
                d["box"] = self.box_of(pts * self.units.mm_factor(), n)
            else:
                rects = [self.plane_face(s, t)[2] for s, t in self.surfaces(nom) if local(s.tag) == "Plane23"]
                found = [c for c in rects if c is not None]
                if found:
                    d["box"] = self.box_of(np.vstack(found), n)
        elif kind in ("Cylinder", "CylindricalSegment"):
            p = self.point(self.need(nom, "Axis", "AxisPoint"), "Axis.AxisPoint")
            a = self.direction(self.need(nom, "Axis", "Direction"), "Axis.Direction")
            dia = self.length(self.need(defn, "Diameter"), "Diameter")
            d = {"type": "cylinder", "point": _v(p), "axis": _v(a), "diameter": dia}
            ts = []
            for surf, _ in self.surfaces(nom):
                core = self.child(surf, "Cylinder23Core")
                if local(surf.tag) != "Cylinder23" or core is None:
                    continue
                sp = self.point(self.need(core, "Axis", "AxisPoint"), "AxisPoint")
                sd = self.direction(self.need(core, "Axis", "Direction"), "Direction")
                sl = self.length(self.child(core, "Length"), "Length")
                if sl is not None:
                    ts += [float((sp - p) @ a), float((sp + sl * sd - p) @ a)]
            length = self.length(self.child(defn, "Length"), "Length")
            # the definition's Length from the axis point is the feature's own extent; the
            # faces' Cylinder23 surfaces are untrimmed (the NIST files pad them 10 % a side),
            # so they only decide when the own extent does not lie within them
            if length is not None and (not ts or (min(ts) - 1e-6 <= 0 and length <= max(ts) + 1e-6)):
                d["length"] = length
            elif ts:
                d["point"] = _v(p + min(ts) * a)
                d["length"] = max(ts) - min(ts)
                self.notes.append(f"{qid}: cylinder extent from its faces' surfaces (untrimmed)")
        elif kind == "Circle":
            c = self.point(self.need(nom, "Location"), "Location")
            n = self.direction(self.need(nom, "Normal"), "Normal")
            d = {"type": "circle", "centre": _v(c), "normal": _v(n)}
            d["diameter"] = self.length(self.need(defn, "Diameter"), "Diameter")
        elif kind in ("Sphere", "SphericalSegment"):
            c = self.point(self.need(nom, "Location"), "Location")
            d = {"type": "sphere", "centre": _v(c), "diameter": self.length(self.need(defn, "Diameter"), "Diameter")}
        elif kind == "Line":
            p = self.point(self.need(nom, "Location"), "Location")
            a = self.direction(self.need(nom, "Direction"), "Direction")
            d = {"type": "line", "point": _v(p), "direction": _v(a)}
            length = self.length(self.child(nom, "Length"), "Length")
            if length is not None:
                d["length"] = length
        elif kind == "Point":
            d = {"type": "point", "point": _v(self.point(self.need(nom, "Location"), "Location"))}
        elif kind == "Cone":
            d = self.cone(nom, defn)
        elif kind in ("Torus", "ToroidalSegment"):
            c = self.point(self.need(nom, "Location"), "Location")
            a = self.direction(self.need(nom, "AxisVector"), "AxisVector")
            d = {"type": "torus", "centre": _v(c), "axis": _v(a)}
            d["major_diameter"] = self.length(self.need(defn, "MajorDiameter"), "MajorDiameter")
            d["minor_diameter"] = self.length(self.need(defn, "MinorDiameter"), "MinorDiameter")
        else:
            n_faces = len(ids(self.child(nom, "EntityInternalIds")))
            raise Skip(
                f"an {kind} feature (a set of {n_faces} face(s)) has no nominal geometry camcmm can use"
                if kind == "OtherNonShape"
                else f"a {kind} feature is not a camcmm feature type"
            )
        for key in ("diameter", "length", "major_diameter", "minor_diameter"):
            if key in d and not d[key] > 0:
                raise InputError(f"{self.where(nom)}: {key} {d[key]!r} must be > 0")
        if internal and d["type"] in ("cylinder", "sphere", "cone", "torus", "circle"):
            d["internal"] = True
        return {fid: d}

    def cone(self, nom: ET.Element, defn: ET.Element) -> dict[str, Any]:
        p = self.point(self.need(nom, "Axis", "AxisPoint"), "Axis.AxisPoint")
        a = self.direction(self.need(nom, "Axis", "Direction"), "Axis.Direction")
        dia = self.length(self.need(defn, "Diameter"), "Diameter") or 0.0
        half_el, full_el = self.child(defn, "HalfAngle"), self.child(defn, "FullAngle")
        if half_el is not None:
            half = self.units.degrees(half_el, self.at(half_el))
        elif full_el is not None:
            half = 0.5 * self.units.degrees(full_el, self.at(full_el))
        else:
            raise Skip("a cone without HalfAngle or FullAngle")
        if not 0 < half < 90:
            raise InputError(f"{self.where(defn, 'HalfAngle')}: {half:g} degrees, not in (0, 90)")
        small = self.length(self.child(defn, "SmallEndDistance"), "SmallEndDistance")
        large = self.length(self.child(defn, "LargeEndDistance"), "LargeEndDistance")
        s = -1.0 if (small is not None and large is not None and large < small) else 1.0
        tan = math.tan(math.radians(half))
        apex = p - s * (0.5 * dia / tan) * a
        d: dict[str, Any] = {"type": "cone", "apex": _v(apex), "axis": _v(s * a), "angle": 2.0 * half}
        if small is not None and large is not None:  # the box of the two end circles
            ends = []
            for t in (small, large):
                c = p + t * a
                r = 0.5 * dia + s * (t * tan)
                ext = max(r, 0.0) * np.sqrt(np.clip(1.0 - a**2, 0.0, 1.0))
                ends += [c - ext, c + ext]
            e = np.array(ends)
            d["box"] = self.pad(e.min(axis=0), e.max(axis=0), None)
        return d

    def read_features(self) -> None:
        noms = self.child(self.root, "Features", "FeatureNominals")
        for nom in [] if noms is None else list(noms):
            qid = nom.get("id") or "?"
            try:
                new = self.feature(nom)
            except Skip as exc:
                self.skip(qid, f"feature {local(nom.tag)}: {exc}")
                self.why[qid] = str(exc)
                continue
            for fid, d in new.items():
                if fid in self.features:
                    raise InputError(f"{self.where(nom)}: feature {fid} twice")
                self.features[fid] = d
                self.feature_ids[fid] = qid
            self.by_qif[qid] = tuple(new)
            self.imported.append({"id": qid, "kind": "feature", "qif": local(nom.tag), "as": list(new)})

    # ---------------------------------------------------------------- datums
    def read_datums(self) -> None:
        defs = self.child(self.root, "DatumDefinitions")
        for dd in [] if defs is None else defs.findall(tag("DatumDefinition")):
            qid = dd.get("id") or "?"
            label = (dd.findtext(tag("DatumLabel")) or "").strip()
            if not label:
                raise InputError(f"{self.where(dd, 'DatumLabel')}: missing")
            if self.child(dd, "DatumTargetIds") is not None:
                self.skip(qid, f"datum {label}: defined by datum targets, which camcmm does not evaluate")
                continue
            fids = ids(self.child(dd, "FeatureNominalIds"))
            if len(fids) != 1:
                self.skip(qid, f"datum {label}: on {len(fids)} features; camcmm takes a datum on one feature")
                continue
            self.lookup(fids[0], f"DatumDefinition id {qid}.FeatureNominalIds")
            plan = self.by_qif.get(fids[0])
            if plan is None:
                self.skip(qid, f"datum {label}: its feature {fids[0]} was not imported")
                continue
            if len(plan) != 1:
                self.skip(qid, f"datum {label}: on a pair of planes (a width's median plane), not a camcmm datum")
                continue
            if label in self.datums:
                raise InputError(f"{self.where(dd, 'DatumLabel')}: label {label!r} defined twice")
            self.datums[label] = plan[0]
            self.datum_defs[qid] = label
            self.imported.append({"id": qid, "kind": "datum", "qif": "DatumDefinition", "as": label})

    def frame(self, drf_id: str, where: str) -> list[str]:
        """The labels of a ``DatumReferenceFrame`` in precedence order."""
        drf = self.lookup(drf_id, where)
        order = {"PRIMARY": 0, "SECONDARY": 1, "TERTIARY": 2}
        out: list[tuple[int, str]] = []
        for datum in drf.findall(f"{tag('Datums')}/{tag('Datum')}"):  # a CompoundDatum nests more
            prec = (datum.findtext(f"{tag('Precedence')}/{tag('PrecedenceEnum')}") or "").strip()
            simple = [s for s in datum if local(s.tag) in ("SimpleDatum", "CompoundDatum")]
            labels = []
            for s in simple:
                for ref in s.iter(tag("DatumDefinitionId")):
                    i = (ref.text or "").strip()
                    self.lookup(i, f"{where} -> DatumDefinitionId")
                    if i not in self.datum_defs:
                        raise Skip(f"its datum frame {drf_id} names datum {i}, which was not imported")
                    labels.append(self.datum_defs[i])
                mod = (s.findtext(tag("MaterialModifier")) or "NONE").strip()
                if mod not in ("NONE", "REGARDLESS"):
                    self.notes.append(f"datum frame {drf_id}: material modifier {mod} not applied (RFS)")
            if labels:
                out.append((order.get(prec, len(out)), "-".join(labels)))
        if not out:
            raise Skip(f"its datum frame {drf_id} names no datum")
        return [lab for _, lab in sorted(out)]

    # ---------------------------------------------------------------- characteristics
    def characteristic(self, nom: ET.Element) -> list[dict[str, Any]]:
        """The plan characteristic(s) of a QIF characteristic nominal: one, or one per
        feature of a pattern (``4X``: each feature meets the tolerance on its own, which is
        what a single-segment tolerance on a pattern requires evaluated RFS)."""
        stem = local(nom.tag).removesuffix("CharacteristicNominal")
        if stem in NOT_EVALUATED:
            raise Skip(NOT_EVALUATED[stem])
        ctype = CHARACTERISTIC_TYPES.get(stem)
        if ctype is None:
            raise Skip(f"a {stem} characteristic is not evaluated by camcmm")
        qid = nom.get("id") or "?"
        did = (nom.findtext(tag("CharacteristicDefinitionId")) or "").strip()
        if not did:
            raise InputError(f"{self.where(nom, 'CharacteristicDefinitionId')}: missing")
        defn = self.lookup(did, f"{local(nom.tag)} id {qid}.CharacteristicDefinitionId")
        fids = ids(self.child(nom, "FeatureNominalIds"))
        if not fids:
            raise Skip("on no feature nominal (FeatureNominalIds)")
        for f in fids:
            self.lookup(f, f"{local(nom.tag)} id {qid}.FeatureNominalIds")
        missing = [f for f in fids if f not in self.by_qif]
        if missing:
            raise Skip(f"its feature {missing[0]} was not imported ({self.why.get(missing[0], 'unknown')})")
        plan_fids = [p for f in fids for p in self.by_qif[f]]
        two = ctype in ("width", "symmetry", "distance")
        pattern = len(fids) > 1 and not two
        if pattern:
            if any(len(self.by_qif[f]) != 1 for f in fids):
                raise Skip(f"on a pattern of {len(fids)} features that are not all single surfaces")
            if len({self.features[p]["type"] for p in plan_fids}) != 1:
                raise Skip(f"on a pattern of {len(fids)} features of different types")
        pair = len(self.by_qif[fids[0]]) == 2
        c: dict[str, Any] = {"id": f"{ctype}-{qid}", "type": ctype, "feature": plan_fids[0]}
        if two or (pair and ctype == "position"):  # position of a pair: its median plane
            if len(plan_fids) != 2:
                raise Skip(f"a {ctype} needs two features, the QIF names {len(plan_fids)}")
            c["other"] = plan_fids[1]
        elif pair:
            raise Skip(f"a {ctype} of a pair of planes is not evaluated by camcmm")
        ftype = self.features[plan_fids[0]]["type"]
        if ctype == "diameter" and ftype not in ("cylinder", "circle", "sphere"):
            raise Skip(f"a diameter of a {ftype}")
        zone = self.child(defn, "ZoneShape")
        if ctype == "position" and ftype in ("cylinder", "line", "cone") and zone is not None:
            if not any(local(z.tag) == "DiametricalZone" for z in zone):
                raise Skip("position of an axis in a non-diametral zone; camcmm's axis zone is a cylinder")
        drf = (defn.findtext(tag("DatumReferenceFrameId")) or "").strip()
        if drf:
            c["datums"] = self.frame(drf, f"{local(defn.tag)} id {did}.DatumReferenceFrameId")
        tol = self.child(defn, "ToleranceValue")
        lim = self.child(defn, "Tolerance")
        if tol is not None:
            t = self.length(tol, "ToleranceValue", pmi=True)
            assert t is not None
            if not t > 0:
                raise InputError(f"{self.where(defn, 'ToleranceValue')}: must be > 0, got {tol.text!r}")
            c["tolerance"] = t
        elif lim is not None:
            lo_el, hi_el = self.child(lim, "MinValue"), self.child(lim, "MaxValue")
            lo, hi = self.length(lo_el, "MinValue", pmi=True), self.length(hi_el, "MaxValue", pmi=True)
            if (lim.findtext(tag("DefinedAsLimit")) or "").strip() == "true":
                target = self.length(self.child(nom, "TargetValue"), "TargetValue", pmi=True)
                if target is None:
                    raise Skip("limits defined as absolute values without a TargetValue")
                lo = None if lo is None else lo - target
                hi = None if hi is None else hi - target
            if lo is None and hi is None:
                raise Skip("a Tolerance without MinValue or MaxValue")
            if lo is not None and hi is not None and lo > hi:
                raise InputError(f"{self.where(defn, 'Tolerance')}: MinValue above MaxValue")
            if ctype not in ("diameter", "width", "distance"):
                raise Skip(f"a {ctype} with size limits instead of a tolerance zone")
            if lo is not None:
                c["lower"] = round(lo, 9)  # absolute limits less the target leave 1e-15 noise
            if hi is not None:
                c["upper"] = round(hi, 9)
            target = self.length(self.child(nom, "TargetValue"), "TargetValue", pmi=True)
            if target is not None:  # the limits are about the drawing's value, not the model's
                c["nominal"] = target
                dia = self.features[plan_fids[0]].get("diameter") if ctype == "diameter" else None
                if dia is not None and abs(dia - target) > 1e-6 * max(1.0, target):
                    self.notes.append(f"{qid}: target diameter {target:g} mm (the limits' reference), model {dia:g} mm")
        else:
            raise Skip("no ToleranceValue nor Tolerance (a reference or measured-only dimension)")
        if ctype == "angularity":
            ang = self.child(defn, "Angle")
            if ang is None:
                raise Skip("an angularity without its Angle")
            c["angle"] = self.units.degrees(ang, self.at(ang), pmi=True)
        mc = (defn.findtext(tag("MaterialCondition")) or "NONE").strip()
        if mc in _MATERIAL:
            c["modifier"] = _MATERIAL[mc]
        if ctype in ("parallelism", "perpendicularity", "angularity", "circular-runout", "total-runout"):
            if not c.get("datums"):
                raise Skip(f"a {ctype} without a datum reference frame")
        for extra in ("SecondCompositeSegmentProfileDefinition", "SecondCompositeSegmentPositionDefinition"):
            if self.child(defn, extra) is not None:
                self.notes.append(f"{qid}: the second segment of a composite tolerance is not imported")
        name = (nom.findtext(tag("Name")) or "").strip()
        if name:
            c["name"] = name
        if pattern:
            return [dict(c, id=f"{c['id']}-{k}", feature=f) for k, f in enumerate(plan_fids, 1)]
        return [c]

    def read_characteristics(self) -> None:
        noms = self.child(self.root, "Characteristics", "CharacteristicNominals")
        for nom in [] if noms is None else list(noms):
            qid = nom.get("id") or "?"
            try:
                cs = self.characteristic(nom)
            except Skip as exc:
                self.skip(qid, f"characteristic {local(nom.tag)}: {exc}")
                continue
            self.chars += cs
            for c in cs:
                self.char_qif[c["id"]] = qid
            as_ = cs[0]["id"] if len(cs) == 1 else [c["id"] for c in cs]
            self.imported.append({"id": qid, "kind": "characteristic", "qif": local(nom.tag), "as": as_})

    def skip(self, qid: str, reason: str) -> None:
        self.skipped.append({"id": qid, "reason": reason})

    # ---------------------------------------------------------------- result
    def run(self) -> tuple[dict[str, Any], dict[str, Any]]:
        self.read_features()
        if not self.features:  # before the datums, whose features would all be missing
            raise InputError(
                f"{self.name}: no feature nominal camcmm can use (Features/FeatureNominals"
                f"{': ' + self.skipped[0]['reason'] if self.skipped else ' is empty or missing'})"
            )
        self.read_datums()
        self.read_characteristics()
        doc: dict[str, Any] = {
            "unit": "mm",
            "band": self.band,
            "features": _rounded(self.features),
            "datums": dict(self.datums),
            "characteristics": _rounded(self.chars),
            "qif": {
                "file": self.name,
                "unit": self.units.name,
                "features": dict(self.feature_ids),
                "characteristics": dict(self.char_qif),
            },
        }
        unlimited = [
            fid
            for fid, d in self.features.items()
            if "box" not in d and "length" not in d and d["type"] in ("plane", "cylinder", "line", "cone")
        ]
        report = {
            "file": self.name,
            "unit": self.units.name,
            "features": len(self.features),
            "datums": len(self.datums),
            "characteristics": len(self.chars),
            "skipped": self.skipped,
            "imported": self.imported,
            "unlimited": unlimited,
            "notes": self.notes,
        }
        return doc, report


def import_qif(path: str | Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """Read the QIF 3.0 model-based definition ``path`` into a plan document (the YAML
    of docs/gdt.md, lengths in mm) and a report: ``features``, ``datums``,
    ``characteristics`` (counts of the plan's), ``skipped`` [{``id`` (the QIF id),
    ``reason``}], ``imported`` [{``id``, ``kind``, ``qif`` (element), ``as`` (plan id)}],
    ``unit`` (the file's primary length unit), ``unlimited`` (features without an extent),
    ``notes``. A file that is not QIF, carries a DTD, holds no usable feature, or has a
    broken reference or unit is refused, one line naming the file."""
    return _Reader(Path(path)).run()
