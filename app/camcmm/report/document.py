"""The report as a structured document: sections of blocks, provenance, data.

One document, three renderings (HTML, PDF, JSON) from the same content, so an auditor
who reads the PDF can find every number again in the JSON. This module holds the
content only (the blocks are in ``blocks.py``); ``html.py`` and ``pdf.py`` turn it into pages, and the JSON is
:meth:`Report.to_dict` itself.

Nothing heavy is imported here: a standard can build a report without loading
matplotlib or reportlab, which are only needed to draw charts and write the PDF.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from ..errors import CamcmmError, InputError
from ..jsonable import utc_now
from .blocks import (
    CONTENT_WIDTH_MM,
    SCHEMA,
    VERDICTS,
    Figure,
    KeyValues,
    Paragraph,
    Signature,
    Table,
    Verdict,
    Warning_,
    _align_for,
    _png_from,
    jsonable,
    png_size,
)


class Section:
    """A titled part of a report: a list of blocks in the order they were added."""

    def __init__(self, title: str, dpi: float = 150.0, appendix: bool = False) -> None:
        self.title = str(title)
        self.blocks: list[Any] = []
        self._dpi = dpi
        #: an appendix is rendered after the body, lettered (records, not results)
        self.appendix = bool(appendix)

    def paragraph(self, text: str) -> Section:
        """Plain text (no markup: it is escaped in every rendering)."""
        self.blocks.append(Paragraph(str(text)))
        return self

    def keyvalues(self, items: dict[str, Any] | Sequence[tuple[str, Any]], caption: str = "") -> Section:
        """A two-column table of names and values, in the given order."""
        pairs = list(items.items()) if isinstance(items, dict) else [tuple(p) for p in items]
        self.blocks.append(KeyValues([(str(k), v) for k, v in pairs], str(caption)))
        return self

    def table(
        self,
        columns: Sequence[str],
        rows: Iterable[Sequence[Any]],
        caption: str = "",
        align: Sequence[str] | None = None,
    ) -> Section:
        """A table; long ones split across PDF pages with the header row repeated.

        Cells may be numbers, strings or None (shown as a dash). ``align`` is one of
        "left", "right", "center" per column; by default columns of numbers are
        right-aligned.
        """
        columns = [str(c) for c in columns]
        table_rows: list[list[Any]] = [list(r) for r in rows]
        rows = table_rows
        for i, r in enumerate(rows):
            if len(r) != len(columns):
                raise InputError(
                    f"report table {caption or columns!r}: row {i} has {len(r)} cells for {len(columns)} columns"
                )
        if align is None:
            align_list = _align_for(rows, len(columns))
        else:
            align_list = [str(a) for a in align]
            if len(align_list) != len(columns) or not set(align_list) <= {"left", "right", "center"}:
                raise InputError(
                    f"report table: align must give left/right/center for each of "
                    f"{len(columns)} columns, got {align_list}"
                )
        self.blocks.append(Table(columns, rows, str(caption), align_list))
        return self

    def figure(self, image: Any, caption: str = "", width_mm: float | None = None, data: Any = None) -> Section:
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

    def verdict(
        self,
        label: str,
        simple: str,
        guarded: str | None = None,
        value: Any = None,
        limit: Any = None,
        uncertainty: Any = None,
        note: str = "",
    ) -> Section:
        """A verdict line with coloured badges under the simple and guarded decision rules.

        Verdict words are those of :mod:`camcmm.conformity`: pass, fail, inconclusive,
        incomplete. ``guarded`` may be None where no test uncertainty is defined.
        """
        for rule, word in (("simple", simple), ("guarded", guarded)):
            if word is None and rule == "guarded":
                continue
            if word not in VERDICTS:
                raise InputError(
                    f"report verdict {label!r}: {rule} verdict {word!r} is not one of {', '.join(VERDICTS)}"
                )
        self.blocks.append(Verdict(str(label), simple, guarded, value, limit, uncertainty, str(note)))
        return self

    def warning(self, text: str) -> Section:
        """Text an operator must not overlook (shown highlighted)."""
        self.blocks.append(Warning_(str(text)))
        return self

    def signature(self, parties: Sequence[tuple[str, str]] = (("Inspected by", ""), ("Approved by", ""))) -> Section:
        """Fields to sign by hand: one row per (role, name) with empty date and signature."""
        self.blocks.append(Signature([(str(r), str(n or "")) for r, n in parties]))
        return self

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"title": self.title, "blocks": [b.to_dict() for b in self.blocks]}
        if self.appendix:
            d["appendix"] = True
        return d


class Report:
    """A report: title, meta data, sections, provenance and the machine-readable result.

    >>> r = Report("VDI/VDE 2634-2 acceptance test", subtitle="Stereo FP", meta={"operator": "A. B."})
    >>> s = r.section("Probing error form P_F")
    >>> s.table(["Position", "P_F [mm]"], [[1, 0.12]])  # doctest: +ELLIPSIS
    <...Section ...>
    >>> r.write("out")  # doctest: +SKIP
    """

    def __init__(self, title: str, subtitle: str = "", meta: dict[str, Any] | None = None, dpi: float = 150.0) -> None:
        self.title = str(title)
        self.subtitle = str(subtitle)
        self.meta: dict[str, Any] = dict(meta or {})
        self.sections: list[Section] = []
        self.data: Any = None
        self.created = utc_now(timespec="seconds")
        self._dpi = dpi
        self._provenance: dict[str, Any] = {"software": None, "plugins": [], "inputs": [], "extra": {}}

    # ------------------------------------------------------------------ building
    def section(self, title: str, appendix: bool = False) -> Section:
        """A new section; ``appendix=True`` puts it after the body (lettered A, B …), with
        the provenance as the appendix's last part."""
        s = Section(title, self._dpi, appendix)
        self.sections.append(s)
        return s

    def provenance(
        self,
        software: str | None = None,
        plugins: Iterable[dict] = (),
        inputs: Iterable[dict] = (),
        extra: dict[str, Any] | None = None,
    ) -> Report:
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

    # ------------------------------------------------------------------ customer
    def customer(self, fields: dict[str, str]) -> Report:
        """Head the report with the customer fields (:mod:`.customer`: customer, part
        number, order, drawing revision, operator, instrument, date, temperature) before
        the meta already given; the date defaults to the day the report is made."""
        from .customer import header

        self.meta = {**header(fields, self.created), **self.meta}
        return self

    @staticmethod
    def customer_options(parser: Any) -> None:
        """``--customer``, ``--part-number`` … on a command writing a report (:func:`.customer.add_options`)."""
        from .customer import add_options

        add_options(parser)

    @staticmethod
    def customer_fields(doc: Any = None, args: Any = None, where: str = "report") -> dict[str, str]:
        """The customer fields of a plan's ``report:`` mapping ``doc`` (refused in one line
        naming ``where`` and the key) with a command's options ``args`` over them."""
        from .customer import check_fields, from_args

        base = check_fields(doc, where)
        return from_args(args, base) if args is not None else base

    @staticmethod
    def overall_verdict(verdicts: Iterable[tuple[str, str]]) -> tuple[str, str]:
        """(badge word, sentence) of a part from (name, ISO 14253-1 verdict) pairs (:func:`.customer.overall`)."""
        from .customer import overall

        return overall(verdicts)

    # ------------------------------------------------------------------ content
    def provenance_dict(self) -> dict:
        """The provenance as recorded, plus the environment the report was made in."""
        from .. import __version__

        p = dict(self._provenance)
        p["software"] = p["software"] or f"camcmm {__version__}"
        p["environment"] = {
            "python": platform.python_version(),
            "platform": platform.platform(),
            "report_generator": f"camcmm.report {__version__}",
        }
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
    def write(
        self, directory: str | os.PathLike, basename: str = "report", formats: Sequence[str] = ("html", "pdf", "json")
    ) -> dict[str, str]:
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
            raise CamcmmError(f"cannot write the report into {str(out_dir)!r}: {exc.strerror or exc}") from None
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
