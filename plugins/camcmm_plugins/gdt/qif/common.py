"""What every QIF 3.0 reader and writer of camcmm shares: the namespace, a safe XML
parse, the file's units (``FileUnits``) and its ids.

QIF 3.0 is ANSI/DMSC QIF 3.0-2018 = ISO 23952:2020; the schema is in
``../shared/data/qif3/schema`` (entry ``QIFApplications/QIFDocument.xsd``).

**Safe parse.** defusedxml is not installed. :func:`parse` uses the standard library's
expat in two passes: first a bare expat pass whose DOCTYPE, entity and external-entity
handlers refuse — a QIF document has no DTD, and a DTD's entities are how an XML bomb
("billion laughs", external entities) works, so refusing any DTD closes both — then
``xml.etree.ElementTree`` on the same bytes. The file's size is checked first
(:data:`MAX_BYTES`), before a byte is parsed. Every refusal is one line naming the file.

**Units** (QIF ``PrimaryUnitsType``): a length without a ``linearUnit`` attribute is in
the primary ``LinearUnit``, else metres; in the ``Characteristics`` section the primary
``PMILinearUnit`` overrides it when given; angles likewise (``AngularUnit`` /
``PMIAngularUnit``, else radians). ``linearUnit="inch"`` names a unit declared in
``FileUnits`` (primary or other) by its ``UnitName``; its ``UnitConversion/Factor``
converts to the SI unit (metre, radian).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

from camcmm.api import InputError

#: The QIF 3.0 namespace.
NS = "http://qifstandards.org/xsd/qif3"
Q = "{" + NS + "}"
#: The QIF version written (``QIFDocument/@versionQIF``).
VERSION = "3.0.0"
#: The units camcmm writes (Results, :mod:`.write`): (element, SI unit, name, factor to SI).
FILE_UNITS: tuple[tuple[str, str, str, float], ...] = (
    ("LinearUnit", "meter", "mm", 0.001),
    ("AngularUnit", "radian", "degree", math.pi / 180.0),
)
#: Largest QIF file read (bytes): the NIST MBD samples are 0.8 and 3.1 MB; a model with
#: its measured points may be tens of MB. Checked before parsing.
MAX_BYTES = 64 * 1024 * 1024

#: Length units whose metre factor is known, to cross-check a file's own conversion.
_KNOWN_M = {"m": 1.0, "meter": 1.0, "metre": 1.0, "mm": 1e-3, "millimeter": 1e-3, "cm": 1e-2, "um": 1e-6,
            "micron": 1e-6, "in": 0.0254, "inch": 0.0254, "ft": 0.3048, "foot": 0.3048}  # fmt: skip
_KNOWN_RAD = {"radian": 1.0, "rad": 1.0, "degree": math.pi / 180.0, "deg": math.pi / 180.0}


def tag(name: str) -> str:
    """The qualified tag of a QIF element."""
    return Q + name


def local(t: str) -> str:
    """A tag without its namespace."""
    return t.rsplit("}", 1)[-1]


def _refuse_dtd(*_args: object) -> None:
    raise InputError("a DTD")  # replaced by the caller's message


def parse(path: str | Path) -> ET.Element:
    """The root ``QIFDocument`` element of the QIF file ``path``, parsed safely (see the
    module docstring). Refuses a missing, too large, non-XML, DTD-carrying or non-QIF file,
    one line naming it."""
    p = Path(path)
    name = p.name
    try:
        size = p.stat().st_size
    except OSError as exc:
        raise InputError(f"{name}: cannot read ({exc.strerror or exc})") from None
    if not p.is_file():
        raise InputError(f"{name}: not a file")
    if size > MAX_BYTES:
        raise InputError(f"{name}: {size} bytes, more than the {MAX_BYTES // (1024 * 1024)} MB a QIF file may have")
    if size == 0:
        raise InputError(f"{name}: empty file, not a QIF document")
    data = p.read_bytes()
    guard = expat.ParserCreate()
    guard.StartDoctypeDeclHandler = _refuse_dtd
    guard.EntityDeclHandler = _refuse_dtd
    guard.ExternalEntityRefHandler = _refuse_dtd  # type: ignore[assignment]
    try:
        guard.Parse(data, True)
    except InputError:
        raise InputError(f"{name}: the XML declares a DTD or entities; a QIF document has none (refused)") from None
    except expat.ExpatError as exc:
        raise InputError(f"{name}: not well-formed XML ({expat.ErrorString(exc.code)}, line {exc.lineno})") from None
    except (ValueError, UnicodeError) as exc:
        raise InputError(f"{name}: not readable XML ({exc})") from None
    root = ET.fromstring(data)
    if root.tag != tag("QIFDocument"):
        what = local(root.tag)
        raise InputError(f"{name}: not a QIF 3.0 document (root element {what!r}, expected QIFDocument in {NS})")
    return root


def number(text: str | None, where: str) -> float:
    """One finite number of an element's text; ``where`` names it in the refusal."""
    try:
        x = float((text or "").strip())
    except ValueError:
        raise InputError(f"{where}: expected a number, got {(text or '').strip()[:40]!r}") from None
    if not math.isfinite(x):
        raise InputError(f"{where}: expected a finite number, got {(text or '').strip()[:40]!r}")
    return x


def numbers(text: str | None, n: int, where: str) -> list[float]:
    """``n`` finite numbers of a space-separated list (a QIF point or vector)."""
    parts = (text or "").split()
    if len(parts) != n:
        raise InputError(f"{where}: expected {n} numbers, got {(text or '').strip()[:60]!r}")
    return [number(s, where) for s in parts]


@dataclass
class Units:
    """The file's units: metre (radian) factor of each declared unit name, and the
    primary ones. ``linear_mm(value, unit_attr, pmi)`` converts a length to mm."""

    source: str
    linear_m: dict[str, float] = field(default_factory=dict)
    angular_rad: dict[str, float] = field(default_factory=dict)
    primary_linear: str | None = None
    pmi_linear: str | None = None
    primary_angular: str | None = None
    pmi_angular: str | None = None

    def linear_factor(self, unit: str | None, pmi: bool, where: str) -> float:
        """mm per unit of a length whose ``linearUnit`` attribute is ``unit`` (None: the
        primary unit; ``pmi``: in the Characteristics section)."""
        name = unit or (self.pmi_linear if pmi and self.pmi_linear else self.primary_linear)
        if name is None:
            return 1000.0  # QIF: metres when the file states no primary unit
        if name not in self.linear_m:
            raise InputError(f"{self.source}: {where}: linearUnit {name!r} is not declared in FileUnits")
        return self.linear_m[name] * 1000.0

    def mm(self, el: ET.Element, where: str, pmi: bool = False) -> float:
        """The length of element ``el`` in mm."""
        return number(el.text, f"{self.source}: {where}") * self.linear_factor(el.get("linearUnit"), pmi, where)

    def mm_factor(self, pmi: bool = False) -> float:
        """mm per unit of a length without its own ``linearUnit``."""
        return self.linear_factor(None, pmi, "FileUnits")

    def degrees(self, el: ET.Element, where: str, pmi: bool = False) -> float:
        """The angle of element ``el`` in degrees."""
        name = el.get("angularUnit") or (self.pmi_angular if pmi and self.pmi_angular else self.primary_angular)
        f = 1.0
        if name is not None:
            if name not in self.angular_rad:
                raise InputError(f"{self.source}: {where}: angularUnit {name!r} is not declared in FileUnits")
            f = self.angular_rad[name]
        return math.degrees(number(el.text, f"{self.source}: {where}") * f)

    @property
    def name(self) -> str:
        return self.primary_linear or "m"


def _unit(u: ET.Element, known: dict[str, float], source: str, where: str) -> tuple[str, float]:
    name = (u.findtext(tag("UnitName")) or "").strip()
    if not name:
        raise InputError(f"{source}: FileUnits.{where}.UnitName: missing")
    fe = u.find(f"{tag('UnitConversion')}/{tag('Factor')}")
    if fe is None:
        si = (u.findtext(tag("SIUnitName")) or "").strip()
        if name == si or name in ("m", "radian"):
            return name, 1.0
        if name.lower() in known:
            return name, known[name.lower()]
        raise InputError(f"{source}: FileUnits.{where}: unit {name!r} has no UnitConversion and is not the SI unit")
    f = number(fe.text, f"{source}: FileUnits.{where}.Factor")
    if not f > 0:
        raise InputError(f"{source}: FileUnits.{where}.Factor: must be > 0, got {fe.text!r}")
    k = known.get(name.lower())
    if k is not None and abs(f - k) > 1e-6 * k:
        raise InputError(
            f"{source}: FileUnits.{where}.Factor: {name!r} converts by {f:g}, not {k:g} (wrong unit conversion)"
        )
    return name, f


def file_units(root: ET.Element, source: str) -> Units:
    """The units of the document (see the module docstring). A unit with a wrong or
    missing conversion, or named twice with different factors, is refused."""
    out = Units(source)
    fu = root.find(tag("FileUnits"))
    if fu is None:
        return out
    for group in (fu.find(tag("PrimaryUnits")), fu.find(tag("OtherUnits"))):
        if group is None:
            continue
        for u in group:
            kind = local(u.tag)
            if kind in ("LinearUnit", "PMILinearUnit"):
                name, f = _unit(u, _KNOWN_M, source, kind)
                table = out.linear_m
            elif kind in ("AngularUnit", "PMIAngularUnit"):
                name, f = _unit(u, _KNOWN_RAD, source, kind)
                table = out.angular_rad
            else:
                continue
            if name in table and abs(table[name] - f) > 1e-9 * f:
                raise InputError(f"{source}: FileUnits.{kind}: {name!r} is declared twice with different factors")
            table[name] = f
            if group is fu.find(tag("PrimaryUnits")):
                attr = {"LinearUnit": "primary_linear", "PMILinearUnit": "pmi_linear",
                        "AngularUnit": "primary_angular", "PMIAngularUnit": "pmi_angular"}[kind]  # fmt: skip
                setattr(out, attr, name)
    return out


def id_map(root: ET.Element, source: str) -> dict[str, ET.Element]:
    """Every element carrying an ``id`` attribute, by id. A QIF id is a positive integer
    unique in the document; a duplicate is refused (a reference to it would be
    ambiguous)."""
    out: dict[str, ET.Element] = {}
    for el in root.iter():
        i = el.get("id")
        if i is None:
            continue
        if i in out:
            raise InputError(f"{source}: id {i}: used by two elements ({local(out[i].tag)}, {local(el.tag)})")
        out[i] = el
    return out


def ids(el: ET.Element | None) -> list[str]:
    """The ``<Id>`` texts of a QIF id list (``FeatureNominalIds``, ``EntityInternalIds``)."""
    if el is None:
        return []
    return [(i.text or "").strip() for i in el.findall(tag("Id"))]
