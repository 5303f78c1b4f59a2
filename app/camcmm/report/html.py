"""The report as one self-contained HTML file.

Self-contained because a report is archived and mailed: inline CSS, images as base64
data URIs, no scripts that run and nothing fetched from the network. Every piece of
text goes through :func:`html.escape` — names come from users' files, and a file called
``<script>.ply`` must show as text, not run. The machine-readable result is embedded as
``<script type="application/json" id="camcmm-data">``, which browsers never execute.
"""

from __future__ import annotations

import base64
import html
import json
from typing import Any

from ..conformity import verdict_words
from .blocks import (
    CONTENT_WIDTH_MM,
    FIGURE_GAP_MM,
    Figure,
    FigureRow,
    KeyValues,
    Paragraph,
    Signature,
    Table,
    VerdictTable,
    Warning_,
    headed_sections,
    jsonable,
    text,
)

# Badge colours; the PDF uses the same ones (pdf.py imports them).
VERDICT_COLOURS = {
    "pass": ("#1e7b34", "#ffffff"),  # green
    "fail": ("#c62828", "#ffffff"),  # red
    "inconclusive": ("#f0a500", "#1a1a1a"),  # amber
    "incomplete": ("#6b7280", "#ffffff"),  # grey: not evaluated, neither good nor bad
}

_CSS = """
:root { --ink:#1a1a1a; --muted:#5b6470; --rule:#c9ced6; --head:#eef1f5; --zebra:#f8f9fb; }
* { box-sizing: border-box; }
html { -webkit-print-color-adjust: exact; print-color-adjust: exact; }
body { margin: 0; background: #e9ecf0; color: var(--ink);
       font: 14px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial,
             "DejaVu Sans", sans-serif; }
main { max-width: 960px; margin: 24px auto; background: #fff; padding: 40px 48px 32px;
       box-shadow: 0 1px 4px rgba(0,0,0,.15); }
header.title { border-bottom: 2px solid var(--ink); padding-bottom: 12px; margin-bottom: 8px; }
h1 { font-size: 26px; margin: 0 0 4px; line-height: 1.2; }
.subtitle { font-size: 17px; color: var(--muted); margin: 0; }
h2 { font-size: 19px; margin: 28px 0 10px; padding-bottom: 4px; border-bottom: 1px solid var(--rule);
     break-after: avoid; page-break-after: avoid; }
p { margin: 8px 0; white-space: pre-wrap; }
table { border-collapse: collapse; margin: 10px 0 14px; font-size: 13px; max-width: 100%; }
table.data { width: auto; min-width: 50%; }
th, td { border: 1px solid var(--rule); padding: 4px 8px; vertical-align: top;
         overflow-wrap: break-word; }
th { background: var(--head); font-weight: 600; text-align: left; }
table.data tbody tr:nth-child(even) td, table.kv tbody tr:nth-child(even) td { background: var(--zebra); }
td.r, th.r { text-align: right; font-variant-numeric: tabular-nums; }
td.c, th.c { text-align: center; }
table.kv th { width: 34%; font-weight: 600; background: var(--head); }
table.kv td { min-width: 12em; }
table.meta { border: none; margin: 6px 0 0; }
table.meta th, table.meta td { border: none; background: none; padding: 1px 14px 1px 0; }
table.meta th { color: var(--muted); font-weight: 500; }
caption { caption-side: top; text-align: left; font-weight: 600; padding: 0 0 4px; color: var(--ink); }
thead { display: table-header-group; }
tr { break-inside: avoid; page-break-inside: avoid; }
.figrow { display: flex; gap: @GAP@%; justify-content: flex-start; align-items: flex-start;
          margin: 10px 0 14px; }
figure { margin: 0; break-inside: avoid; page-break-inside: avoid; }
figure img { width: 100%; height: auto; display: block; border: 1px solid #e3e6ea; }
figcaption { font-size: 12px; color: var(--muted); margin-top: 4px; }
table.verdicts { width: 100%; }
table.verdicts th, table.verdicts td.r { white-space: nowrap; }
table.verdicts th, table.verdicts td { vertical-align: middle; padding: 6px 10px; }
table.verdicts tbody th { background: none; font-weight: 700; }
table.verdicts tbody tr td { background: #fff; }
table.verdicts td.note { color: var(--muted); font-size: 12px; text-align: left; }
.badge { display: inline-block; white-space: nowrap; padding: 2px 10px; border-radius: 10px; font-weight: 700;
         font-size: 12px; letter-spacing: .04em; text-transform: uppercase; }
.warning { background: #fff4d6; border-left: 5px solid #f0a500; padding: 8px 12px; margin: 10px 0;
           white-space: pre-wrap; break-inside: avoid; }
.warning b { color: #8a5a00; }
section.provenance td, section.appendix td { font-size: 12px; }
section.appendix h2 { color: var(--muted); }
h2.appendix { border-bottom: 2px solid var(--ink); margin-top: 40px; break-before: page; page-break-before: always; }
table.signature { width: 100%; margin-top: 18px; }
table.signature td { height: 56px; }
td.mono { word-break: break-all; font-family: "DejaVu Sans Mono", Menlo, Consolas, monospace; font-size: 11.5px; }
footer { margin-top: 28px; padding-top: 8px; border-top: 1px solid var(--rule); color: var(--muted);
         font-size: 12px; }
@page { size: A4; margin: 18mm 20mm; }
@media print {
  body { background: #fff; font-size: 10.5pt; }
  main { max-width: none; margin: 0; padding: 0; box-shadow: none; }
}
""".replace("@GAP@", f"{100 * FIGURE_GAP_MM / CONTENT_WIDTH_MM:.2f}")


def _e(x: Any) -> str:
    return html.escape(text(x), quote=True)


def _badge(word: str | None) -> str:
    if word is None:  # this rule was not applied to this parameter
        return "\u2014"
    bg, fg = VERDICT_COLOURS[word]
    # the key names the colour; the badge says it in words ("passed", as the pages do)
    return f'<span class="badge v-{word}" style="background:{bg};color:{fg}">{html.escape(verdict_words(word))}</span>'


def _is_hash(col: str) -> bool:
    return col.lower() in ("sha256", "sha-256", "hash")


def _table(columns: list[str], rows: list[list[Any]], align: list[str], caption: str = "", cls: str = "data") -> str:
    a = {"left": "", "right": "r", "center": "c"}
    out = [f'<table class="{cls}">']
    if caption:
        out.append(f"<caption>{html.escape(caption)}</caption>")
    out.append(
        "<thead><tr>"
        + "".join(f'<th class="{a[al]}">{html.escape(c)}</th>' for c, al in zip(columns, align))
        + "</tr></thead><tbody>"
    )
    # hashes in a monospace face that may break anywhere (64 hex digits fit no column)
    classes = [" ".join(filter(None, (a[al], "mono" if _is_hash(c) else ""))) for c, al in zip(columns, align)]
    for r in rows:
        out.append("<tr>" + "".join(f'<td class="{k}">{_e(v)}</td>' for v, k in zip(r, classes)) + "</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def _keyvalues(items: list[tuple[str, Any]], cls: str = "kv", caption: str = "") -> str:
    rows = "".join(f"<tr><th>{html.escape(k)}</th><td>{_e(v)}</td></tr>" for k, v in items)
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f'<table class="{cls}">{cap}<tbody>{rows}</tbody></table>'


def _figure(f: Figure, scale: float) -> str:
    pct = 100.0 * f.width_mm * scale / CONTENT_WIDTH_MM
    uri = "data:image/png;base64," + base64.b64encode(f.png).decode("ascii")
    cap = f"<figcaption>{html.escape(f.caption)}</figcaption>" if f.caption else ""
    alt = html.escape(f.caption or "figure", quote=True)
    return f'<figure style="width:{pct:.2f}%" data-sha256="{f.sha256}"><img src="{uri}" alt="{alt}">{cap}</figure>'


def _verdicts(t: VerdictTable) -> str:
    cols = t.columns()
    head = "".join(
        ('<th class="c">' if c.endswith("rule") else "<th>") + ("<i>U</i>" if c == "U" else html.escape(c)) + "</th>"
        for c in cols
    )
    rows = []
    for v in t.verdicts:
        cells = []
        for c in cols:
            x = t.cell(v, c)
            if c.endswith("rule"):
                cells.append(f'<td class="c">{_badge(x)}</td>')
            elif c == "Parameter":
                cells.append(f"<th>{html.escape(x)}</th>")
            else:
                cells.append(
                    f'<td class="note">{html.escape(x)}</td>' if c == "Note" else f'<td class="r">{_e(x)}</td>'
                )
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return f'<table class="verdicts"><thead><tr>{head}</tr></thead><tbody>{"".join(rows)}</tbody></table>'


def _block(b: Any) -> str:
    if isinstance(b, Paragraph):
        return f"<p>{html.escape(b.text)}</p>"
    if isinstance(b, KeyValues):
        return _keyvalues(b.items, caption=b.caption)
    if isinstance(b, Table):
        return _table(b.columns, b.rows, b.align, b.caption)
    if isinstance(b, FigureRow):
        used = sum(f.width_mm for f in b.figures) + FIGURE_GAP_MM * (len(b.figures) - 1)
        scale = min(1.0, CONTENT_WIDTH_MM / used) if used > 0 else 1.0
        return '<div class="figrow">' + "".join(_figure(f, scale) for f in b.figures) + "</div>"
    if isinstance(b, VerdictTable):
        return _verdicts(b)
    if isinstance(b, Warning_):
        return f'<div class="warning"><b>Warning:</b> {html.escape(b.text)}</div>'
    if isinstance(b, Signature):
        rows = "".join(
            f"<tr><th>{html.escape(r)}</th><td>{html.escape(n)}</td><td></td><td></td></tr>" for r, n in b.parties
        )
        head = "<thead><tr><th></th><th>Name</th><th>Date</th><th>Signature</th></tr></thead>"
        return f'<table class="signature">{head}<tbody>{rows}</tbody></table>'
    raise TypeError(f"unknown report block {type(b).__name__}")


def _script_json(data: Any) -> str:
    """JSON that is safe inside <script>: '<', '>' and '&' as \\u escapes, so a string
    containing ``</script>`` cannot close the element; json.loads reads it back equal."""
    s = json.dumps(jsonable(data), ensure_ascii=False, allow_nan=False)
    return s.replace("&", "\\u0026").replace("<", "\\u003c").replace(">", "\\u003e")


def render_html(report) -> str:
    """The whole report as an HTML document (str)."""
    prov = report.provenance_dict()
    out = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f'<meta name="generator" content="{html.escape(prov["environment"]["report_generator"], quote=True)}">',
        f"<title>{html.escape(report.title)}</title>",
        f"<style>{_CSS}</style></head><body><main>",
        '<header class="title">',
        f"<h1>{html.escape(report.title)}</h1>",
    ]
    if report.subtitle:
        out.append(f'<p class="subtitle">{html.escape(report.subtitle)}</p>')
    if report.meta:
        out.append(_keyvalues([(k, v) for k, v in report.meta.items()], cls="meta"))
    out.append("</header>")
    started = False
    for heading, blocks, appendix in headed_sections(report):
        if appendix and not started:  # the records behind the results, after them
            out.append('<h2 class="appendix">Appendix</h2>')
            started = True
        cls = "appendix" if appendix else ("provenance" if heading == "Provenance" else "")
        out.append(
            f'<section class="{cls}"><h2>{html.escape(heading)}</h2>'
            if cls
            else f"<section><h2>{html.escape(heading)}</h2>"
        )
        out.extend(_block(b) for b in blocks)
        out.append("</section>")
    out.append(
        f"<footer>{html.escape(report.title)} &middot; generated {html.escape(report.created)} by "
        f"{html.escape(prov['software'])} &middot; the machine-readable result is embedded in this "
        f"file (script id &quot;camcmm-data&quot;) and in the JSON file beside it.</footer>"
    )
    out.append(
        f'</main><script type="application/json" id="camcmm-data">{_script_json(report.data)}</script></body></html>'
    )
    return "\n".join(out)
