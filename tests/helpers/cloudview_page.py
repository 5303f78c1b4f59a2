"""A page of its own for resources/ui/cloudview.js without the app: a fake ``window.trame``
(``state.watch``/``get``/``set``, ``trigger`` recorded in ``window.__triggers``), one
``<div class="cmm-cloudview" data-cv=NAME>`` of a given size, the buffers served from a
folder under ``__camcmm_cv/`` by a ``http.server`` in a thread. Used by
tests/browser/test_cloudview_js.py and benchmarks/bench_browser_view.py.

    with CloudviewPage(folder, size=(400, 300)) as page_url:
        state = scene_state([points_layer(folder, "cloud", xyz, rgb)], camera=...)
        page.goto(page_url); page.evaluate(SET_STATE, ["cv_test", state])
"""

from __future__ import annotations

import hashlib
import http.server
import json
import threading
from pathlib import Path
from typing import Any

import numpy as np

NAME = "cv_test"
BASE = "__camcmm_cv/"

PAGE = """<!doctype html>
<html><head><meta charset="utf-8"><title>cloudview test</title>
<link rel="stylesheet" href="cloudview.css">
<style>html, body {{ margin: 0; padding: 0; }} .cmm-cloudview {{ width: {w}px; height: {h}px; }}</style>
<script>
window.__triggers = [];
// ?backend=webgl|cpu: cloudview.js's backend (its automatic choice is the CPU under SwiftShader)
window.CAMCMM_CLOUDVIEW_BACKEND = new URLSearchParams(location.search).get("backend") || undefined;
window.trame = (function () {{
  var state = {{}}, watchers = [];
  function notify(keys) {{
    watchers.slice().forEach(function (w) {{
      if (w.keys.some(function (k) {{ return keys.indexOf(k) >= 0; }}))
        w.cb.apply(null, w.keys.map(function (k) {{ return state[k]; }}));
    }});
  }}
  return {{
    state: {{
      state: state,
      get: function (k) {{ return state[k]; }},
      set: function (k, v) {{ state[k] = v; notify([k]); }},
      watch: function (keys, cb) {{
        var w = {{ keys: keys, cb: cb }};
        watchers.push(w);
        cb.apply(null, keys.map(function (k) {{ return state[k]; }}));
        return function () {{ watchers.splice(watchers.indexOf(w), 1); }};
      }},
    }},
    trigger: function (name, args) {{ window.__triggers.push([name, args]); return Promise.resolve(); }},
  }};
}})();
</script>
<script src="cloudview.js"></script>
</head><body>
<script>
// the element appears late, as a Vue page makes it (the MutationObserver must find it)
setTimeout(function () {{
  var d = document.createElement("div");
  d.className = "cmm-cloudview";
  d.setAttribute("data-cv", "{name}");
  document.body.appendChild(d);
}}, 30);
</script>
</body></html>
"""

#: page.evaluate(SET_STATE, [name, state]): the server setting the state key
SET_STATE = "([k, v]) => window.trame.state.set(k, v)"
#: page.wait_for_function(READY, arg=name)
READY = "(k) => !!(window.camcmmCloudView && window.camcmmCloudView.ready(k))"


def ui_dir() -> Path:
    from camcmm.assets import resources_dir

    return resources_dir() / "ui"


def put(folder: Path, array: np.ndarray, suffix: str) -> str:
    """Write ``array``'s bytes (little-endian) as ``<sha1>.<suffix>`` in ``folder``; its name."""
    data = np.ascontiguousarray(array).tobytes()
    name = f"{hashlib.sha1(data).hexdigest()[:20]}.{suffix}"
    path = Path(folder) / name
    if not path.exists():
        path.write_bytes(data)
    return name


def points_layer(
    folder: Path,
    layer_id: str,
    xyz: np.ndarray,
    rgb: np.ndarray | None = None,
    *,
    color: tuple[int, int, int] = (200, 200, 200),
    point_size: int = 1,
    origin: np.ndarray | None = None,
) -> dict[str, Any]:
    """A points layer of the protocol; ``xyz`` in world mm (``origin`` subtracted here)."""
    rel = np.asarray(xyz, dtype=np.float64) - (0 if origin is None else np.asarray(origin, dtype=np.float64))
    return {
        "id": layer_id,
        "kind": "points",
        "n": len(rel),
        "positions": put(folder, rel.astype("<f4"), "f32"),
        "colors": None if rgb is None else put(folder, np.asarray(rgb, dtype=np.uint8), "u8"),
        "color": list(color),
        "indices": None,
        "point_size": point_size,
        "opacity": 1.0,
        "pickable": True,
    }


def mesh_layer(
    folder: Path,
    layer_id: str,
    xyz: np.ndarray,
    triangles: np.ndarray,
    rgb: np.ndarray | None = None,
    *,
    kind: str = "mesh",
    color: tuple[int, int, int] = (200, 200, 200),
    opacity: float = 1.0,
) -> dict[str, Any]:
    """A mesh (``triangles`` (T, 3)) or lines (``kind="lines"``, (E, 2)) layer."""
    return {
        "id": layer_id,
        "kind": kind,
        "n": len(xyz),
        "positions": put(folder, np.asarray(xyz, dtype="<f4"), "f32"),
        "colors": None if rgb is None else put(folder, np.asarray(rgb, dtype=np.uint8), "u8"),
        "color": list(color),
        "indices": put(folder, np.asarray(triangles, dtype="<u4"), "u32"),
        "point_size": 1,
        "opacity": opacity,
        "pickable": True,
    }


def scene_state(layers: list[dict[str, Any]], camera: dict[str, Any], rev: int = 1, **extra: Any) -> dict[str, Any]:
    """The state key's value: ``camera`` {position, focal_point, view_up, view_angle} world mm."""
    state: dict[str, Any] = {
        "rev": rev,
        "base": BASE,
        "origin": [0.0, 0.0, 0.0],
        "layers": layers,
        "legend": None,
        "entries": [],
        "labels": [],
        "camera": {"rev": rev, **camera},
        "note": "",
        "tool": "rotate",
    }
    state.update(extra)
    return json.loads(json.dumps(state))  # plain JSON, as trame sends it


def project(camera: dict[str, Any], size: tuple[int, int], xyz: np.ndarray) -> np.ndarray:
    """Pixel coordinates (x right, y down; pixel (i, j) covers [i, i+1) x [j, j+1)) of world
    points under VTK's perspective camera: f = (H/2) / tan(view_angle/2), x = W/2 + f xc/d,
    y = H/2 - f yc/d — the reference the renderer is tested against."""
    w, h = size
    pos = np.asarray(camera["position"], float)
    fwd = np.asarray(camera["focal_point"], float) - pos
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, camera["view_up"])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    q = np.atleast_2d(xyz) - pos
    d = q @ fwd
    f = (h / 2) / np.tan(np.radians(camera["view_angle"]) / 2)
    return np.stack([w / 2 + f * (q @ right) / d, h / 2 - f * (q @ up) / d], axis=1)


class CloudviewPage:
    """Serves the page (``/``), cloudview.js/.css and ``folder`` under ``/__camcmm_cv/``
    on 127.0.0.1 (a free port) while in the ``with``; gives the page's URL."""

    def __init__(self, folder: Path, size: tuple[int, int] = (400, 300), name: str = NAME):
        self.folder = Path(folder)
        self.page = PAGE.format(w=size[0], h=size[1], name=name).encode()
        self.server: http.server.ThreadingHTTPServer | None = None

    def __enter__(self) -> str:
        ui, folder, page = ui_dir(), self.folder, self.page

        class Handler(http.server.BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:  # quiet: the test's output is its own
                pass

            def do_GET(self) -> None:  # noqa: N802 (http.server's name)
                path = self.path.split("?", 1)[0]
                if path in ("/", "/index.html"):
                    body, ctype = page, "text/html"
                elif path in ("/cloudview.js", "/cloudview.css"):
                    body = (ui / path[1:]).read_bytes()
                    ctype = "text/css" if path.endswith(".css") else "text/javascript"
                elif path.startswith("/" + BASE) and "/" not in path[len(BASE) + 1 :]:
                    f = folder / path[len(BASE) + 1 :]
                    if not f.is_file():
                        self.send_error(404)
                        return
                    body, ctype = f.read_bytes(), "application/octet-stream"
                else:
                    self.send_error(404)
                    return
                self.send_response(200)
                self.send_header("Content-Type", ctype)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

        self.server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        threading.Thread(target=self.server.serve_forever, daemon=True).start()
        return f"http://127.0.0.1:{self.server.server_address[1]}/"

    def __exit__(self, *exc: Any) -> None:
        if self.server is not None:
            self.server.shutdown()
            self.server.server_close()
