"""Files offered to the browser: one temporary folder per page, served at a route.

Each page (acceptance test, compare with CAD, uncertainty) offers reports and
exports as links. The project keeps the files by content hash; the browser needs a
readable name, so a copy under that name goes into the page's folder, which trame
serves (``server.enable_module({"serve": ...})``) and which is removed on close.
"""

from __future__ import annotations

import logging
import re
import shutil
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

log = logging.getLogger("camcmm.gui")

REPORT_TITLES = {"html": "Open report (HTML)", "pdf": "Download PDF", "json": "Download JSON"}
_ORDER = {"html": 0, "pdf": 1, "json": 2}


def safe_file_name(name: str, default: str = "download") -> str:
    """``name`` without path separators or characters a browser would mangle."""
    base = re.sub(r"[^\w.\-+() ]", "_", str(name)).strip(" .") or default
    return base[:80]


def sort_links(links: Iterable[dict[str, str]]) -> list[dict[str, str]]:
    """Reports first in the order HTML, PDF, JSON; everything else after."""
    return sorted(links, key=lambda x: _ORDER.get(x.get("kind", ""), 9))


def table_csv(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> bytes:
    """A small CSV (comma, dot decimal; floats to 6 significant digits) for the export
    of a page's table."""
    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for r in rows:
        w.writerow(["" if v is None else (f"{v:.6g}" if isinstance(v, float) else v) for v in r])
    return buf.getvalue().encode("utf-8")


class Downloads:
    """A served folder of named copies. ``offer`` returns the link for the page."""

    def __init__(self, route: str, prefix: str = "camcmm-downloads-", folder: str | Path | None = None):
        self.route = route
        self.folder = Path(folder) if folder else Path(tempfile.mkdtemp(prefix=prefix))
        self.folder.mkdir(parents=True, exist_ok=True)

    def mount(self, server: Any) -> None:
        server.enable_module({"serve": {self.route: str(self.folder)}})

    def offer(
        self,
        name: str,
        src: str | Path | None = None,
        data: bytes | None = None,
        title: str | None = None,
        kind: str | None = None,
        replace: bool = False,
    ) -> dict[str, str] | None:
        """Copy ``src`` (or write ``data``) to the folder as ``name``; ``None`` (logged)
        when that fails — a missing download must not break the page."""
        fname = safe_file_name(name)
        dest = self.folder / fname
        try:
            if replace or not dest.exists():
                if data is not None:
                    tmp = dest.with_suffix(dest.suffix + ".part")
                    tmp.write_bytes(data)
                    tmp.replace(dest)
                elif src is not None:
                    shutil.copyfile(src, dest)
                else:
                    raise OSError("nothing to offer")
        except OSError as exc:
            log.warning("cannot offer %s for download: %s", src or name, exc)
            return None
        kind = kind or Path(fname).suffix.lstrip(".")
        return {"kind": kind, "name": fname, "url": f"{self.route}/{fname}", "title": title or f"Download {fname}"}

    def close(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)
