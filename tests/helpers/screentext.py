"""The text a person reads on the GUI's pages and in the reports, and the internal names in it.

Issue 30: a lab must not meet the program's own vocabulary where it reads results — no
parameter keys (``sigma_px``), plugin ids (``fit.line``), code keywords (``=True``), raw
YAML/JSON, ASCII units (``um``, ``urad``), scientific notation in a number a person reads
(``6.55e-12``) or an item name that says its test twice (``sphere-sphere-01.ply``).

Two halves:

- :func:`findings` — the detector: every forbidden token in one text, as
  ``(rule, token)`` pairs. File names, URLs, paths and hashes are data and are taken out
  first (a measured file may be called ``sphere_01.ply``).
- :func:`page_texts` and :func:`report_texts` — what a person sees: a built trame server's
  layout (the static words of the template, the string literals its bindings show, and the
  state values its mustaches, display attributes, lists and figures show, with ``v-for``
  aliases followed to their state key) and the text of an HTML and a PDF report.

The GUI is read without a browser, so a text built in the browser's own JavaScript is not
seen; the state and the template are everything the server sends.
"""

from __future__ import annotations

import html as html_lib
import math
import re
from collections.abc import Iterable, Iterator
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import numpy as np

# -- the detector -----------------------------------------------------------------------------
#: data, not vocabulary: removed before the rules run
_DATA = [
    re.compile(r"https?://\S+"),
    re.compile(r"(?<![\w.])(?:[A-Za-z]:)?(?:~|\.{1,2})?(?:/[\w.+\-@]+){2,}/?"),  # a path
    re.compile(r"\b[0-9a-f]{12,}\b"),  # sha256 and other hashes
    re.compile(
        r"[\w.+\-()\[\]]+\.(?:ply|stl|obj|e57|pcd|xyz|pts|las|laz|asc|csv|txt|png|jpe?g|tiff?|bmp|step|stp|iges|igs|"
        r"ya?ml|json|html?|pdf|npz|npy|zip|qif|xml|py|sqlite)\b",
        re.IGNORECASE,
    ),
]

RULES: dict[str, re.Pattern[str]] = {
    # 6.55e-12, 1E+05: never for a number a person reads
    "scientific notation": re.compile(r"(?<![\w.])[-+−]?\d+(?:\.\d+)?[eE][-+−]?\d+(?![\w.])"),
    # sigma_px, verdict_guarded, volume_maps, p2_5: a key, not a word
    "internal key": re.compile(r"(?<![\w-])[a-z][a-z0-9]+(?:_[a-z0-9]+)+(?![\w-])"),
    # SIMPLE_RADIAL, OPENCV_FISHEYE: a constant's name
    "constant name": re.compile(r"(?<![\w-])[A-Z][A-Z0-9]+(?:_[A-Z0-9]{2,})+(?![\w-])"),
    # fit.line, lightfield.gradient, virtuallab.fringe-system: a plugin id
    "plugin id": re.compile(r"(?<![\w.\-/])[a-z][a-z0-9]+(?:\.[a-z][a-z0-9]*(?:-[a-z0-9]+)*)+(?!\w|[.\-/]\w)"),
    # allow_unhomed=True, sigma_px = 6: code
    "code": re.compile(r"\w+\s*=\s*(?:True|False|None)\b|\b[a-z]\w*_\w+\s*=\s*[-+]?\d"),
    # {"a": 1}, {'a': 1}: raw JSON / a Python dict
    "raw JSON": re.compile(r"[\[{]\s*[\"']\w+[\"']\s*[:,]"),
    # key: value lines, as YAML shows them
    "raw YAML": re.compile(r"(?m)^\s*-?\s*[a-z]\w*:\s*\S.*\n\s*-?\s*[a-z]\w*:\s*\S"),
    # um, urad: ASCII for µm, µrad
    "ASCII unit": re.compile(r"(?<![\w-])(?:um|urad)(?![\w-])"),
    # `overlap`: a name in backticks, as in a docstring, is code shown to a person
    "code in backticks": re.compile(r"`[^`\n]{1,60}`"),
}
#: a word with a dot that is not a plugin id
_NOT_IDS = {"e.g", "i.e", "cf", "vs", "etc", "approx"}


def without_data(text: str) -> str:
    """``text`` with file names, URLs, paths and hashes blanked out (they are the user's data)."""
    for pattern in _DATA:
        text = pattern.sub(" ", text)
    return text


def doubled(token: str) -> bool:
    """True when a name says one of its parts twice in a row, ``-`` and ``_`` alike:
    ``sphere-sphere-01.ply``, ``ball_bar-ball-bar-01.ply`` (a number repeated, as in a date
    ``2026-11-11``, is not a name; nor is a word without a number, ``camera-camera``)."""
    if not any(c.isdigit() for c in token):
        return False
    parts = [p.lower() for p in re.split(r"[-_]", token) if p]
    for k in range(1, len(parts) // 2 + 1):
        for i in range(len(parts) - 2 * k + 1):
            if parts[i : i + k] == parts[i + k : i + 2 * k] and any(c.isalpha() for c in "".join(parts[i : i + k])):
                return True
    return False


def findings(text: str, plugin_ids: Iterable[str] = ()) -> list[tuple[str, str]]:
    """Every forbidden token in ``text``: ``[(rule, token), ...]``.

    ``plugin_ids``: the ids of the installed plugins, flagged also where they hold no dot
    (``vdi2634-2``)."""
    out: list[tuple[str, str]] = []
    for token in re.findall(r"[\w.\-]+", text):  # before the file names go: they are where names double
        if ("-" in token or "_" in token) and doubled(token.strip(".-_")):
            out.append(("doubled name", token))
    clean = without_data(text)
    for rule, pattern in RULES.items():
        for m in pattern.finditer(clean):
            token = m.group(0).strip()
            if rule == "plugin id" and (token.lower() in _NOT_IDS or re.fullmatch(r"[a-z]{1,2}(\.[a-z]{1,2})+", token)):
                continue
            out.append((rule, token))
    for pid in plugin_ids:
        if "." not in pid and re.search(rf"(?<![\w.\-/]){re.escape(pid)}(?![\w\-/])", clean):
            out.append(("plugin id", pid))
    return out


# -- the GUI's text ---------------------------------------------------------------------------
#: attributes whose value a person reads (static, or bound with ':'/'v-bind:')
DISPLAY_ATTRS = {
    "title",
    "label",
    "text",
    "hint",
    "placeholder",
    "subtitle",
    "messages",
    "error-messages",
    "prefix",
    "suffix",
    "aria-label",
    "content",
    "no-data-text",
    "loading-text",
    "append-inner-text",
    "value-comparison",
}
#: the fields of a list's entries a select shows when it names none (Vuetify's item-title)
_ITEM_TITLE = "title"
_STRING = re.compile(r"'((?:[^'\\]|\\.)*)'|\"((?:[^\"\\]|\\.)*)\"|`((?:[^`\\]|\\.)*)`")
#: a string literal compared or looked up is a key, not a word shown
_KEY_CONTEXT = re.compile(r"(?:===?|!==?|\bin\b|includes\(|\[)\s*$")
_KEY_AFTER = re.compile(r"^\s*(?:===?|!==?|\]|\bin\b)")
_REF = re.compile(r"(?<![\w.'\"$])([A-Za-z_]\w*(?:\.[A-Za-z_]\w*|\[\d+\])*)")
#: ``{{ JSON.stringify(x) }}``: a stored record shown as it is kept (Inspect's folded "Result
#: JSON (as stored)"), read like a report's provenance — identifiers by design; left out
_RECORD = re.compile(r"\s*JSON\.stringify\(")
_VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source", "track", "wbr"}
_JS_WORDS = {"true", "false", "null", "undefined", "typeof", "in", "of", "new", "return", "this", "Math", "Number"}


def js_text(v: Any) -> str:
    """A value as Vue writes it into the page (JavaScript's number formatting: exponential
    below 1e-6 and from 1e21)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return "NaN" if v != v else ("Infinity" if v > 0 else "-Infinity")
        if v != 0 and (abs(v) < 1e-6 or abs(v) >= 1e21):  # the shortest digits, exponent as JS writes it
            return re.sub(r"e([-+])0*(\d)", lambda m: f"e{'+' if m.group(1) == '+' else '-'}{m.group(2)}", repr(v))
        return np.format_float_positional(v, trim="-")
    return "" if v is None else str(v)


def _leaves(v: Any) -> Iterator[str]:
    if isinstance(v, dict):
        for x in v.values():
            yield from _leaves(x)
    elif isinstance(v, (list, tuple)):
        for x in v:
            yield from _leaves(x)
    elif v is not None and not isinstance(v, bool):
        yield js_text(v)


def _follow(v: Any, path: list[str]) -> list[Any]:
    """The values at ``path`` under ``v``, mapping over lists (a ``v-for`` alias)."""
    vals = [v]
    for step in path:
        nxt: list[Any] = []
        for x in vals:
            if isinstance(x, (list, tuple)) and not step.isdigit():
                nxt.extend(y.get(step) for y in x if isinstance(y, dict))
            elif isinstance(x, dict):
                nxt.append(x.get(step))
            elif isinstance(x, (list, tuple)) and step.isdigit() and int(step) < len(x):
                nxt.append(x[int(step)])
        vals = nxt
    return vals


def _figure_text(fig: Any) -> Iterator[str]:
    """The words of a plotly figure: titles, axis titles, annotations, trace names, tick texts."""
    if not isinstance(fig, dict):
        return
    layout = fig.get("layout") or {}
    for k, axis in layout.items():
        if isinstance(axis, dict) and (k.startswith(("xaxis", "yaxis", "coloraxis")) or k == "title"):
            t = axis.get("title", axis.get("text"))
            yield from _leaves(t.get("text") if isinstance(t, dict) else t)
            yield from _leaves(axis.get("ticktext"))
    for a in layout.get("annotations") or []:
        yield from _leaves(a.get("text"))
    for trace in fig.get("data") or []:
        if isinstance(trace, dict):
            yield from _leaves(trace.get("name"))
            yield from _leaves(trace.get("text") if isinstance(trace.get("text"), str) else None)
            bar = (trace.get("marker") or {}).get("colorbar") or trace.get("colorbar") or {}
            t = bar.get("title")
            yield from _leaves(t.get("text") if isinstance(t, dict) else t)


class _Template(HTMLParser):
    """Walks a trame layout, keeping each ``v-for`` alias's state path in scope."""

    def __init__(self, state: dict[str, Any]):
        super().__init__(convert_charrefs=True)
        self.state = state
        self.scopes: list[dict[str, tuple[str, list[str]]]] = [{}]
        self.pages: list[str] = ["(every page)"]  # the page an element shows on, per open element
        self.out: list[tuple[str, str]] = []

    # -- expressions --
    def resolve(self, ref: str) -> tuple[str, list[str]] | None:
        parts = re.findall(r"[A-Za-z_]\w*|\d+", ref)
        if not parts or parts[0] in _JS_WORDS:
            return None
        for scope in reversed(self.scopes):
            if parts[0] in scope:
                key, path = scope[parts[0]]
                return key, path + parts[1:]
        return (parts[0], parts[1:]) if parts[0] in self.state else None

    def values(self, expr: str) -> list[Any]:
        """What a bound expression shows: its literal words and the state values it names
        (of ``a || b``, the first alternative that has a value)."""
        if "||" in expr and "?" not in expr:
            for alternative in expr.split("||"):
                found = self.values(alternative)
                if any(x not in (None, "", [], {}) for x in found):
                    return found
            return []
        shown: list[Any] = []
        code = expr
        for m in _STRING.finditer(expr):
            lit = next(g for g in m.groups() if g is not None)
            if not (_KEY_CONTEXT.search(expr[: m.start()]) or _KEY_AFTER.search(expr[m.end() :])):
                shown.append(re.sub(r"\$\{[^}]*\}", " ", lit))
            code = code.replace(m.group(0), " " * len(m.group(0)), 1)
        for m in _REF.finditer(code):
            before, after = code[: m.start()], code[m.end() :].lstrip()
            if after.startswith("("):  # a call: its arguments are seen as refs anyway
                continue
            if re.search(r"(?:===?|!==?|\[)\s*$", before) or re.match(r"(?:===?|!==?)", after):
                continue  # compared, or the key of a lookup: not shown
            r = self.resolve(m.group(1))
            if r is None:
                continue
            found = _follow(self.state[r[0]], r[1])
            if after.startswith("[") and not re.match(r"\[\d+\]", after):  # x[key]: any entry of x
                found = [y for x in found for y in (x.values() if isinstance(x, dict) else x or [])]
            shown.extend(found)
        return shown

    # -- the walk --
    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self._element(tag, dict(attrs), push=tag not in _VOID)

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self._element(tag, dict(attrs), push=False)

    def handle_endtag(self, tag: str) -> None:
        if len(self.scopes) > 1:
            self.scopes.pop()
            self.pages.pop()

    def emit(self, texts: Iterable[str]) -> None:
        self.out.extend((self.pages[-1], t) for t in texts)

    def _element(self, tag: str, attrs: dict[str, str | None], push: bool) -> None:
        scope: dict[str, tuple[str, list[str]]] = {}
        loop = attrs.get("v-for")
        if loop:
            m = re.match(r"\s*\(?\s*(\w+)(?:\s*,\s*\w+)*\s*\)?\s+(?:in|of)\s+(.+)$", loop)
            if m:
                self.scopes.append({})  # the source is resolved in the outer scope
                r = self.resolve(m.group(2).strip())
                self.scopes.pop()
                if r is not None:
                    scope[m.group(1)] = r
        self.scopes.append(scope)
        shown_if = str(attrs.get("v-if") or attrs.get("v-show") or "")
        page = re.search(r"\bpage\s*===?\s*'(\w+)'", shown_if)
        self.pages.append(page.group(1) if page else self.pages[-1])
        for name, value in attrs.items():
            if value is None:
                continue
            bound = name.startswith((":", "v-bind:"))
            base = name.split(":")[-1]
            if base in DISPLAY_ATTRS:
                self.emit(_leaves(self.values(value)) if bound else [value])
            elif name == "v-html":
                self.emit(re.sub(r"<[^>]+>", " ", s) for s in _leaves(self.values(value)))
            elif name == ":items":
                title = attrs.get("item-title") or _ITEM_TITLE
                for v in self.values(value):
                    for x in v if isinstance(v, list) else [v]:
                        self.emit(_leaves(x.get(title) if isinstance(x, dict) else x))
            elif name == ":layout":  # a plotly figure's words
                for fig in self.values(value):
                    self.emit(_figure_text({"layout": fig}))
            elif name == ":data":
                for data in self.values(value):
                    self.emit(_figure_text({"data": data if isinstance(data, list) else [data]}))
        if not push:
            self.scopes.pop()
            self.pages.pop()

    def handle_data(self, data: str) -> None:
        pos = 0
        for m in re.finditer(r"\{\{(.*?)\}\}", data, re.S):
            self.emit([data[pos : m.start()]])
            if not _RECORD.match(m.group(1)):
                self.emit(_leaves(self.values(m.group(1))))
            pos = m.end()
        self.emit([data[pos:]])


#: the words of a 3-D view's scene (camcmm.gui.clientview: drawn by cloudview.js from the state)
_SCENE_WORDS = ("title", "text", "name", "label", "note", "unit")


def _scene_text(v: Any) -> Iterator[str]:
    """The words of a client view's scene: its legend (title, tick labels), entries, labels, note."""
    if isinstance(v, dict):
        for k, x in v.items():
            if k in _SCENE_WORDS and isinstance(x, str):
                yield x
            elif k in ("legend", "entries", "labels") or isinstance(x, (list, dict)) and k not in ("layers", "camera"):
                yield from _scene_text(x)
    elif isinstance(v, list):
        for x in v:
            yield from (_scene_text(x) if isinstance(x, (dict, list)) else [x] if isinstance(x, str) else [])


def page_texts(state: dict[str, Any], template: str) -> list[tuple[str, str]]:
    """The texts a person sees in a built layout ``template`` with ``state`` (a trame
    state's ``to_dict()``): ``[(page, text), ...]`` — the template's words and what its
    bindings show (plotly figures' titles and annotations too), each with the page it shows
    on (the element's ``v-if``/``v-show="page === '<key>'"``; "(every page)" outside one) —
    and the words of the 3-D views' scenes (``cv_<page>``: legend title and ticks, labels)."""
    walker = _Template(state)
    walker.feed(template)
    walker.close()
    for key, value in state.items():  # the 3-D views: cv_<page>, drawn in the browser from the state
        if key.startswith("cv_") and isinstance(value, dict) and "layers" in value:
            walker.out += [
                (key[3:], t) for t in _scene_text({k: value.get(k) for k in ("legend", "entries", "labels", "note")})
            ]
    return [(page, t) for page, t in walker.out if t and t.strip()]


# -- the reports ------------------------------------------------------------------------------
# The provenance (the last section) is left out of both: it is the record of the software,
# plugins, parameters and input files behind the result, named as the program and the files
# name them so that a run can be traced and repeated — identifiers, like the hashes beside them.
def html_report_text(path: str | Path) -> str:
    """The words of an HTML report: its markup, styles, scripts (the machine-readable JSON
    it embeds), images and provenance left out."""
    doc = Path(path).read_text(encoding="utf-8")
    doc = re.sub(r"(?is)<(script|style)\b.*?</\1>", " ", doc)
    doc = re.sub(r'(?is)<section class="[^"]*\bprovenance\b[^"]*">.*?</section>', " ", doc)
    doc = re.sub(r"(?is)<section[^>]*>\s*<h2>[^<]*Provenance</h2>.*?</section>", " ", doc)
    doc = re.sub(r"(?s)<[^>]+>", " ", doc)
    return html_lib.unescape(doc)


def pdf_report_text(path: str | Path) -> str:
    """The words of a PDF report (pypdf's text extraction)."""
    from pypdf import PdfReader

    text = "\n".join(page.extract_text() or "" for page in PdfReader(str(path)).pages)
    heads = list(re.finditer(r"(?m)^\s*(?:(?:\d+|Appendix [A-Z])\s+)?Provenance\s*$", text))
    return text[: heads[-1].start()] if heads else text
