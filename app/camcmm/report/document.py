"""The report as a structured document: sections of blocks, provenance, data.

One document, three renderings (HTML, PDF, JSON) from the same content, so an auditor
who reads the PDF can find every number again in the JSON. This module holds the
content only; ``html.py`` and ``pdf.py`` turn it into pages, and the JSON is
:meth:`Report.to_dict` itself.

Nothing heavy is imported here: a standard can build a report without loading
matplotlib or reportlab, which are only needed to draw charts and write the PDF.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import platform
import struct
import tempfile
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Any, Iterable, Sequence

from ..errors import CamcmmError, InputError
from ..jsonable import to_jsonable, utc_now

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
        return short if len(mantissa) <= 10 else f"{x:.7g}"
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
        length, kind = struct.unpack(">I4s", png[pos:pos + 8])
        if kind == b"pHYs" and length == 9:
            ppu_x, _ppu_y, unit = struct.unpack(">IIB", png[pos + 8:pos + 17])
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
    raise InputError(f"report figure: cannot use a {type(image).__name__}; "
                     "give PNG bytes, a PNG file or a matplotlib figure")


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
        return {"type": "table", "columns": self.columns, "rows": jsonable(self.rows, "table rows"),
                "caption": self.caption, "align": self.align}


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
        d = {"type": "figure", "caption": self.caption, "sha256": self.sha256,
             "width_mm": round(self.width_mm, 2), "pixels": list(self.pixels)}
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
        return {"type": "verdict", "label": self.label, "simple": self.simple, "guarded": self.guarded,
                "value": jsonable(self.value), "limit": jsonable(self.limit),
                "uncertainty": jsonable(self.uncertainty), "note": self.note}


@dataclass
class Warning_:
    text: str

    def to_dict(self) -> dict:
        return {"type": "warning", "text": self.text}


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
        return {"Parameter": v.label, "Value": v.value, "Limit": v.limit, "U": v.uncertainty,
                "Simple rule": v.simple, "Guarded rule": v.guarded, "Note": v.note}[column]


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


def provenance_blocks(prov: dict) -> list[Any]:
    """The provenance as blocks (key-values and tables), rendered like any section.

    Plugins and inputs become tables whose columns are the union of their keys, so
    whatever a standard records (id, version, role, size ...) is shown.
    """
    blocks: list[Any] = [KeyValues([("Software", prov["software"])]
                                   + [(k.replace("_", " ").capitalize(), v) for k, v in prov["environment"].items()],
                                   "Software and environment")]
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


class Section:
    """A titled part of a report: a list of blocks in the order they were added."""

    def __init__(self, title: str, dpi: float = 150.0) -> None:
        self.title = str(title)
        self.blocks: list[Any] = []
        self._dpi = dpi

    def paragraph(self, text: str) -> "Section":
        """Plain text (no markup: it is escaped in every rendering)."""
        self.blocks.append(Paragraph(str(text)))
        return self

    def keyvalues(self, items: dict[str, Any] | Sequence[tuple[str, Any]], caption: str = "") -> "Section":
        """A two-column table of names and values, in the given order."""
        pairs = list(items.items()) if isinstance(items, dict) else [tuple(p) for p in items]
        self.blocks.append(KeyValues([(str(k), v) for k, v in pairs], str(caption)))
        return self

    def table(self, columns: Sequence[str], rows: Iterable[Sequence[Any]], caption: str = "",
              align: Sequence[str] | None = None) -> "Section":
        """A table; long ones split across PDF pages with the header row repeated.

        Cells may be numbers, strings or None (shown as a dash). ``align`` is one of
        "left", "right", "center" per column; by default columns of numbers are
        right-aligned.
        """
        columns = [str(c) for c in columns]
        rows = [list(r) for r in rows]
        for i, r in enumerate(rows):
            if len(r) != len(columns):
                raise InputError(f"report table {caption or columns!r}: row {i} has {len(r)} cells "
                                 f"for {len(columns)} columns")
        if align is None:
            align_list = _align_for(rows, len(columns))
        else:
            align_list = [str(a) for a in align]
            if len(align_list) != len(columns) or not set(align_list) <= {"left", "right", "center"}:
                raise InputError(f"report table: align must give left/right/center for each of "
                                 f"{len(columns)} columns, got {align_list}")
        self.blocks.append(Table(columns, rows, str(caption), align_list))
        return self

    def figure(self, image: Any, caption: str = "", width_mm: float | None = None,
               data: Any = None) -> "Section":
        """A figure from PNG bytes (e.g. from :mod:`camcmm.report.charts`), a PNG file
        or a matplotlib figure.

        ``width_mm`` defaults to the image's own printed width (from the dpi in the
        PNG), capped at the text width. Consecutive figures that fit are set side by
        side. ``data`` (optional) is the numbers behind the figure; it goes into the
        JSON so a plotted value can be traced. The JSON records the PNG's SHA-256.
        """
        png = _png_from(image, self._dpi)
        w_px, h_px, dpi = png_size(png)
        if width_mm is None:
            width_mm = w_px / (dpi or 96.0) * 25.4
        width_mm = float(min(max(width_mm, 10.0), CONTENT_WIDTH_MM))
        info = dict(getattr(image, "info", None) or {}) if isinstance(image, bytes) else {}
        self.blocks.append(Figure(png, str(caption), width_mm, (w_px, h_px), info, data))
        return self

    def verdict(self, label: str, simple: str, guarded: str | None = None, value: Any = None,
                limit: Any = None, uncertainty: Any = None, note: str = "") -> "Section":
        """A verdict line with coloured badges under the simple and guarded decision rules.

        Verdict words are those of :mod:`camcmm.conformity`: pass, fail, inconclusive,
        incomplete. ``guarded`` may be None where no test uncertainty is defined.
        """
        for rule, word in (("simple", simple), ("guarded", guarded)):
            if word is None and rule == "guarded":
                continue
            if word not in VERDICTS:
                raise InputError(f"report verdict {label!r}: {rule} verdict {word!r} is not one of "
                                 f"{', '.join(VERDICTS)}")
        self.blocks.append(Verdict(str(label), simple, guarded, value, limit, uncertainty, str(note)))
        return self

    def warning(self, text: str) -> "Section":
        """Text an operator must not overlook (shown highlighted)."""
        self.blocks.append(Warning_(str(text)))
        return self

    def to_dict(self) -> dict:
        return {"title": self.title, "blocks": [b.to_dict() for b in self.blocks]}


class Report:
    """A report: title, meta data, sections, provenance and the machine-readable result.

    >>> r = Report("VDI/VDE 2634-2 acceptance test", subtitle="Stereo FP", meta={"operator": "A. B."})
    >>> s = r.section("Probing error form P_F")
    >>> s.table(["Position", "P_F [mm]"], [[1, 0.12]])  # doctest: +ELLIPSIS
    <...Section ...>
    >>> r.write("out")  # doctest: +SKIP
    """

    def __init__(self, title: str, subtitle: str = "", meta: dict[str, Any] | None = None,
                 dpi: float = 150.0) -> None:
        self.title = str(title)
        self.subtitle = str(subtitle)
        self.meta: dict[str, Any] = dict(meta or {})
        self.sections: list[Section] = []
        self.data: Any = None
        self.created = utc_now(timespec="seconds")
        self._dpi = dpi
        self._provenance: dict[str, Any] = {"software": None, "plugins": [], "inputs": [], "extra": {}}

    # ------------------------------------------------------------------ building
    def section(self, title: str) -> Section:
        s = Section(title, self._dpi)
        self.sections.append(s)
        return s

    def provenance(self, software: str | None = None, plugins: Iterable[dict] = (),
                   inputs: Iterable[dict] = (), extra: dict[str, Any] | None = None) -> "Report":
        """Record what produced the report; may be called more than once (lists add up).

        ``inputs`` are dicts with at least ``file``; a missing ``sha256`` is computed
        from the file, and an input that has neither is refused — an untraceable input
        would defeat the purpose of the section.
        """
        p = self._provenance
        if software is not None:
            p["software"] = str(software)
        for plug in plugins:
            plug = jsonable(dict(plug), "provenance plugin")
            if plug not in p["plugins"]:
                p["plugins"].append(plug)
        for inp in inputs:
            inp = dict(inp)
            if not inp.get("sha256"):
                f = Path(str(inp.get("file", "")))
                if not inp.get("file") or not f.is_file():
                    raise InputError(f"report input {inp.get('file')!r}: no sha256 given and no such file to hash")
                inp["sha256"] = _file_sha256(f)
            inp = jsonable(inp, "provenance input")
            if inp not in p["inputs"]:
                p["inputs"].append(inp)
        if extra:
            p["extra"].update(jsonable(dict(extra), "provenance extra"))
        return self

    # ------------------------------------------------------------------ content
    def provenance_dict(self) -> dict:
        """The provenance as recorded, plus the environment the report was made in."""
        from .. import __version__
        p = dict(self._provenance)
        p["software"] = p["software"] or f"camcmm {__version__}"
        p["environment"] = {"python": platform.python_version(), "platform": platform.platform(),
                            "report_generator": f"camcmm.report {__version__}"}
        return p

    def to_dict(self) -> dict:
        """The report's content as JSON data: what the JSON file holds.

        Tables keep their raw cell values (full precision), figures their caption and
        the SHA-256 of the PNG embedded in the HTML and PDF.
        """
        return {
            "schema": SCHEMA,
            "title": self.title,
            "subtitle": self.subtitle,
            "created": self.created,
            "meta": jsonable(self.meta, "meta"),
            "sections": [s.to_dict() for s in self.sections],
            "provenance": self.provenance_dict(),
            "data": jsonable(self.data, "data"),
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"

    def render_html(self) -> str:
        from .html import render_html
        return render_html(self)

    def render_pdf(self) -> bytes:
        from .pdf import render_pdf
        return render_pdf(self)

    # ------------------------------------------------------------------ output
    def write(self, directory: str | os.PathLike, basename: str = "report",
              formats: Sequence[str] = ("html", "pdf", "json")) -> dict[str, str]:
        """Write ``<basename>.html``, ``.pdf`` and ``.json`` into ``directory``.

        Everything is rendered in memory first, so a failure writes nothing; each file
        then appears atomically (temporary file + ``os.replace``), so a reader never
        sees half a report. Returns ``{"html": path, "pdf": path, "json": path}``.
        """
        if not basename or os.sep in basename or (os.altsep and os.altsep in basename) or basename in (".", ".."):
            raise InputError(f"report basename {basename!r} must be a plain file name")
        unknown = set(formats) - {"html", "pdf", "json"}
        if unknown:
            raise InputError(f"report formats {sorted(unknown)}: choose from html, pdf, json")
        rendered: dict[str, bytes] = {}
        if "html" in formats:
            rendered["html"] = self.render_html().encode("utf-8")
        if "pdf" in formats:
            rendered["pdf"] = self.render_pdf()
        if "json" in formats:
            rendered["json"] = self.to_json().encode("utf-8")
        out_dir = Path(directory)
        paths = {}
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
            for ext, content in rendered.items():
                target = out_dir / f"{basename}.{ext}"
                _atomic_write(target, content)
                paths[ext] = str(target)
        except OSError as exc:
            raise CamcmmError(f"cannot write the report into {str(out_dir)!r}: "
                              f"{exc.strerror or exc}") from None
        return paths


def _file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _atomic_write(target: Path, content: bytes) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(content)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)  # mkstemp makes 0600; a report is meant to be shared
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
