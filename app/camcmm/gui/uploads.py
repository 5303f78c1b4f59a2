"""How much a browser may upload, checked before any memory is reserved for it.

A file chosen in the page's file input travels over the websocket as one wslink
message: msgpack, cut into chunks of at most ``WSLINK_MAX_MSG_SIZE`` (4 MB) bytes, each
with a 12-byte header ``(id, offset, total size)``. wslink's own ``UnChunker``
allocates ``bytearray(total size)`` from the *first* chunk's header, before any content
has arrived, and after the ``wslink.hello`` it allows 4 GB per message and any number
of messages at once: three 48-byte chunks declaring 3.9 GB each took a session to
5.6 GB, never released (wslink's chunking.py says as much: "vulnerable to DOS").

:class:`BoundedUnChunker` replaces it in this process (:func:`install`):

* a message whose declared size is above the limit is refused from its header;
* the declared sizes of all messages under way in this process (every tab of the
  session) together stay within the limit (:class:`Budget`), so many small headers
  cannot add up either;
* memory grows with the bytes that actually arrive, never with a header's promise;
  chunks must come in order (the trame client sends them so), a gap or an overrun ends
  the message;
* what a closed connection left half-received is given back.

A refused message is dropped (its later chunks too) and the page says why in one line
(``on_refused``); the connection stays open. The limit is ``camcmm serve
--max-upload SIZE`` (default 2 GB), given to each session's process in
``$CAMCMM_MAX_UPLOAD``. The websocket frames themselves stay bounded by aiohttp's
``max_msg_size`` (wslink sets it to the chunk size plus its overhead; the front's proxy
uses the same).
"""

from __future__ import annotations

import logging
import os
import re
import threading
from collections.abc import Callable
from typing import Any

from ..errors import CamcmmError
from ..numbers import significant

log = logging.getLogger("camcmm.gui")

#: the environment variable that carries ``--max-upload`` (bytes) to a session's process
MAX_UPLOAD_ENV = "CAMCMM_MAX_UPLOAD"
DEFAULT_MAX_UPLOAD = 2 * 1024**3
_UNITS = {"": 1, "b": 1, "k": 1024, "kb": 1024, "m": 1024**2, "mb": 1024**2, "g": 1024**3, "gb": 1024**3}


def parse_size(text: Any, what: str = "--max-upload") -> int:
    """``"2G"``, ``"500 MB"``, ``"1.5GB"``, ``"1048576"`` -> bytes (K, M, G are powers of
    1024). Raises CamcmmError (one line) for anything else or a size of 0."""
    m = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]*)?)\s*([a-zA-Z]*)\s*", str(text))
    unit = m.group(2).lower() if m else ""
    if m is None or unit not in _UNITS:
        raise CamcmmError(f"{what} {str(text)[:40]!r}: a size such as 2G, 500M or 1048576 (bytes)")
    n = int(float(m.group(1)) * _UNITS[unit])
    if n < 1024:
        raise CamcmmError(f"{what} {str(text)[:40]!r}: at least 1 KB")
    return n


def size_text(n: float) -> str:
    for unit, f in (("GB", 1024**3), ("MB", 1024**2), ("KB", 1024)):
        if n >= f:
            return f"{significant(n / f, 3)} {unit}"  # 1000 KB, never 1e+03 KB
    return f"{int(n)} bytes"


def limit_from_env(env: Any = None) -> int:
    """The limit this process was given (``$CAMCMM_MAX_UPLOAD``), else the default."""
    value = (os.environ if env is None else env).get(MAX_UPLOAD_ENV, "")
    return parse_size(value) if str(value).strip() else DEFAULT_MAX_UPLOAD


class UploadRefused(ValueError):
    """A message refused from its header (one line, for the page)."""


class Budget:
    """The bytes declared by the messages under way in this process, at most ``limit``."""

    def __init__(self, limit: int):
        self.limit = int(limit)
        self.used = 0
        self._lock = threading.Lock()

    def take(self, n: int) -> bool:
        with self._lock:
            if self.used + n > self.limit:
                return False
            self.used += n
            return True

    def give(self, n: int) -> None:
        with self._lock:
            self.used = max(0, self.used - n)


def _unchunker_base() -> Any:
    from wslink.chunking import UnChunker

    return UnChunker


class BoundedUnChunker(_unchunker_base()):  # type: ignore[misc]
    """wslink's UnChunker with the limits of this module's docstring. Before the
    client's ``wslink.hello`` wslink's own small limit (512 bytes) holds; after it, the
    limit given here instead of wslink's 4 GB."""

    def __init__(self, budget: Budget, on_refused: Callable[[str], None] | None = None):
        super().__init__()
        self.budget = budget
        self.on_refused = on_refused
        self.refused_ids: set[int] = set()

    def set_max_message_size(self, size: int) -> None:
        super().set_max_message_size(min(int(size), self.budget.limit))

    def release_pending_messages(self) -> None:
        for p in self.pending_messages.values():
            self.budget.give(p["total"])
        super().release_pending_messages()

    def _refuse(self, mid: int, text: str) -> None:
        self.refused_ids.add(mid)
        while len(self.refused_ids) > 1024:  # ids are random: forget old ones
            self.refused_ids.pop()
        raise UploadRefused(text)

    def _drop(self, mid: int) -> None:
        p = self.pending_messages.pop(mid, None)
        if p is not None:
            self.budget.give(p["total"])

    def process_chunk(self, chunk: bytes) -> Any:
        from wslink.chunking import HEADER_LENGTH, _decode_header

        if len(chunk) < HEADER_LENGTH:
            raise UploadRefused(f"a message chunk of {len(chunk)} bytes, shorter than its header")
        mid, offset, total = _decode_header(chunk[:HEADER_LENGTH])
        content = memoryview(chunk)[HEADER_LENGTH:]
        pending = self.pending_messages.get(mid)
        if pending is None:
            if mid in self.refused_ids:
                return None  # the rest of a message already refused
            if offset != 0:
                self._refuse(mid, "a message that does not start at its first chunk")
            if total > self.max_message_size:
                self._refuse(
                    mid,
                    f"an upload of {size_text(total)} is refused: above the {size_text(self.max_message_size)} "
                    + (
                        "this server accepts (camcmm serve --max-upload)"
                        if self.max_message_size >= self.budget.limit
                        else "a message may have before the client's hello"
                    ),
                )
            if not self.budget.take(total):
                self._refuse(
                    mid,
                    f"an upload of {size_text(total)} is refused: with the uploads under way it would exceed "
                    f"the {size_text(self.budget.limit)} this server accepts at once (camcmm serve --max-upload)",
                )
            # grows with what arrives: a header's total reserves nothing
            pending = self.pending_messages[mid] = {"received_size": 0, "total": total, "content": bytearray()}
        if offset != pending["received_size"] or total != pending["total"] or offset + len(content) > total:
            self._drop(mid)
            self._refuse(mid, "a message whose chunks do not follow each other")
        pending["content"] += content
        pending["received_size"] += len(content)
        if pending["received_size"] < total:
            return None
        self._drop(mid)
        import msgpack

        return msgpack.unpackb(pending["content"])


_installed: dict[str, Any] = {}


def install(limit: int, on_refused: Callable[[str], None] | None = None) -> Budget:
    """Make every wslink connection of this process use :class:`BoundedUnChunker` with
    one :class:`Budget` of ``limit`` bytes; ``on_refused(line)`` tells the page. wslink
    makes its ``UnChunker()`` in ``WslinkHandler.onConnect`` and has no hook for it,
    hence the replacement of the name it calls there (and of ``onMessage``/``onClose``,
    to turn a refusal into one line instead of a dropped connection and a traceback,
    and to give back what a closed connection left half-received)."""
    import wslink.protocol as wp

    budget = Budget(limit)
    _installed.update(budget=budget, on_refused=on_refused)
    if _installed.get("patched"):
        return budget
    _installed["patched"] = True

    def make() -> BoundedUnChunker:
        return BoundedUnChunker(_installed["budget"], _installed["on_refused"])

    wp.UnChunker = make  # type: ignore[assignment,misc]
    handler = wp.WslinkHandler
    on_message, on_close = handler.onMessage, handler.onClose

    async def onMessage(self: Any, is_binary: bool, msg: Any, client_id: Any) -> None:
        try:
            await on_message(self, is_binary, msg, client_id)
        except UploadRefused as exc:
            text = str(exc)
            cb = _installed["on_refused"]
            if cb is not None and client_id in self.authentified_client_ids:
                cb(text)  # the page says it (and the session's log)
            else:  # before its hello a client gets nothing shown to the session's tabs
                log.warning("camcmm: websocket message refused: %s", text)

    async def onClose(self: Any, client_id: Any) -> None:
        u = self.unchunkers.get(client_id)
        if u is not None:
            u.release_pending_messages()
        await on_close(self, client_id)

    handler.onMessage = onMessage  # type: ignore[method-assign]
    handler.onClose = onClose  # type: ignore[method-assign]
    return budget
