"""The test plan: a YAML file (or dict) naming the standard, the system, the MPEs, the
artefacts with their calibration certificates and the measurement files.

Contract keys (docs/standards.md; more may be added, none renamed)::

    standard: vdi2634-2                    # or vdi2634-3
    system: {name: "Stereo FP", measuring_volume: [100, 100, 100]}     # mm
    mpe: {PF: 0.186, PS: 0.143, SD: 0.096, F: 0.243}                    # mm
    artefacts:
      sphere:     {diameter: 20.001, uncertainty: 0.001, k: 2}         # + form, form_uncertainty
      ball_bar:   {length: 49.944, uncertainty: 0.0008, k: 2, sphere_diameter: 20.0}
      flat:       {length: 150.0, width: 60.0, flatness: 0.0026}       # + flatness_uncertainty, k
      ball_plate: {sphere_diameter: 5.0, lengths: [5.942, 7.956, 9.957], uncertainty: 0.0003, k: 2}
    measurements:                          # paths relative to the plan file
      sphere: [sphere_01.ply, ...]         # or {file, position, repeat, unit}, or a list of repeats
    outliers: vdi2634                      # or per test: {sphere: "percent:5", ...}
    scaling: {sphere: radii, ball_plate: lengths}   # part 3: none | radii | lengths
    repeats: 3                             # part 3 (ISO 10360-8)
    unit: mm                               # unit of files that do not declare one

Lengths are mm; uncertainties are expanded uncertainties U with coverage factor k.
Every fault raises :class:`camcmm.api.InputError` with one line naming the key.
Missing measurement *files* are not plan errors: they make that measurement fail and
the verdict incomplete (see :mod:`.standard`). Measurement paths are resolved relative
to the plan's folder through ``camcmm.api.checked_path``: in a confined run (the web
server) a file outside its folders refuses the plan (``PathRefused``) before any is read.
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Artefact, Certificate, InputError, PathRefused, checked_path, read_yaml, to_mm_factor

TESTS = ("sphere", "ball_bar", "flat", "ball_plate")
PARAMETERS = ("PF", "PS", "SD", "F")
SCALINGS = ("none", "radii", "lengths")
_RULE = re.compile(r"^(none|vdi2634|percent:\d+(\.\d*)?|sigma:\d+(\.\d*)?)$")


@dataclass
class PlannedMeasurement:
    """One measurement of the plan: its test, file (resolved against the plan's folder),
    position id, repeat number (1-based) and the file's unit if the plan gives one."""

    test: str
    name: str
    file: Path | None
    position: str
    repeat: int = 1
    unit: str | None = None
    key: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"test": self.test, "file": self.name, "position": self.position, "repeat": self.repeat}


@dataclass
class Plan:
    """A validated plan; ``raw`` is the plan as given (a plain dict, for the project state)."""

    standard: str
    system_name: str
    measuring_volume: np.ndarray
    mpe: dict[str, float]
    artefacts: dict[str, Artefact]
    measurements: dict[str, list[PlannedMeasurement]]
    outliers: dict[str, str]
    scaling: dict[str, str]
    repeats: int | None
    unit: str | None
    base_dir: Path | None
    source: str
    raw: dict[str, Any] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def diagonal(self) -> float:
        """Longest diagonal of the measuring volume L0 (mm), the reference of the artefact rules."""
        return float(np.linalg.norm(self.measuring_volume))

    def rule(self, test: str) -> str:
        return self.outliers.get(test, "vdi2634")

    def certificate(self, test: str, name: str) -> Certificate | None:
        a = self.artefacts.get(test)
        return None if a is None else a.certificates.get(name)

    def value(self, test: str, name: str) -> float | None:
        """A calibrated value (certificate) or else a nominal one, mm; None if absent."""
        c = self.certificate(test, name)
        if c is not None:
            return c.value
        a = self.artefacts.get(test)
        v = None if a is None else a.nominal.get(name)
        return None if v is None else float(v)

    def required(self, test: str, name: str) -> float:
        """:meth:`value` of one the evaluation needs (the plan's validation asks for it):
        InputError naming it when absent, not a failure on None later."""
        v = self.value(test, name)
        if v is None:
            raise InputError(f"{self.source}: artefacts.{test}.{name} is missing")
        return v

    def required_certificate(self, test: str, name: str) -> Certificate:
        """:meth:`certificate` of one the evaluation needs: InputError naming it when absent."""
        c = self.certificate(test, name)
        if c is None:
            raise InputError(f"{self.source}: artefacts.{test}: the calibrated {name} and its uncertainty are missing")
        return c


class _Where:
    def __init__(self, source: str):
        self.source = source

    def fail(self, key: str, why: str) -> InputError:
        return InputError(f"{self.source}: {key} {why}")


def _num(w: _Where, v: Any, key: str, positive: bool = True) -> float:
    """A finite number (> 0, or >= 0 when not ``positive``) or an error naming ``key``."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise w.fail(key, f"must be a number, got {v!r}")
    v = float(v)
    if positive and v <= 0:
        raise w.fail(key, f"must be > 0, got {v:g}")
    if v < 0:
        raise w.fail(key, f"must be >= 0, got {v:g}")
    return v


def _number(
    w: _Where, d: dict, key: str, path: str, positive: bool = True, required: bool = True, default: float | None = None
) -> float | None:
    if key not in d or d[key] is None:
        if required:
            raise w.fail(f"{path}.{key}", "is missing")
        return default
    return _num(w, d[key], f"{path}.{key}", positive)


def _optional(w: _Where, d: dict, key: str, path: str, default: float, positive: bool = True) -> float:
    """An optional number, ``default`` when absent."""
    v = _number(w, d, key, path, positive=positive, required=False)
    return default if v is None else v


def _mapping(w: _Where, d: Any, path: str) -> dict:
    if not isinstance(d, dict):
        raise w.fail(path, f"must be a mapping, got {type(d).__name__}")
    return d


def read_source(source: Any) -> tuple[dict[str, Any], Path | None, str]:
    """(plan dict, its folder or None, a name for messages) from a path or a dict."""
    if isinstance(source, dict):
        base = source.get("base_dir")
        return copy.deepcopy(source), (Path(base) if base else None), str(source.get("name") or "plan")
    path = Path(source)
    if not path.is_file():
        raise InputError(f"{path}: plan file not found")
    doc = read_yaml(path, name=path.name)  # one line naming the file: syntax, duplicate key, alias bomb
    if not isinstance(doc, dict):
        raise InputError(
            f"{path.name}: a plan must be a YAML mapping with standard, system, mpe, artefacts, measurements"
        )
    return doc, path.parent.resolve(), path.name


def _artefact(w: _Where, test: str, d: Any) -> Artefact:
    p = f"artefacts.{test}"
    d = _mapping(w, d, p)
    k = _optional(w, d, "k", p, 2.0)
    certs: dict[str, Certificate] = {}
    nominal: dict[str, Any] = {}

    def cert(name: str, value_key: str, u_key: str, required: bool = True) -> None:
        v = _number(w, d, value_key, p, required=required, positive=value_key != "form" and value_key != "flatness")
        if v is not None:
            u = _optional(w, d, u_key, p, 0.0, positive=False)
            certs[name] = Certificate(v, u, k)

    if test == "sphere":
        cert("diameter", "diameter", "uncertainty")
        cert("form", "form", "form_uncertainty", required=False)
    elif test == "ball_bar":
        cert("length", "length", "uncertainty")
        nominal["sphere_diameter"] = _number(w, d, "sphere_diameter", p)
        if "sphere_diameter_uncertainty" in d:  # calibrated spheres (needed only to scale by radii)
            cert("sphere_diameter", "sphere_diameter", "sphere_diameter_uncertainty")
    elif test == "flat":
        nominal["length"] = _number(w, d, "length", p)
        nominal["width"] = _number(w, d, "width", p)
        cert("flatness", "flatness", "flatness_uncertainty", required=False)
    elif test == "ball_plate":
        nominal["sphere_diameter"] = _number(w, d, "sphere_diameter", p)
        if "sphere_diameter_uncertainty" in d:  # calibrated spheres: a scale reference (scaling: radii)
            cert("sphere_diameter", "sphere_diameter", "sphere_diameter_uncertainty")
        lengths = d.get("lengths")
        if not isinstance(lengths, list) or len(lengths) != 3:
            raise w.fail(
                f"{p}.lengths",
                f"must list the three calibrated lengths L1 = |c1c2|, L2 = |c2c3|, L3 = |c3c1| in mm, got {lengths!r}",
            )
        u = _optional(w, d, "uncertainty", p, 0.0, positive=False)
        for i, v in enumerate(lengths):
            v = _num(w, v, f"{p}.lengths[{i}]")
            certs[f"length_{i + 1}"] = Certificate(v, u, k)
        a, b, c = sorted(certs[f"length_{i}"].value for i in (1, 2, 3))
        if a + b <= c:
            raise w.fail(f"{p}.lengths", f"{lengths} cannot be the sides of a triangle of three spheres")
        d_s = nominal["sphere_diameter"]
        if a <= d_s:  # centres closer than a diameter: the spheres would overlap
            raise w.fail(
                f"{p}.lengths", f"{lengths}: {a:g} mm is no longer than sphere_diameter {d_s:g} mm; the spheres overlap"
            )
    nominal.update({key: d[key] for key in ("id", "name") if key in d})
    return Artefact(str(d.get("id", test)), test, str(d.get("name", "")), nominal, certs)


def _rules(w: _Where, value: Any, tests: list[str]) -> dict[str, str]:
    if value is None:
        return {}
    if isinstance(value, str):
        value = {t: value for t in tests}
    value = _mapping(w, value, "outliers")
    out = {}
    for test, rule in value.items():
        if test not in TESTS:
            raise w.fail(f"outliers.{test}", f"is not a test; use {', '.join(TESTS)}")
        text = str(rule).strip().lower()
        if not _RULE.match(text):
            raise w.fail(
                f"outliers.{test}", f"{rule!r} is not an outlier rule; use none, vdi2634, percent:P or sigma:K"
            )
        out[test] = text
    return out


def _measurements(w: _Where, d: Any, base: Path | None, unit: str | None) -> dict[str, list[PlannedMeasurement]]:
    d = _mapping(w, d if d is not None else {}, "measurements")
    out: dict[str, list[PlannedMeasurement]] = {}
    for test, entries in d.items():
        if test not in TESTS:
            raise w.fail(f"measurements.{test}", f"is not a test; use {', '.join(TESTS)}")
        if entries is None:
            entries = []
        if not isinstance(entries, list):
            raise w.fail(f"measurements.{test}", "must be a list of files")
        items: list[PlannedMeasurement] = []
        for i, e in enumerate(entries):
            group = e if isinstance(e, list) else [e]  # a list: the repeats of one position
            for r, item in enumerate(group):
                key = f"measurements.{test}[{i}]" + (f"[{r}]" if isinstance(e, list) else "")
                position, repeat, u = f"{test.replace('_', '-')}-{i + 1:02d}", r + 1, unit
                if isinstance(item, dict):
                    if "file" not in item:
                        raise w.fail(key, "needs a file")
                    position = str(item.get("position", position))
                    repeat = int(item.get("repeat", repeat))
                    u = item.get("unit", unit)
                    item = item["file"]
                if not isinstance(item, str) or not item.strip():
                    raise w.fail(key, f"must be a file name, got {item!r}")
                if u is not None:
                    try:
                        to_mm_factor(str(u))
                    except Exception as exc:
                        raise w.fail(f"{key}.unit", str(exc)) from None
                # relative to the plan's folder; in a confined run (the server) a file
                # outside its folders is refused here, before anything is read
                try:
                    path = Path(checked_path(item, key, base=base))
                except PathRefused as exc:
                    raise PathRefused(f"{w.source}: {exc}") from None
                items.append(PlannedMeasurement(test, item, path, position, repeat, u, key))
        out[test] = items
    return out


def load(source: Any, standard: str | None = None) -> Plan:
    """Validate a plan given as a path (YAML) or a dict (``base_dir`` key: the folder its
    relative paths refer to). ``standard``: the id it must name."""
    if isinstance(source, Plan):
        if standard and source.standard != standard:
            raise InputError(f"{source.source}: the plan is for {source.standard}, not {standard}")
        return source
    doc, base, name = read_source(source)
    w = _Where(name)
    std = doc.get("standard")
    if not isinstance(std, str) or not std:
        raise w.fail("standard", f"is missing; say which standard the plan is for (e.g. {standard or 'vdi2634-2'})")
    if standard and std != standard:
        raise w.fail("standard", f"is {std!r}; this evaluation is {standard!r}")
    system = _mapping(w, doc.get("system") or {}, "system")
    vol = system.get("measuring_volume")
    if not isinstance(vol, list) or len(vol) != 3:
        raise w.fail("system.measuring_volume", f"must be [x, y, z] in mm, got {vol!r}")
    vol = np.array([_num(w, v, f"system.measuring_volume[{i}]") for i, v in enumerate(vol)])
    mpe_d = _mapping(w, doc.get("mpe") or {}, "mpe")
    mpe: dict[str, float] = {}
    for key in mpe_d:
        if key not in PARAMETERS:
            raise w.fail(f"mpe.{key}", f"is not a quality parameter; use {', '.join(PARAMETERS)}")
        v = _number(w, mpe_d, key, "mpe")
        assert v is not None  # required: _number raises rather than return None
        mpe[key] = v
    arts = _mapping(w, doc.get("artefacts") or {}, "artefacts")
    for key in arts:
        if key not in TESTS:
            raise w.fail(f"artefacts.{key}", f"is not an artefact; use {', '.join(TESTS)}")
    artefacts = {k: _artefact(w, k, v) for k, v in arts.items()}
    unit = doc.get("unit")
    if unit is not None:
        try:
            to_mm_factor(str(unit))
        except Exception as exc:
            raise w.fail("unit", str(exc)) from None
    meas = _measurements(w, doc.get("measurements"), base, unit)
    for test, items in meas.items():
        if items and test not in artefacts:
            raise w.fail(f"artefacts.{test}", f"is missing but measurements.{test} lists {len(items)} files")
    scaling = doc.get("scaling") or {}
    if isinstance(scaling, str):
        scaling = {t: scaling for t in TESTS}
    scaling = _mapping(w, scaling, "scaling")
    for key, v in scaling.items():
        if key not in TESTS or v not in SCALINGS:
            raise w.fail(f"scaling.{key}", f"= {v!r}; use a test name and one of {', '.join(SCALINGS)}")
    repeats = doc.get("repeats")
    if repeats is not None and (isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1):
        raise w.fail("repeats", f"must be a whole number >= 1, got {repeats!r}")
    options = _mapping(w, doc.get("options") or {}, "options")
    return Plan(
        std,
        str(system.get("name", "")),
        vol,
        mpe,
        artefacts,
        meas,
        _rules(w, doc.get("outliers"), list(TESTS)),
        dict(scaling),
        repeats,
        None if unit is None else str(unit),
        base,
        name,
        doc,
        dict(options),
    )
