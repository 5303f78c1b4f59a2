"""The GD&T plan: read and check the YAML of ``camcmm gdt evaluate``, and write it back.

The document (lengths in ``unit``, default mm; angles in degrees)::

    unit: mm
    band: 0.5                      # default band of a feature (half-width about its nominal)
    k: 2                           # optional: default coverage factor of the characteristics
    features:
      A:  {type: plane, point: [0, 0, 0], normal: [0, 0, 1], box: [[0, 0, -1], [80, 60, 1]]}
      H1: {type: cylinder, point: [20, 30, 0], axis: [0, 0, 1], diameter: 10, length: 30, internal: true}
      S1: {type: sphere, centre: [60, 30, 40], diameter: 20}
      K1: {type: cone, apex: [0, 0, 50], axis: [0, 0, -1], angle: 30}   # full apex angle, degrees
      L1: {type: line, point: [0, 0, 0], direction: [1, 0, 0], length: 80}
      C1: {type: circle, centre: [20, 30, 5], normal: [0, 0, 1], diameter: 10}
      T1: {type: torus, centre: [0, 0, 0], axis: [0, 0, 1], major_diameter: 40, minor_diameter: 6}
      F1: {type: face, cad: 12}    # a face of the STEP nominal (1-based, OpenCascade's order)
    datums: {A: A, B: B, C: C, AB: [A, B]}
    characteristics:
      - {id: flat-A, type: flatness, feature: A, tolerance: 0.05}
      - {id: pos-H1, type: position, feature: H1, datums: [A, B, C], tolerance: 0.1}
      - {id: dia-H1, type: diameter, feature: H1, lower: -0.02, upper: 0.02}

Rules, as :func:`parse_plan` applies them:

* Every feature key is checked: the type's parameters of :data:`.model.FEATURE_TYPES`
  (``line.length`` and ``cylinder.length`` optional: without them the extent along the
  axis is unlimited), ``band``, ``box`` ([min corner, max corner]), ``association``
  (:data:`.model.ASSOCIATIONS`) and ``internal`` (a hole or bore: the material lies
  outside the nominal surface; default false — a shaft, a boss, a ball). ``internal`` is
  kept in ``FeatureSpec.nominal`` for the signs of :func:`.features.surface_distance` and
  the ISO 5459 datum default. An unknown key is refused (a misspelt ``diamter`` would
  otherwise silently be no diameter).
* A feature a datum names and whose ``association`` the plan does not state is
  associated by ``tangent``, the ISO 5459 default for datums; every other feature by
  ``ls``.
* ``datums`` maps a label to one feature id, or to a list of two or more ids: a common
  datum (ISO 5459 "A-B", e.g. ``AB: [A, B]``). A characteristic may also name the
  common datum ``"A-B"`` of two declared labels without declaring it: it is added to
  the plan's datums as (feature of A, feature of B). A characteristic's ``datums`` is a
  list in precedence order, or one string (``"A"``, or ``"A|B|C"``).
* Characteristic keys: ``id`` (unique), ``type`` (:data:`.model.CHARACTERISTICS`),
  ``feature``, ``datums``, ``tolerance`` (> 0), ``lower`` / ``upper`` (deviations from
  the nominal size; lower ≤ upper), ``modifier`` (MMC, LMC or RFS), ``k`` (> 0); any
  other key goes to ``CharacteristicSpec.options`` as given, except that the lengths
  among them (:data:`LENGTH_OPTIONS`) are converted to mm, and a feature id it names
  under ``to`` or ``features`` must exist.
* Unknown top-level keys are kept in ``Plan.options`` (alignment settings and the like
  for the evaluation), and written back by :func:`plan_document`.

Every refusal is one line, ``FILE: key.path: reason``, an :class:`camcmm.api.InputError`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, ParameterError, checked_path, read_yaml, to_mm_factor

from .model import ASSOCIATIONS, CHARACTERISTICS, FEATURE_TYPES, CharacteristicSpec, FeatureSpec, Plan

#: Band of a feature when the plan states none (mm).
DEFAULT_BAND_MM = 0.5

#: Nominal parameters that are lengths (converted from the plan's unit), points (3 lengths)
#: and unit directions.
_POINTS = ("point", "centre", "apex")
_DIRECTIONS = ("normal", "axis", "direction")
_LENGTHS = ("diameter", "length", "major_diameter", "minor_diameter")
#: Parameters a type may omit (an unlimited extent along the axis).
_OPTIONAL = {"line": ("length",), "cylinder": ("length",)}
#: Keys every feature may carry besides its type's parameters.
_COMMON = ("type", "band", "box", "association", "internal")

#: Characteristic option keys that are lengths (converted to mm like the tolerances).
LENGTH_OPTIONS = ("nominal", "section", "offset", "length", "width", "diameter", "height")
#: Characteristic option keys that name other features (checked to exist).
_FEATURE_OPTIONS = ("to", "features", "other")
_CHAR_KEYS = ("id", "type", "feature", "datums", "tolerance", "lower", "upper", "modifier", "k")
MODIFIERS = ("MMC", "LMC", "RFS")
_SIZE = CHARACTERISTICS["size"]
_ALL_CHARACTERISTICS = tuple(t for family in CHARACTERISTICS.values() for t in family)


class _Checker:
    """Builds the one-line refusals ``FILE: key.path: reason``."""

    def __init__(self, source: str) -> None:
        self.name = Path(source).name if source else "plan"

    def fail(self, key: str, reason: str) -> InputError:
        return InputError(f"{self.name}: {key}: {reason}" if key else f"{self.name}: {reason}")

    def number(self, value: Any, key: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(key, f"expected a number, got {_show(value)}")
        x = float(value)
        if not math.isfinite(x):
            raise self.fail(key, f"expected a finite number, got {_show(value)}")
        return x

    def positive(self, value: Any, key: str) -> float:
        x = self.number(value, key)
        if not x > 0:
            raise self.fail(key, f"must be > 0, got {_show(value)}")
        return x

    def vector(self, value: Any, key: str) -> np.ndarray:
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            raise self.fail(key, f"expected 3 numbers, got {_show(value)}")
        return np.array([self.number(v, f"{key}[{i}]") for i, v in enumerate(value)])

    def direction(self, value: Any, key: str) -> np.ndarray:
        v = self.vector(value, key)
        n = float(np.linalg.norm(v))
        if not n > 0:
            raise self.fail(key, "a direction of zero length")
        return v / n

    def mapping(self, value: Any, key: str) -> dict:
        if not isinstance(value, dict):
            raise self.fail(key, f"expected a mapping, got {_show(value)}")
        return value

    def ident(self, value: Any, key: str) -> str:
        if isinstance(value, bool) or not isinstance(value, (str, int)) or str(value).strip() == "":
            raise self.fail(key, f"expected a name, got {_show(value)}")
        return str(value)


def _show(value: Any) -> str:
    s = repr(value)
    return s if len(s) <= 60 else s[:59] + "…"


def read_plan(path: str | Path) -> Plan:
    """The plan in YAML file ``path`` (through camcmm's YAML loader and, in a confined
    run, the path rules). Refusals name the file: see :func:`parse_plan`."""
    p = checked_path(path, "plan")
    doc = read_yaml(p, name=Path(path).name)
    return parse_plan(doc, source=str(path))


def parse_plan(doc: Any, source: str = "") -> Plan:
    """Check the plan document ``doc`` (the YAML's mapping) and convert it to mm.

    ``source`` names the file in refusals (``"plan"`` without one). Returns a
    :class:`.model.Plan` whose lengths are in mm, directions unit vectors, angles in
    degrees. Raises InputError (one line naming the file and key) on anything wrong.
    """
    ck = _Checker(source)
    if doc is None:
        raise ck.fail("", "empty document; expected a plan with features")
    doc = ck.mapping(doc, "")
    unit = doc.get("unit", "mm")
    if not isinstance(unit, str):
        raise ck.fail("unit", f"expected a length unit, got {_show(unit)}")
    try:
        f = to_mm_factor(unit)
    except ParameterError as exc:
        raise ck.fail("unit", str(exc)) from None
    band = ck.positive(doc["band"], "band") * f if "band" in doc else DEFAULT_BAND_MM
    k_default = ck.positive(doc["k"], "k") if "k" in doc else 2.0
    if "features" not in doc:
        raise ck.fail("features", "missing; a plan names at least one feature")
    raw_features = ck.mapping(doc["features"], "features")
    if not raw_features:
        raise ck.fail("features", "empty; a plan names at least one feature")
    ids = [ck.ident(fid, f"features.{fid}") for fid in raw_features]
    if len(set(ids)) != len(ids):  # 1 and "1" are two YAML keys but one id
        dup = next(i for i in ids if ids.count(i) > 1)
        raise ck.fail(f"features.{dup}", f"{dup!r} is used twice; ids must be unique")
    datums = _datums(ck, doc.get("datums") or {}, set(ids))
    datum_features = {fid for fids in datums.values() for fid in fids}
    features = {
        fid: _feature(ck, fid, raw, f, band, fid in datum_features)
        for fid, raw in zip(ids, raw_features.values(), strict=True)
    }
    raw_chars = doc.get("characteristics") or []
    if not isinstance(raw_chars, list):
        raise ck.fail("characteristics", f"expected a list, got {_show(raw_chars)}")
    chars: list[CharacteristicSpec] = []
    for i, raw in enumerate(raw_chars):
        chars.append(_characteristic(ck, i, raw, f, k_default, features, datums))
    seen: set[str] = set()
    for i, c in enumerate(chars):
        if c.id in seen:
            raise ck.fail(f"characteristics[{i}].id", f"{c.id!r} is used twice; ids must be unique")
        seen.add(c.id)
    known = {"unit", "band", "k", "features", "datums", "characteristics"}
    options = {key: value for key, value in doc.items() if key not in known}
    if "k" in doc:
        options["k"] = k_default
    return Plan(
        unit=unit,
        band=band,
        features=features,
        datums=datums,
        characteristics=chars,
        options=options,
        source=str(source),
    )


def _feature(ck: _Checker, fid: str, raw: Any, f: float, band: float, is_datum: bool) -> FeatureSpec:
    key = f"features.{fid}"
    raw = ck.mapping(raw, key)
    if "type" not in raw:
        raise ck.fail(f"{key}.type", f"missing; use one of {', '.join(FEATURE_TYPES)}")
    ftype = raw["type"]
    if ftype not in FEATURE_TYPES:
        raise ck.fail(f"{key}.type", f"unknown type {_show(ftype)}; use one of {', '.join(FEATURE_TYPES)}")
    params = FEATURE_TYPES[ftype]
    allowed = set(params) | set(_COMMON)
    for name in raw:
        if name not in allowed:
            raise ck.fail(
                f"{key}.{name}", f"unknown key for a {ftype}; use {', '.join(list(params) + list(_COMMON[1:]))}"
            )
    nominal: dict[str, Any] = {}
    for name in params:
        pkey = f"{key}.{name}"
        if name not in raw:
            if name in _OPTIONAL.get(ftype, ()):
                continue
            raise ck.fail(
                pkey, f"missing; a {ftype} needs {', '.join(p for p in params if p not in _OPTIONAL.get(ftype, ()))}"
            )
        value = raw[name]
        if name in _POINTS:
            nominal[name] = ck.vector(value, pkey) * f
        elif name in _DIRECTIONS:
            nominal[name] = ck.direction(value, pkey)
        elif name in _LENGTHS:
            nominal[name] = ck.positive(value, pkey) * f
        elif name == "angle":
            a = ck.number(value, pkey)
            if not 0 < a < 180:
                raise ck.fail(pkey, f"a cone's full apex angle must lie in (0, 180) degrees, got {_show(value)}")
            nominal[name] = a
        elif name == "cad":
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ck.fail(pkey, f"expected a face number (1, 2, ...), got {_show(value)}")
            nominal[name] = int(value)
    if "internal" in raw:
        if not isinstance(raw["internal"], bool):
            raise ck.fail(f"{key}.internal", f"expected true or false, got {_show(raw['internal'])}")
        nominal["internal"] = raw["internal"]
    else:
        nominal["internal"] = False
    fband = ck.positive(raw["band"], f"{key}.band") * f if "band" in raw else band
    box = None
    if "box" in raw:
        b = raw["box"]
        if not isinstance(b, (list, tuple)) or len(b) != 2:
            raise ck.fail(f"{key}.box", f"expected [[xmin, ymin, zmin], [xmax, ymax, zmax]], got {_show(b)}")
        box = np.array([ck.vector(b[0], f"{key}.box[0]"), ck.vector(b[1], f"{key}.box[1]")]) * f
        if np.any(box[0] > box[1]):
            raise ck.fail(f"{key}.box", "the first corner must be the minimum and the second the maximum")
    if "association" in raw:
        association = raw["association"]
        if association not in ASSOCIATIONS:
            raise ck.fail(
                f"{key}.association", f"unknown association {_show(association)}; use one of {', '.join(ASSOCIATIONS)}"
            )
    else:
        association = "tangent" if is_datum else "ls"
    return FeatureSpec(id=fid, type=ftype, nominal=nominal, band=fband, box=box, association=str(association))


def _datums(ck: _Checker, raw: Any, features: set[str]) -> dict[str, tuple[str, ...]]:
    raw = ck.mapping(raw, "datums")
    out: dict[str, tuple[str, ...]] = {}
    for label, value in raw.items():
        key = f"datums.{label}"
        label = ck.ident(label, key)
        if label in out:
            raise ck.fail(key, f"{label!r} is used twice; labels must be unique")
        if isinstance(value, (list, tuple)):
            if len(value) < 2:
                raise ck.fail(key, "a common datum names two or more features")
            fids = tuple(ck.ident(v, f"{key}[{i}]") for i, v in enumerate(value))
            if len(set(fids)) != len(fids):
                raise ck.fail(key, "a common datum names a feature twice")
        else:
            fids = (ck.ident(value, key),)
        for fid in fids:
            if fid not in features:
                raise ck.fail(key, f"unknown feature {fid!r}")
        out[label] = fids
    return out


def _datum_labels(ck: _Checker, raw: Any, key: str, datums: dict[str, tuple[str, ...]]) -> tuple[str, ...]:
    if isinstance(raw, str):
        labels = [s.strip() for s in raw.split("|")]
    elif isinstance(raw, (list, tuple)):
        labels = [ck.ident(v, f"{key}[{i}]") for i, v in enumerate(raw)]
    else:
        raise ck.fail(key, f"expected a list of datum labels, got {_show(raw)}")
    for i, label in enumerate(labels):
        if label in datums:
            continue
        parts = label.split("-")
        if len(parts) >= 2 and all(p in datums and len(datums[p]) == 1 for p in parts):
            # "A-B": the common datum of two declared single datums, declared on the fly
            datums[label] = tuple(datums[p][0] for p in parts)
            continue
        raise ck.fail(f"{key}[{i}]", f"unknown datum {label!r}; declare it under datums")
    if len(set(labels)) != len(labels):
        raise ck.fail(key, "a datum is named twice")
    return tuple(labels)


def _characteristic(
    ck: _Checker,
    i: int,
    raw: Any,
    f: float,
    k_default: float,
    features: dict[str, FeatureSpec],
    datums: dict[str, tuple[str, ...]],
) -> CharacteristicSpec:
    key = f"characteristics[{i}]"
    raw = ck.mapping(raw, key)
    for name in ("id", "type", "feature"):
        if name not in raw:
            raise ck.fail(f"{key}.{name}", "missing")
    cid = ck.ident(raw["id"], f"{key}.id")
    ctype = raw["type"]
    if ctype not in _ALL_CHARACTERISTICS:
        raise ck.fail(
            f"{key}.type", f"unknown characteristic {_show(ctype)}; use one of {', '.join(_ALL_CHARACTERISTICS)}"
        )
    feature = ck.ident(raw["feature"], f"{key}.feature")
    if feature not in features:
        raise ck.fail(f"{key}.feature", f"unknown feature {feature!r}")
    labels = _datum_labels(ck, raw["datums"], f"{key}.datums", datums) if raw.get("datums") is not None else ()
    if not labels and (ctype in CHARACTERISTICS["orientation"] or ctype in CHARACTERISTICS["runout"]):
        raise ck.fail(f"{key}.datums", f"a {ctype} is relative to a datum; name one")
    tol = ck.positive(raw["tolerance"], f"{key}.tolerance") * f if raw.get("tolerance") is not None else None
    lower = ck.number(raw["lower"], f"{key}.lower") * f if raw.get("lower") is not None else None
    upper = ck.number(raw["upper"], f"{key}.upper") * f if raw.get("upper") is not None else None
    if lower is not None and upper is not None and lower > upper:
        raise ck.fail(f"{key}.lower", f"{raw['lower']} is above upper {raw['upper']}")
    if ctype not in _SIZE and (lower is not None or upper is not None):
        raise ck.fail(
            f"{key}.lower", f"lower/upper limits are for sizes ({', '.join(_SIZE)}); a {ctype} has a tolerance"
        )
    modifier = raw.get("modifier")
    if modifier is not None:
        if not isinstance(modifier, str) or modifier.upper() not in MODIFIERS:
            raise ck.fail(f"{key}.modifier", f"unknown modifier {_show(modifier)}; use one of {', '.join(MODIFIERS)}")
        modifier = modifier.upper()
    k = ck.positive(raw["k"], f"{key}.k") if raw.get("k") is not None else k_default
    options: dict[str, Any] = {}
    for name, value in raw.items():
        if name in _CHAR_KEYS:
            continue
        okey = f"{key}.{name}"
        if name in LENGTH_OPTIONS and value is not None:
            value = ck.number(value, okey) * f
        elif name in _FEATURE_OPTIONS and value is not None:
            names = value if isinstance(value, list) else [value]
            for j, v in enumerate(names):
                if ck.ident(v, okey) not in features:
                    raise ck.fail(okey if not isinstance(value, list) else f"{okey}[{j}]", f"unknown feature {v!r}")
        options[str(name)] = value
    return CharacteristicSpec(
        id=cid,
        type=str(ctype),
        feature=feature,
        datums=labels,
        tolerance=tol,
        lower=lower,
        upper=upper,
        modifier=modifier,
        k=k,
        options=options,
    )


def plan_document(plan: Plan) -> dict[str, Any]:
    """The plan as its YAML document (lengths back in ``plan.unit``), for export:
    ``parse_plan(plan_document(plan))`` gives the plan again (to rounding of the unit
    conversion). Plain Python values only (lists, floats, str), ready for yaml/json."""
    g = 1.0 / to_mm_factor(plan.unit)

    def length(x: float) -> float:
        return float(x) * g

    def vec(v: Any, scale: float = 1.0) -> list[float]:
        return [float(c) * scale for c in np.asarray(v, dtype=float)]

    features: dict[str, Any] = {}
    for fid, spec in plan.features.items():
        d: dict[str, Any] = {"type": spec.type}
        for name in FEATURE_TYPES[spec.type]:
            if name not in spec.nominal:
                continue
            value = spec.nominal[name]
            if name in _POINTS:
                d[name] = vec(value, g)
            elif name in _DIRECTIONS:
                d[name] = vec(value)
            elif name in _LENGTHS:
                d[name] = length(value)
            elif name == "cad":
                d[name] = int(value)
            else:
                d[name] = float(value)
        if spec.nominal.get("internal"):
            d["internal"] = True
        d["band"] = length(spec.band)
        if spec.box is not None:
            d["box"] = [vec(spec.box[0], g), vec(spec.box[1], g)]
        d["association"] = spec.association
        features[fid] = d
    datums = {label: (list(fids) if len(fids) > 1 else fids[0]) for label, fids in plan.datums.items()}
    chars = []
    for c in plan.characteristics:
        d = {"id": c.id, "type": c.type, "feature": c.feature}
        if c.datums:
            d["datums"] = list(c.datums)
        for name in ("tolerance", "lower", "upper"):
            value = getattr(c, name)
            if value is not None:
                d[name] = length(value)
        if c.modifier is not None:
            d["modifier"] = c.modifier
        d["k"] = float(c.k)
        for name, value in c.options.items():
            d[name] = length(value) if name in LENGTH_OPTIONS and value is not None else value
        chars.append(d)
    doc: dict[str, Any] = {"unit": plan.unit, "band": length(plan.band)}
    doc.update(plan.options)
    doc.update({"features": features, "datums": datums, "characteristics": chars})
    return doc
