"""The blocks a report is made of (paragraphs, key-value lists, tables, figures,
verdicts, warnings), the page geometry they are laid out against, and how a value reads
in a cell. ``document.py`` assembles them into a :class:`~.document.Report`; ``html.py``
and ``pdf.py`` render them and import only this module, so that the Report can call
its renderers without an import cycle."""

from __future__ import annotations

import hashlib
import io
import json
import math
import struct
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Any

from .. import numbers
from ..errors import InputError
from ..jsonable import to_jsonable

#: The verdict words a report shows, as :mod:`camcmm.conformity` returns them.
VERDICTS = ("pass", "fail", "inconclusive", "incomplete")

#: Width of the printed text column on A4 (210 mm - 2 x 20 mm margins). Figures are
#: laid out against it in both the PDF and the HTML, so the two look alike.
CONTENT_WIDTH_MM = 170.0
#: Horizontal gap between figures set side by side.
FIGURE_GAP_MM = 6.0

SCHEMA = "camcmm.report/1"

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------- JSON
def jsonable(x: Any, where: str = "data") -> Any:
    """``x`` as plain JSON data (:func:`camcmm.jsonable.to_jsonable`): numpy values become
    numbers and lists, NaN/Inf ``null``.

    JSON has no NaN, and a report file that ``json.loads`` cannot read is worse than
    one that says "not defined" (null). Anything else that is not data raises a
    TypeError naming where it sits, so a caller learns which key to fix.
    """
    return to_jsonable(x, strict=True, where=f"report {where}")


def text(x: Any) -> str:
    """How a value reads in a table cell or key-value pair (HTML and PDF alike).

    A float that has a short exact form (up to 10 significant digits, e.g. a certified
    length 300.0451 mm) shows exactly that, so no certified digit is lost; a computed
    one (0.30000000000000004) shows 7 significant digits. Callers wanting a given
    number of decimals pass strings. The JSON keeps the full value either way.
    Missing values (None, NaN) read as an em dash, never as "nan".
    """
    if hasattr(x, "dtype") and getattr(x, "ndim", None) == 0:
        x = x.item()  # numpy scalar -> Python: an int64 reads as an int, not as 1.23457e+07
    if x is None:
        return "\u2014"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    if isinstance(x, (dict, list, tuple)):  # nested values (provenance, meta) as compact JSON
        return json.dumps(jsonable(x), ensure_ascii=False)
    if isinstance(x, float):
        if not math.isfinite(x):
            return "\u2014" if math.isnan(x) else ("\u221e" if x > 0 else "\u2212\u221e")
        short = repr(x)
        mantissa = short.lstrip("-").split("e")[0].replace(".", "").lstrip("0")
        # never an exponent, a real minus (camcmm.numbers): 1e-05 reads 0.00001
        return numbers.significant(x, 10 if len(mantissa) <= 10 else 7)
    return str(x)


# --------------------------------------------------------------------------- PNG
def png_size(png: bytes) -> tuple[int, int, float | None]:
    """(width_px, height_px, dpi or None) of a PNG, read from its IHDR and pHYs chunks.

    The dpi lets a chart drawn at, say, 80 mm keep that width in the report, so its
    fonts print at the size they were drawn at.
    """
    if len(png) < 24 or not png.startswith(PNG_SIGNATURE) or png[12:16] != b"IHDR":
        raise InputError("report figure: not a PNG image (give PNG bytes or a matplotlib figure)")
    width, height = struct.unpack(">II", png[16:24])
    dpi = None
    pos = 8
    while pos + 8 <= len(png):
        length, kind = struct.unpack(">I4s", png[pos : pos + 8])
        if kind == b"pHYs" and length == 9:
            ppu_x, _ppu_y, unit = struct.unpack(">IIB", png[pos + 8 : pos + 17])
            if unit == 1 and ppu_x > 0:  # pixels per metre
                dpi = ppu_x * 0.0254
            break
        if kind in (b"IDAT", b"IEND"):
            break
        pos += 12 + length
    return width, height, dpi


def _png_from(image: Any, dpi: float) -> bytes:
    """PNG bytes from bytes, a path to a PNG file, or a matplotlib figure."""
    if isinstance(image, (bytes, bytearray, memoryview)):
        return bytes(image)
    if isinstance(image, (str, PurePath)):
        try:
            return Path(image).read_bytes()
        except OSError as exc:
            raise InputError(f"report figure {str(image)!r}: cannot read it ({exc.strerror})") from None
    if hasattr(image, "savefig"):
        buf = io.BytesIO()
        # Figures are frozen into PNG now, so later changes to the figure cannot make
        # the report differ from what was hashed.
        image.savefig(buf, format="png", dpi=dpi)
        return buf.getvalue()
    raise InputError(
        f"report figure: cannot use a {type(image).__name__}; give PNG bytes, a PNG file or a matplotlib figure"
    )


# --------------------------------------------------------------------------- blocks
@dataclass
class Paragraph:
    text: str

    def to_dict(self) -> dict:
        return {"type": "paragraph", "text": self.text}


@dataclass
class KeyValues:
    items: list[tuple[str, Any]]
    caption: str = ""

    def to_dict(self) -> dict:
        d = {"type": "keyvalues", "items": {k: jsonable(v, f"keyvalues[{k!r}]") for k, v in self.items}}
        if self.caption:
            d["caption"] = self.caption
        return d


@dataclass
class Table:
    columns: list[str]
    rows: list[list[Any]]
    caption: str = ""
    align: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {
            "type": "table",
            "columns": self.columns,
            "rows": jsonable(self.rows, "table rows"),
            "caption": self.caption,
            "align": self.align,
        }


@dataclass
class Figure:
    png: bytes
    caption: str
    width_mm: float
    pixels: tuple[int, int]
    info: dict = field(default_factory=dict)
    data: Any = None

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.png).hexdigest()

    @property
    def height_mm(self) -> float:
        return self.width_mm * self.pixels[1] / self.pixels[0]

    def to_dict(self) -> dict:
        d = {
            "type": "figure",
            "caption": self.caption,
            "sha256": self.sha256,
            "width_mm": round(self.width_mm, 2),
            "pixels": list(self.pixels),
        }
        if self.info:
            d["info"] = jsonable(self.info, "figure info")
        if self.data is not None:
            d["data"] = jsonable(self.data, "figure data")
        return d


@dataclass
class Verdict:
    label: str
    simple: str
    guarded: str | None = None
    value: Any = None
    limit: Any = None
    uncertainty: Any = None
    note: str = ""

    def to_dict(self) -> dict:
        return {
            "type": "verdict",
            "label": self.label,
            "simple": self.simple,
            "guarded": self.guarded,
            "value": jsonable(self.value),
            "limit": jsonable(self.limit),
            "uncertainty": jsonable(self.uncertainty),
            "note": self.note,
        }


@dataclass
class Warning_:
    text: str

    def to_dict(self) -> dict:
        return {"type": "warning", "text": self.text}


@dataclass
class Signature:
    """Lines a person signs by hand: per party its role, its name (may be blank) and
    empty date and signature fields, tall enough to sign in on paper."""

    parties: list[tuple[str, str]]

    def to_dict(self) -> dict:
        return {"type": "signature", "parties": [{"role": r, "name": n} for r, n in self.parties]}


@dataclass
class FigureRow:
    """Consecutive figures that fit side by side on one line (layout only, not content)."""

    figures: list[Figure]


@dataclass
class VerdictTable:
    """Consecutive verdicts shown as one table, so their badges line up (layout only)."""

    verdicts: list[Verdict]

    def columns(self) -> list[str]:
        """Parameter, value, limit, then U / guarded rule / note only where some verdict has one."""
        cols = ["Parameter", "Value", "Limit"]
        if any(v.uncertainty is not None for v in self.verdicts):
            cols.append("U")
        cols.append("Simple rule")
        if any(v.guarded is not None for v in self.verdicts):
            cols.append("Guarded rule")
        if any(v.note for v in self.verdicts):
            cols.append("Note")
        return cols

    @staticmethod
    def cell(v: Verdict, column: str) -> Any:
        return {
            "Parameter": v.label,
            "Value": v.value,
            "Limit": v.limit,
            "U": v.uncertainty,
            "Simple rule": v.simple,
            "Guarded rule": v.guarded,
            "Note": v.note,
        }[column]


def layout(blocks: Iterable[Any]) -> list[Any]:
    """The blocks with runs of figures grouped into rows that fit the text width and
    runs of verdicts into one table.

    Both renderers use this one function, so the HTML and the PDF put the same figures
    side by side.
    """
    out: list[Any] = []
    for b in blocks:
        if isinstance(b, Verdict):
            if out and isinstance(out[-1], VerdictTable):
                out[-1].verdicts.append(b)
            else:
                out.append(VerdictTable([b]))
            continue
        if isinstance(b, Figure):
            row = out[-1] if out and isinstance(out[-1], FigureRow) else None
            if row is not None:
                used = sum(f.width_mm for f in row.figures) + FIGURE_GAP_MM * len(row.figures)
                if used + b.width_mm <= CONTENT_WIDTH_MM + 1e-9:
                    row.figures.append(b)
                    continue
            out.append(FigureRow([b]))
        else:
            out.append(b)
    return out


def headed_sections(report: Any) -> list[tuple[str, list[Any], bool]]:
    """(heading, blocks, appendix) in reading order, for both renderers: the body's
    sections numbered 1, 2 …, then the appendix's lettered A, B … with the provenance as
    its last part — so a customer reads results first and the records behind them after."""
    body = [s for s in report.sections if not getattr(s, "appendix", False)]
    appendix = [s for s in report.sections if getattr(s, "appendix", False)]
    out: list[tuple[str, list[Any], bool]] = [
        (f"{i}\u2002{s.title}", layout(s.blocks), False) for i, s in enumerate(body, 1)
    ]
    if not appendix:  # a report without appendix keeps its provenance as the last section
        return out + [("Provenance", provenance_blocks(report.provenance_dict()), False)]
    letters = "ABCDEFGHIJKLMNOPQRSTUVWXYZ"
    out += [(f"Appendix {letters[i]}\u2002{s.title}", layout(s.blocks), True) for i, s in enumerate(appendix)]
    out.append(
        (f"Appendix {letters[len(appendix)]}\u2002Provenance", provenance_blocks(report.provenance_dict()), True)
    )
    return out


def provenance_blocks(prov: dict) -> list[Any]:
    """The provenance as blocks (key-values and tables), rendered like any section.

    Plugins and inputs become tables whose columns are the union of their keys, so
    whatever a standard records (id, version, role, size ...) is shown.
    """
    blocks: list[Any] = [
        KeyValues(
            [("Software", prov["software"])]
            + [(k.replace("_", " ").capitalize(), v) for k, v in prov["environment"].items()],
            "Software and environment",
        )
    ]
    for caption, rows in (("Plugins", prov["plugins"]), ("Input files", prov["inputs"])):
        if rows:
            cols: list[str] = []
            for r in rows:
                cols += [k for k in r if k not in cols]
            blocks.append(Table(cols, [[r.get(c) for c in cols] for r in rows], caption, ["left"] * len(cols)))
    if prov["extra"]:
        blocks.append(KeyValues([(k, v) for k, v in prov["extra"].items()], "Further records"))
    return blocks


def _align_for(rows: list[list[Any]], n_cols: int) -> list[str]:
    """Right-align columns of numbers (so digits line up), left-align the rest."""

    def numeric(c: Any) -> bool:
        if c is None or isinstance(c, bool):
            return c is None
        if isinstance(c, (int, float)) or hasattr(c, "dtype"):
            return True
        s = str(c).strip().lstrip("+-\u2212\u00b1")
        return s[:1].isdigit() or s in ("", "\u2014")

    out = []
    for j in range(n_cols):
        cells = [r[j] for r in rows if j < len(r)]
        is_num = bool(cells) and all(numeric(c) for c in cells) and any(c is not None for c in cells)
        out.append("right" if is_num else "left")
    return out
