"""The projector page, the Devices page's second window: ``http://HOST:PORT/projector``
opened full-screen on the projector's display shows the pattern of the connected
pattern projector, in step with the captures.

No desktop program: a plain page served by the app's own web server (routes added
to trame's aiohttp application through ``on_server_bind``). It polls the display
version, loads the pattern PNG for a new version, and once the browser has decoded
and painted it, acknowledges that version; the projector device (see
``PatternProjector.show``) waits for the acknowledgement before the cameras expose.
Polling every 20 ms instead of a websocket keeps the page free of trame's client,
so it works in any browser put on any screen.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

HTML = """<!doctype html>
<html><head><meta charset="utf-8"><title>camcmm projector</title>
<style>html,body{margin:0;height:100%;background:#000;overflow:hidden;cursor:none}
img{position:fixed;left:0;top:0;width:100vw;height:100vh;object-fit:contain;image-rendering:pixelated}
#note{position:fixed;left:8px;bottom:8px;color:#555;font:12px sans-serif}</style></head>
<body><img id="p" alt=""><div id="note">camcmm projector — press F11 for full screen</div>
<script>
let shown = -1, loading = false;
const img = document.getElementById('p'), note = document.getElementById('note');
async function tick() {
  if (!loading) {
    try {
      const r = await fetch('projector/state', {cache: 'no-store'});
      const s = await r.json();
      note.style.display = s.connected ? 'none' : 'block';
      if (s.version !== shown) {
        loading = true;
        const v = s.version;
        img.onload = async () => {
          // painted on the next animation frame; a window in the background gets
          // none, so do not wait for one longer than 50 ms
          await new Promise(done => {
            requestAnimationFrame(() => requestAnimationFrame(done)); setTimeout(done, 50); });
          await fetch('projector/ack?v=' + v, {method: 'POST'});
          shown = v; loading = false; };
        img.onerror = () => { loading = false; };
        img.src = 'projector/pattern.png?v=' + v;
      }
    } catch (e) { loading = false; }
  }
  setTimeout(tick, 20);
}
tick();
</script></body></html>"""


def add_routes(server: Any, projector_of: Callable[[], Any]) -> None:
    """Serve the page; ``projector_of()`` returns the current pattern projector (an
    object with ``version``, ``png()`` and ``acknowledge(v)``) or None."""
    from aiohttp import web

    async def page(_request):
        return web.Response(text=HTML, content_type="text/html")

    async def state(_request):
        p = projector_of()
        return web.json_response(
            {
                "connected": p is not None and bool(getattr(p, "connected", False)),
                "version": int(getattr(p, "version", 0)) if p is not None else 0,
            }
        )

    async def pattern(_request):
        p = projector_of()
        if p is None:
            return web.Response(status=404, text="no pattern projector")
        return web.Response(body=p.png(), content_type="image/png", headers={"Cache-Control": "no-store"})

    async def ack(request):
        p = projector_of()
        try:
            v = int(request.query.get("v", ""))
        except ValueError:
            return web.Response(status=400, text="v: expected the display version")
        if p is not None:
            p.acknowledge(v)
        return web.Response(text="ok")

    def bind(wslink_server):
        app = wslink_server.app
        app.router.add_get("/projector", page)
        app.router.add_get("/projector/state", state)
        app.router.add_get("/projector/pattern.png", pattern)
        app.router.add_post("/projector/ack", ack)

    server.controller.on_server_bind.add(bind)
