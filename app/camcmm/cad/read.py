"""Reading STEP (ISO 10303-21: AP203/AP214/AP242) and IGES files into an OpenCascade shape.

OpenCascade's readers convert the file's lengths into the session unit
(``xstep.cascade.unit``), which is set to millimetres here before every read, so the shape
is in mm whatever the file's unit; the unit the file declares is kept as ``source_unit``
(STEP: the length unit of its representation contexts, ``STEPControl_Reader.FileUnits``;
IGES: the global section's unit).

Before OpenCascade sees the file its first bytes are checked (a STEP file begins with
``ISO-10303-21;``; an IGES file has fixed 80-column records with the section letter S or
G in column 73), so a file that is not one is refused in one line instead of being handed
to a parser that reports little. Every refusal is an :class:`~camcmm.errors.InputError`
naming the file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import InputError

#: Extension (lower case) -> format name.
EXTENSIONS = {".step": "STEP", ".stp": "STEP", ".iges": "IGES", ".igs": "IGES"}

#: OpenCascade's unit names -> camcmm's unit keys.
_UNITS = {
    "MILLIMETRE": "mm",
    "MM": "mm",
    "METRE": "m",
    "M": "m",
    "CENTIMETRE": "cm",
    "CM": "cm",
    "MICROMETRE": "um",
    "UM": "um",
    "INCH": "in",
    "IN": "in",
    "INCHES": "in",
    "FOOT": "ft",
    "FT": "ft",
}


def cad_format(path: Path) -> str:
    """'STEP' or 'IGES' by the extension; InputError for anything else."""
    fmt = EXTENSIONS.get(path.suffix.lower())
    if fmt is None:
        raise InputError(f"{path.name}: not a CAD file (camcmm reads {', '.join(sorted(EXTENSIONS))})")
    return fmt


def _check_head(path: Path, fmt: str) -> None:
    with open(path, "rb") as fh:
        head = fh.read(400)
    if not head.strip():
        raise InputError(f"{path.name}: the file is empty")
    if fmt == "STEP":
        if not head.lstrip(b"\xef\xbb\xbf \t\r\n").upper().startswith(b"ISO-10303-21"):
            raise InputError(f"{path.name}: not a STEP file (it does not begin with 'ISO-10303-21;')")
        return
    first = head.split(b"\n", 1)[0].rstrip(b"\r")
    if len(first) < 73 or first[72:73] not in (b"S", b"G"):
        raise InputError(f"{path.name}: not an IGES file (no start or global record in columns 73-80)")


def _unit_name(names: list[str]) -> str:
    for n in names:
        key = _UNITS.get(n.strip().upper().replace(".", ""))
        if key:
            return key
    return "mm"


def read_shape(path: str | Path) -> tuple[Any, str, str]:
    """``(TopoDS_Shape in mm, format, source unit)`` of a STEP or IGES file."""
    p = Path(path)
    fmt = cad_format(p)
    if not p.is_file():
        raise InputError(f"{p.name}: file not found ({p})")
    _check_head(p, fmt)
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static

    Interface_Static.SetCVal_s("xstep.cascade.unit", "MM")
    if fmt == "STEP":
        from OCP.OCP.collections import Sequence_TCollection_AsciiString as Seq
        from OCP.STEPControl import STEPControl_Reader

        reader: Any = STEPControl_Reader()
        status = reader.ReadFile(str(p))
        if status != IFSelect_RetDone:
            raise InputError(f"{p.name}: OpenCascade cannot parse this STEP file ({str(status).rsplit('_', 1)[-1]})")
        lengths, angles, solid = Seq(), Seq(), Seq()
        reader.FileUnits(lengths, angles, solid)
        unit = _unit_name([lengths.Value(i).ToCString() for i in range(1, lengths.Length() + 1)])
    else:
        from OCP.IGESControl import IGESControl_Reader

        reader = IGESControl_Reader()
        status = reader.ReadFile(str(p))
        if status != IFSelect_RetDone:
            raise InputError(f"{p.name}: OpenCascade cannot parse this IGES file ({str(status).rsplit('_', 1)[-1]})")
        try:
            unit = _unit_name([reader.IGESModel().GlobalSection().UnitName().ToCString()])
        except Exception:  # a global section without a unit name: IGES's default is inches
            unit = "in"
    if reader.TransferRoots() == 0:
        raise InputError(f"{p.name}: the {fmt} file holds no shape OpenCascade can transfer")
    shape = reader.OneShape()
    if shape.IsNull():
        raise InputError(f"{p.name}: the {fmt} file holds no shape")
    return shape, fmt, unit
