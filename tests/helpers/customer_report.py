"""What a customer report must and must not show in its body (issue 28): the body text of
the HTML (head and sections before the appendix, tags and the embedded JSON removed) and
of the PDF (the pages before the one headed "Appendix"), and the internal tokens a
customer must not read there."""

from __future__ import annotations

import html as htmlmod
import re
from pathlib import Path

#: Tokens of camcmm's internals: snake_case keys, plugin ids, JSON braces and key quotes.
INTERNAL = {
    "snake_case key": re.compile(r"\b[a-z][a-z0-9]*_[a-z0-9_]+\b"),
    "plugin id": re.compile(r"\b(?:gdt|inspect|fit|cloud|segment)\.[a-z][a-z-]+\b"),
    "JSON brace": re.compile(r"[{}]"),
    "JSON key": re.compile(r'"\w+"\s*:'),
}


def html_body(text: str) -> str:
    """The words a reader sees before the appendix, without markup."""
    main = text[text.index("<main>") : text.index('<h2 class="appendix">')]
    main = re.sub(r"<img [^>]*>", " ", main)  # figures' base64 data and alt texts are not read as words
    return htmlmod.unescape(re.sub(r"<[^>]+>", " ", main))


def pdf_pages(path: str | Path) -> list[str]:
    from pypdf import PdfReader

    return [p.extract_text() for p in PdfReader(str(path)).pages]


def pdf_body(path: str | Path) -> str:
    """The PDF's text before the page that opens the appendix (its first line "Appendix")."""
    pages = pdf_pages(path)
    n = next(i for i, p in enumerate(pages) if re.search(r"^Appendix\s*$", p, re.M))
    return "\n".join(pages[:n])


def internal_tokens(text: str) -> list[tuple[str, str]]:
    """(kind, token) of every internal token in ``text``."""
    return [(kind, m.group(0)) for kind, rx in INTERNAL.items() for m in rx.finditer(text)]
