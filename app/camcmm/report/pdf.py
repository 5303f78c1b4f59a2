"""The report as a PDF (A4), drawn with reportlab's platypus.

Same content and order as the HTML (both walk the document with ``layout()``). Long
tables split across pages and repeat their header row; figures keep the width they were
drawn at, scaled down to fit; every page carries the report title and "page i of n".

Text is set in DejaVu Sans, which matplotlib ships: reportlab's built-in Helvetica
has no glyphs for "−", "≤", Greek letters or an operator's non-Latin name, and a
metrology report is full of those. reportlab is imported only when a PDF is made.
"""

from __future__ import annotations

import html
import io
from importlib.util import find_spec
from pathlib import Path
from typing import Any

from ..conformity import verdict_words
from .blocks import (
    CONTENT_WIDTH_MM,
    FIGURE_GAP_MM,
    FigureRow,
    KeyValues,
    Paragraph,
    Signature,
    Table,
    VerdictTable,
    Warning_,
    headed_sections,
    text,
)
from .html import VERDICT_COLOURS

MARGIN_MM = 20.0
BADGE_MM = 27.0  # wide enough for "INCONCLUSIVE" in 8 pt bold
_FONTS: dict[str, str] | None = None


def _fonts() -> dict[str, str]:
    """Register DejaVu Sans (regular, bold, mono) once; fall back to Helvetica."""
    global _FONTS
    if _FONTS is not None:
        return _FONTS
    from reportlab.lib.fonts import addMapping
    from reportlab.pdfbase import pdfmetrics
    from reportlab.pdfbase.ttfonts import TTFont

    fonts = {"regular": "Helvetica", "bold": "Helvetica-Bold", "mono": "Courier"}
    spec = find_spec("matplotlib")
    if spec and spec.submodule_search_locations:
        ttf = Path(list(spec.submodule_search_locations)[0]) / "mpl-data" / "fonts" / "ttf"
        files = {
            "regular": "DejaVuSans.ttf",
            "bold": "DejaVuSans-Bold.ttf",
            "italic": "DejaVuSans-Oblique.ttf",
            "mono": "DejaVuSansMono.ttf",
        }
        if all((ttf / f).is_file() for f in files.values()):
            names = {"regular": "CamSans", "bold": "CamSans-Bold", "italic": "CamSans-Italic", "mono": "CamMono"}
            for key, f in files.items():
                pdfmetrics.registerFont(TTFont(names[key], str(ttf / f)))
            # so that <b> and <i> inside a Paragraph pick the right face
            addMapping("CamSans", 0, 0, "CamSans")
            addMapping("CamSans", 1, 0, "CamSans-Bold")
            addMapping("CamSans", 0, 1, "CamSans-Italic")
            addMapping("CamSans", 1, 1, "CamSans-Bold")
            addMapping("CamSans-Bold", 0, 1, "CamSans-Bold")
            fonts = names
    _FONTS = fonts
    return fonts


def _x(s: Any) -> str:
    """Text for a reportlab Paragraph, which parses a little XML: escape it."""
    return html.escape(text(s), quote=False).replace("\n", "<br/>")


class _Builder:
    def __init__(self, report) -> None:
        from reportlab.lib import colors
        from reportlab.lib.enums import TA_CENTER, TA_LEFT, TA_RIGHT
        from reportlab.lib.styles import ParagraphStyle
        from reportlab.lib.units import mm

        self.report = report
        self.mm = mm
        self.colors = colors
        f = _fonts()
        self.f = f
        self.width = CONTENT_WIDTH_MM * mm
        ink, muted = colors.HexColor("#1a1a1a"), colors.HexColor("#5b6470")
        self.rule = colors.HexColor("#c9ced6")
        self.head_bg = colors.HexColor("#eef1f5")
        self.zebra = colors.HexColor("#f8f9fb")
        P = ParagraphStyle
        self.st = {
            "title": P("title", fontName=f["bold"], fontSize=19, leading=23, textColor=ink, spaceAfter=3),
            "subtitle": P("subtitle", fontName=f["regular"], fontSize=12.5, leading=16, textColor=muted),
            "h2": P("h2", fontName=f["bold"], fontSize=13, leading=16, textColor=ink, spaceBefore=12, spaceAfter=6),
            "body": P("body", fontName=f["regular"], fontSize=9.5, leading=13, textColor=ink, spaceAfter=5),
            "cell": P("cell", fontName=f["regular"], fontSize=8.5, leading=10.5, textColor=ink),
            "cell_r": P("cell_r", fontName=f["regular"], fontSize=8.5, leading=10.5, alignment=TA_RIGHT),
            "cell_c": P("cell_c", fontName=f["regular"], fontSize=8.5, leading=10.5, alignment=TA_CENTER),
            "mono": P("mono", fontName=f["mono"], fontSize=7.5, leading=9.5),
            "head": P("head", fontName=f["bold"], fontSize=8.5, leading=10.5, alignment=TA_LEFT),
            "head_r": P("head_r", fontName=f["bold"], fontSize=8.5, leading=10.5, alignment=TA_RIGHT),
            "head_c": P("head_c", fontName=f["bold"], fontSize=8.5, leading=10.5, alignment=TA_CENTER),
            "caption": P("caption", fontName=f["bold"], fontSize=9, leading=11.5, spaceBefore=4, spaceAfter=3),
            "figcap": P("figcap", fontName=f["regular"], fontSize=8, leading=10, textColor=muted),
            "meta_k": P("meta_k", fontName=f["regular"], fontSize=9, leading=11.5, textColor=muted),
            "meta_v": P("meta_v", fontName=f["regular"], fontSize=9, leading=11.5, textColor=ink),
            "badge": P("badge", fontName=f["bold"], fontSize=8, leading=10, alignment=TA_CENTER),
            "rule": P("rule", fontName=f["regular"], fontSize=7.5, leading=9.5, textColor=muted, alignment=TA_RIGHT),
            "warn": P("warn", fontName=f["regular"], fontSize=9.5, leading=13),
        }

    # ----------------------------------------------------------------- helpers
    def _p(self, s: Any, style: str, markup: bool = False):
        from reportlab.platypus import Paragraph as P

        return P(s if markup else _x(s), self.st[style])

    def _widths(self, columns: list[str], rows: list[list[Any]], styles: list[str]) -> list[float]:
        """Column widths from the text they hold, shrunk to the page where needed.

        Narrow columns keep their natural width; the rest share what is left in
        proportion to their natural widths, and their Paragraph cells wrap.
        """
        from reportlab.pdfbase.pdfmetrics import stringWidth

        pad = 12.0
        nat = []
        for j, c in enumerate(columns):
            fs = self.st[styles[j]]
            w = stringWidth(c, self.f["bold"], 8.5)
            for r in rows:
                for line in text(r[j]).split("\n"):
                    w = max(w, stringWidth(line, fs.fontName, fs.fontSize))
            nat.append(w + pad)
        total = sum(nat)
        if total <= self.width:
            return nat
        fair = self.width / len(nat)
        narrow = [w for w in nat if w <= fair]
        wide_total = total - sum(narrow)
        room = self.width - sum(narrow)
        return [w if w <= fair else w * room / wide_total for w in nat]

    def _table_style(self, n_rows: int, header: bool = True, zebra: bool = True):
        from reportlab.platypus import TableStyle

        cmds = [
            ("GRID", (0, 0), (-1, -1), 0.5, self.rule),
            ("VALIGN", (0, 0), (-1, -1), "TOP"),
            ("TOPPADDING", (0, 0), (-1, -1), 2.5),
            ("BOTTOMPADDING", (0, 0), (-1, -1), 3),
            ("LEFTPADDING", (0, 0), (-1, -1), 5),
            ("RIGHTPADDING", (0, 0), (-1, -1), 5),
        ]
        if header:
            cmds.append(("BACKGROUND", (0, 0), (-1, 0), self.head_bg))
        if header and zebra:  # every second body row, as in the HTML
            cmds += [("BACKGROUND", (0, i), (-1, i), self.zebra) for i in range(2, n_rows, 2)]
        return TableStyle(cmds)

    # ----------------------------------------------------------------- blocks
    def table(self, columns: list[str], rows: list[list[Any]], align: list[str], caption: str = "") -> list:
        from reportlab.platypus import CondPageBreak
        from reportlab.platypus import Table as T

        suffix = {"left": "", "right": "_r", "center": "_c"}
        styles = [
            "mono" if c.lower() in ("sha256", "sha-256", "hash") else "cell" + suffix[a] for c, a in zip(columns, align)
        ]
        data = [[self._p(c, "head" + suffix[a]) for c, a in zip(columns, align)]]
        data += [[self._p(v, s) for v, s in zip(r, styles)] for r in rows]
        t = T(data, colWidths=self._widths(columns, rows, styles), repeatRows=1, hAlign="LEFT")
        t.setStyle(self._table_style(len(data)))
        # A long table may start low on a page and continue on the next (header
        # repeated); it only moves on if its caption and first rows would not fit.
        out = [CondPageBreak(25 * self.mm)]
        if caption:
            out.append(self._p(caption, "caption"))
        return out + [t, self._space(4)]

    def keyvalues(self, items: list[tuple[str, Any]], caption: str = "") -> list:
        from reportlab.platypus import Table as T

        data = [[self._p(k, "head"), self._p(v, "cell")] for k, v in items]
        w = self._widths(["", ""], [[k, v] for k, v in items], ["head", "cell"])
        kw = min(w[0], 0.4 * self.width)
        t = T(data, colWidths=[kw, min(w[1], self.width - kw)], hAlign="LEFT", repeatRows=0)
        style = self._table_style(len(data), header=False)
        style.add("BACKGROUND", (0, 0), (0, -1), self.head_bg)
        t.setStyle(style)
        return ([self._p(caption, "caption")] if caption else []) + [t, self._space(4)]

    def figure_row(self, row: FigureRow) -> list:
        from reportlab.platypus import Image, TableStyle
        from reportlab.platypus import Table as T

        mm = self.mm
        used = sum(f.width_mm for f in row.figures) + FIGURE_GAP_MM * (len(row.figures) - 1)
        scale = min(1.0, CONTENT_WIDTH_MM / used)
        max_h = 200.0  # mm: leaves room for the caption and the footer on an A4 page
        cells, widths = [], []
        for f in row.figures:
            w = f.width_mm * scale
            h = f.height_mm * scale
            if h > max_h:
                w, h = w * max_h / h, max_h
            cell = [Image(io.BytesIO(f.png), width=w * mm, height=h * mm, hAlign="LEFT")]
            if f.caption:
                cell += [self._space(2), self._p(f.caption, "figcap")]
            cells.append(cell)
            widths.append(w * mm + FIGURE_GAP_MM * mm)
        widths[-1] -= FIGURE_GAP_MM * mm
        t = T([cells], colWidths=widths, hAlign="LEFT")
        t.setStyle(
            TableStyle(
                [
                    ("VALIGN", (0, 0), (-1, -1), "TOP"),
                    ("LEFTPADDING", (0, 0), (-1, -1), 0),
                    ("RIGHTPADDING", (0, 0), (-1, -1), 0),
                    ("TOPPADDING", (0, 0), (-1, -1), 0),
                    ("BOTTOMPADDING", (0, 0), (-1, -1), 0),
                ]
            )
        )
        return [self._space(4), t, self._space(8)]

    def _badge(self, word: str | None):
        """A verdict word on its colour, as a one-cell table (rounded corners)."""
        from reportlab.platypus import Paragraph as P
        from reportlab.platypus import Table as T
        from reportlab.platypus import TableStyle

        if word is None:  # this rule was not applied to this parameter
            return self._p(None, "cell_c")
        (bg, fg), label = VERDICT_COLOURS[word], verdict_words(word).upper()
        st = self.st["badge"].clone("badge_" + word, textColor=self.colors.HexColor(fg))
        t = T([[P(html.escape(label), st)]], colWidths=[BADGE_MM * self.mm])
        t.setStyle(
            TableStyle(
                [
                    ("BACKGROUND", (0, 0), (-1, -1), self.colors.HexColor(bg)),
                    ("ROUNDEDCORNERS", [5, 5, 5, 5]),
                    ("TOPPADDING", (0, 0), (-1, -1), 1.5),
                    ("BOTTOMPADDING", (0, 0), (-1, -1), 2.5),
                    ("LEFTPADDING", (0, 0), (-1, -1), 2),
                    ("RIGHTPADDING", (0, 0), (-1, -1), 2),
                ]
            )
        )
        return t

    def verdicts(self, vt: VerdictTable) -> list:
        from reportlab.platypus import KeepTogether
        from reportlab.platypus import Table as T

        mm = self.mm
        cols = vt.columns()
        head = [
            self._p(
                "<i>U</i>" if c == "U" else html.escape(c),
                "head_c" if c.endswith("rule") else ("head_r" if c in ("Value", "Limit", "U") else "head"),
                markup=True,
            )
            for c in cols
        ]
        data = [head]
        for v in vt.verdicts:
            row = []
            for c in cols:
                x = vt.cell(v, c)
                if c.endswith("rule"):
                    row.append(self._badge(x))
                elif c == "Parameter":
                    row.append(self._p(x, "head"))
                elif c == "Note":
                    row.append(self._p(x, "figcap"))
                else:
                    row.append(self._p(x, "cell_r"))
            data.append(row)
        fixed = {"Simple rule": (BADGE_MM + 4) * mm, "Guarded rule": (BADGE_MM + 4) * mm}
        nat = self._widths(
            cols,
            [[vt.cell(v, c) if not c.endswith("rule") else "" for c in cols] for v in vt.verdicts],
            ["cell"] * len(cols),
        )
        widths = [fixed.get(c, w) for c, w in zip(cols, nat)]
        if "Note" in cols:  # the note takes what is left, up to the text width
            i = cols.index("Note")
            widths[i] = max(30 * mm, self.width - (sum(widths) - widths[i]))
        t = T(data, colWidths=widths, repeatRows=1, hAlign="LEFT")
        style = self._table_style(len(data), header=True, zebra=False)  # the badges carry the colour
        style.add("VALIGN", (0, 0), (-1, -1), "MIDDLE")
        style.add("TOPPADDING", (0, 1), (-1, -1), 4)
        style.add("BOTTOMPADDING", (0, 1), (-1, -1), 4)
        t.setStyle(style)
        # a handful of verdicts reads as one statement: keep it on one page
        return [KeepTogether([t]) if len(data) <= 12 else t, self._space(4)]

    def warning(self, w: Warning_) -> list:
        from reportlab.platypus import Table as T
        from reportlab.platypus import TableStyle

        amber = self.colors.HexColor("#f0a500")
        t = T(
            [[self._p(f'<font color="#8a5a00"><b>Warning:</b></font> {_x(w.text)}', "warn", markup=True)]],
            colWidths=[self.width],
            hAlign="LEFT",
        )
        t.setStyle(
            TableStyle(
                [
                    ("BACKGROUND", (0, 0), (-1, -1), self.colors.HexColor("#fff4d6")),
                    ("LINEBEFORE", (0, 0), (0, -1), 4, amber),
                    ("LEFTPADDING", (0, 0), (-1, -1), 9),
                    ("TOPPADDING", (0, 0), (-1, -1), 5),
                    ("BOTTOMPADDING", (0, 0), (-1, -1), 6),
                ]
            )
        )
        return [t, self._space(5)]

    def _space(self, pt: float):
        from reportlab.platypus import Spacer

        return Spacer(1, pt)

    def block(self, b: Any) -> list:
        if isinstance(b, Paragraph):
            return [self._p(b.text, "body")]
        if isinstance(b, KeyValues):
            return self.keyvalues(b.items, b.caption)
        if isinstance(b, Table):
            return self.table(b.columns, b.rows, b.align, b.caption)
        if isinstance(b, FigureRow):
            return self.figure_row(b)
        if isinstance(b, VerdictTable):
            return self.verdicts(b)
        if isinstance(b, Warning_):
            return self.warning(b)
        if isinstance(b, Signature):
            return self.signature(b)
        raise TypeError(f"unknown report block {type(b).__name__}")

    # ----------------------------------------------------------------- document
    def story(self) -> list:
        from reportlab.platypus import HRFlowable, TableStyle
        from reportlab.platypus import Table as T

        r = self.report
        story: list = [self._p(r.title, "title")]
        if r.subtitle:
            story.append(self._p(r.subtitle, "subtitle"))
        story.append(
            HRFlowable(width="100%", thickness=1.5, color=self.colors.HexColor("#1a1a1a"), spaceBefore=6, spaceAfter=4)
        )
        if r.meta:
            data = [[self._p(k, "meta_k"), self._p(v, "meta_v")] for k, v in r.meta.items()]
            t = T(data, colWidths=[40 * self.mm, self.width - 40 * self.mm], hAlign="LEFT")
            t.setStyle(
                TableStyle(
                    [
                        ("LEFTPADDING", (0, 0), (-1, -1), 0),
                        ("TOPPADDING", (0, 0), (-1, -1), 0.5),
                        ("BOTTOMPADDING", (0, 0), (-1, -1), 0.5),
                    ]
                )
            )
            story.append(t)
        started = False
        for heading, blocks, appendix in headed_sections(r):
            if appendix and not started:  # the records behind the results start a page
                from reportlab.platypus import PageBreak

                story += [PageBreak(), self._p("Appendix", "title")]
                started = True
            story += self.section(heading, blocks)
        return story

    def signature(self, sig: Signature) -> list:
        """One row per party: role, name, and empty date and signature cells tall enough to sign."""
        from reportlab.platypus import KeepTogether, TableStyle
        from reportlab.platypus import Table as T

        mm = self.mm
        data = [[self._p("", "head"), self._p("Name", "head"), self._p("Date", "head"), self._p("Signature", "head")]]
        data += [[self._p(r, "head"), self._p(n, "cell"), "", ""] for r, n in sig.parties]
        widths = [35 * mm, 50 * mm, 30 * mm, self.width - 115 * mm]
        t = T(data, colWidths=widths, rowHeights=[None] + [16 * mm] * len(sig.parties), hAlign="LEFT")
        t.setStyle(
            TableStyle(
                [
                    ("GRID", (0, 0), (-1, -1), 0.5, self.rule),
                    ("BACKGROUND", (0, 0), (-1, 0), self.head_bg),
                    ("VALIGN", (0, 0), (-1, -1), "TOP"),
                ]
            )
        )
        return [self._space(8), KeepTogether([t])]

    def section(self, title: str, blocks: list) -> list:
        """A heading and its blocks; the heading never ends a page alone.

        It stays with its first block (KeepTogether) unless that is a table, which
        may be long and is allowed to split: then a conditional page break makes sure
        the heading, caption and a few rows fit.
        """
        from reportlab.platypus import CondPageBreak, KeepTogether

        heading = self._p(title, "h2")
        if not blocks:
            return [CondPageBreak(30 * self.mm), heading]
        # a KeepTogether inside the heading's KeepTogether makes reportlab start a new page
        # whatever room is left (a verdict table after the title page's meta): unwrap it
        first = [g for f in self.block(blocks[0]) for g in (f._content if isinstance(f, KeepTogether) else [f])]
        if isinstance(blocks[0], Table):
            out = [CondPageBreak(40 * self.mm), heading] + first
        else:
            out = [KeepTogether([heading] + first)]
        for b in blocks[1:]:
            out += self.block(b)
        return out


def _canvas_class(title: str, font: str):
    """A canvas that knows the page count when it draws each footer ("page i of n")."""
    from reportlab.lib import colors
    from reportlab.lib.pagesizes import A4
    from reportlab.lib.units import mm
    from reportlab.pdfgen.canvas import Canvas

    class FooterCanvas(Canvas):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self._pages: list[dict] = []

        def showPage(self):  # keep the page; draw footers once the count is known
            self._pages.append(dict(self.__dict__))
            self._startPage()

        def save(self):
            n = len(self._pages)
            for i, state in enumerate(self._pages, 1):
                self.__dict__.update(state)
                self.saveState()
                self.setStrokeColor(colors.HexColor("#c9ced6"))
                self.setLineWidth(0.5)
                y = 12 * mm
                self.line(MARGIN_MM * mm, y + 4 * mm, A4[0] - MARGIN_MM * mm, y + 4 * mm)
                self.setFont(font, 7.5)
                self.setFillColor(colors.HexColor("#5b6470"))
                t = title if len(title) <= 100 else title[:97] + "..."
                self.drawString(MARGIN_MM * mm, y, t)
                self.drawRightString(A4[0] - MARGIN_MM * mm, y, f"page {i} of {n}")
                self.restoreState()
                super().showPage()
            super().save()

    return FooterCanvas


def render_pdf(report) -> bytes:
    """The whole report as PDF bytes."""
    from reportlab import rl_config
    from reportlab.lib.pagesizes import A4
    from reportlab.lib.units import mm
    from reportlab.platypus import SimpleDocTemplate

    b = _Builder(report)
    prov = report.provenance_dict()
    buf = io.BytesIO()
    doc = SimpleDocTemplate(
        buf,
        pagesize=A4,
        leftMargin=MARGIN_MM * mm,
        rightMargin=MARGIN_MM * mm,
        topMargin=18 * mm,
        bottomMargin=22 * mm,
        title=report.title,
        subject=report.subtitle,
        author=prov["software"],
        creator=prov["environment"]["report_generator"],
    )
    # ASCII85 makes every image stream 25 % larger and, without reportlab's C
    # accelerator, takes most of the time of a report with figures; PDF streams are
    # binary-safe, so it is switched off while this PDF is made.
    a85, rl_config.useA85 = rl_config.useA85, 0
    try:
        doc.build(b.story(), canvasmaker=_canvas_class(report.title, b.f["regular"]))
    finally:
        rl_config.useA85 = a85
    return buf.getvalue()
