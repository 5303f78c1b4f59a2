/* camcmm's client-side 3-D view (issue 29): draws the pages' scenes in the browser on the CPU.

   Why the CPU: on this kind of machine WebGL is SwiftShader (software); a gl.POINTS draw of 2 M
   points took 690 ms, a plain-JS splatter into a 2-D canvas 34 ms (docs/bigclouds.md). Where the
   browser reports a hardware GPU a WebGL2 backend draws instead (see "optional GPU backend").

   Protocol (the Python side, camcmm.gui.clientview, writes it): every element
   <div class="cmm-cloudview" data-cv="NAME"> gets a renderer (a canvas filling it and HTML
   overlays). It watches the trame state key NAME:
     {rev, base, origin [mm], layers: [{id, kind: points|mesh|lines, n, positions, colors, color,
      indices, point_size, opacity, pickable, line_width?, on_top?}], legend, entries, labels,
      camera: {rev, position, focal_point, view_up, view_angle}, note, tool: rotate|lasso|rect}
   Buffers are immutable files named by content hash under `base` (relative to the page; the
   token travels in the page's cookie, as for the downloads): positions float32 x,y,z relative
   to `origin` (points in level-of-detail order: any prefix is a uniform subsample), colors uint8
   RGB, indices uint32 (mesh: 3 per triangle, lines: 2 per segment). Cached by name.

   Mouse: left drag rotates about the focal point (VTK's trackball: 200 degrees per view width),
   wheel dollies (x1.1 per notch), right/middle or shift+left drag pans, double-click restores
   the server's camera. With tool lasso/rect a left drag draws the selection instead.
   Interaction frames draw a prefix of each point layer (the budget, adapted so a frame takes
   about 40 ms, in whole chunks of 65536 points, with splats grown by sqrt(n/k) up to twice their
   size so the subsample covers the same area); 150 ms after the last event everything is drawn.
   Projection as VTK's perspective camera: view_angle is the vertical angle; a point at camera
   coordinates (xc, yc, d) (d along the view direction) lands at pixel
   (W/2 + f xc/d, H/2 - f yc/d) with f = (H/2) / tan(view_angle/2) — except while a colour legend
   is shown (the scene is framed left of it) and in a view narrower than tall (see lens()).
   Until the first frame of a scene a spinner says "drawing …" (data-testid cloudview-busy).

   To the server (window.trame.trigger):
     cv_pick   [NAME, layer_id, index, [x, y, z] world mm]  a click (no drag) on a pickable layer:
               the nearest covered pixel within 6 px of the id-buffer (layer, index) of the last full
               frame. Points: the point and its position; mesh: the nearest vertex of the triangle
               hit and the surface point under the pixel; lines: the nearest end of the segment.
     cv_camera [NAME, {position, focal_point, view_up, view_angle}, [w, h]]  when an interaction ends
     cv_select [NAME, {shape, polygon: [[x_ndc, y_ndc]...], mvp: 16 floats column-major world mm -> clip}]
   For tests and benchmarks: window.camcmmCloudView.views[NAME].frame(delta?) -> ms,
   .stats(), .setBudget(k|null); window.camcmmCloudView.ready(NAME). */
(function () {
  "use strict";
  if (window.camcmmCloudView) return;

  var TARGET_MS = 40; // interaction frame time the budget aims at
  var REST_MS = 150; // full draw this long after the last event
  var MIN_BUDGET = 50000;
  var PICK_RADIUS = 6; // px
  var CLICK_SLOP = 3; // px of movement that still counts as a click
  var DBLCLICK_MS = 250; // a pick waits this long for a second click (a double-click resets)
  var BG_TOP = [255, 255, 255]; // the server view's gradient (camcmm.gui.view.SceneView)
  var BG_BOTTOM = [0xf4, 0xf5, 0xf7];
  var DEFAULT_COLOR = [200, 200, 200];
  var LEGEND_GAP = 8; // px between the scene's area and the colour legend
  var LABEL_GAP = 2; // px between two pick labels pushed apart
  var PLACEHOLDER_MS = 15000; // the spinner's longest wait over the server's empty placeholder

  // -- small vector algebra (3-vectors as arrays, float64) -----------------------------------
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
  function mul(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function len(a) { return Math.sqrt(dot(a, a)); }
  function unit(a) { var l = len(a); return l > 0 ? mul(a, 1 / l) : [0, 0, 0]; }
  function rotate(v, axis, deg) { // Rodrigues, right-handed about the unit axis
    var t = deg * Math.PI / 180, c = Math.cos(t), s = Math.sin(t), k = unit(axis);
    var kv = cross(k, v), kd = dot(k, v) * (1 - c);
    return [v[0] * c + kv[0] * s + k[0] * kd, v[1] * c + kv[1] * s + k[1] * kd, v[2] * c + kv[2] * s + k[2] * kd];
  }
  function vec3(a, fallback) {
    if (!a || a.length !== 3) return fallback.slice();
    var out = [+a[0], +a[1], +a[2]];
    return isFinite(out[0]) && isFinite(out[1]) && isFinite(out[2]) ? out : fallback.slice();
  }
  function packRGB(c) { // ImageData is RGBA bytes: one little-endian uint32 = 0xAABBGGRR
    return (0xff000000 | ((c[2] & 255) << 16) | ((c[1] & 255) << 8) | (c[0] & 255)) >>> 0;
  }
  function cssRGB(c) { return "rgb(" + (c[0] | 0) + "," + (c[1] | 0) + "," + (c[2] | 0) + ")"; }

  // -- buffers: fetched once per name, shared by the views --------------------------------------
  var cache = {}; // url|kind -> {promise, data, bytes, url}
  var CHUNK = 65536; // points are reordered within chunks of this size (lodSort)

  /* Points in level-of-detail order land on random pixels: every z-test misses the cache.
     Within each chunk of CHUNK points the order is free (a chunk-aligned prefix stays the same
     uniform subsample), so each chunk is sorted along a Morton curve (the top 16 bits of a 30-bit
     code, radix sort): neighbours in the array are neighbours on the screen. Measured in this renderer:
     about a third off the frame time for 2 M points. `perm` maps back to the server's index. */
  var SPREAD = new Uint32Array(1024);
  for (var sv = 0; sv < 1024; sv++) {
    var v = sv;
    v = (v | (v << 16)) & 0x030000ff;
    v = (v | (v << 8)) & 0x0300f00f;
    v = (v | (v << 4)) & 0x030c30c3;
    v = (v | (v << 2)) & 0x09249249;
    SPREAD[sv] = v;
  }

  function lodSort(raw) {
    var n = (raw.length / 3) | 0, i, j, k;
    var x0 = Infinity, y0 = Infinity, z0 = Infinity, x1 = -Infinity, y1 = -Infinity, z1 = -Infinity;
    for (j = 0; j < 3 * n; j += 3) {
      var x = raw[j], y = raw[j + 1], z = raw[j + 2];
      if (x < x0) x0 = x;
      if (x > x1) x1 = x;
      if (y < y0) y0 = y;
      if (y > y1) y1 = y;
      if (z < z0) z0 = z;
      if (z > z1) z1 = z;
    }
    var sx = x1 > x0 ? 1023.99 / (x1 - x0) : 0, sy = y1 > y0 ? 1023.99 / (y1 - y0) : 0, sz = z1 > z0 ? 1023.99 / (z1 - z0) : 0;
    // the top 16 bits of the 30-bit code: 2^16 cells for a chunk of 2^16 points is as good as sorted
    var keys = new Uint16Array(n), perm = new Uint32Array(n);
    for (i = 0, j = 0; i < n; i++, j += 3) {
      var code = SPREAD[((raw[j] - x0) * sx) & 1023] | (SPREAD[((raw[j + 1] - y0) * sy) & 1023] << 1) |
        (SPREAD[((raw[j + 2] - z0) * sz) & 1023] << 2);
      keys[i] = code >>> 14;
    }
    var tmp = new Uint32Array(CHUNK), count = new Uint32Array(256), b, sum, c;
    for (var c0 = 0; c0 < n; c0 += CHUNK) { // LSD radix sort of each chunk: low byte, then high byte
      var m = Math.min(CHUNK, n - c0), end = c0 + m;
      count.fill(0);
      for (i = c0; i < end; i++) count[keys[i] & 255]++;
      for (b = 0, sum = 0; b < 256; b++) { c = count[b]; count[b] = sum; sum += c; }
      for (i = c0; i < end; i++) tmp[count[keys[i] & 255]++] = i;
      count.fill(0);
      for (i = 0; i < m; i++) count[keys[tmp[i]] >>> 8]++;
      for (b = 0, sum = 0; b < 256; b++) { c = count[b]; count[b] = sum; sum += c; }
      for (i = 0; i < m; i++) { k = tmp[i]; perm[c0 + count[keys[k] >>> 8]++] = k; }
    }
    var pos = new Float32Array(3 * n);
    for (i = 0, j = 0; i < n; i++, j += 3) {
      k = 3 * perm[i];
      pos[j] = raw[k];
      pos[j + 1] = raw[k + 1];
      pos[j + 2] = raw[k + 2];
    }
    return { pos: pos, perm: perm };
  }

  function gather(col, perm) {
    var out = new Uint32Array(perm.length);
    for (var i = 0; i < perm.length; i++) out[i] = col[perm[i]];
    return out;
  }

  function fetchBuffer(url, kind) {
    var hit = cache[url + "|" + kind];
    if (hit) return hit.promise;
    var entry = { data: null, bytes: 0, promise: null };
    entry.promise = fetch(url, { credentials: "same-origin" })
      .then(function (r) {
        if (!r.ok) throw new Error(url + ": HTTP " + r.status);
        return r.arrayBuffer();
      })
      .then(function (ab) {
        var data;
        if (kind === "rgb") {
          var rgb = new Uint8Array(ab), n = (rgb.length / 3) | 0;
          data = new Uint32Array(n); // packed once: the draw loop stores one word per pixel
          for (var i = 0, j = 0; i < n; i++, j += 3) {
            data[i] = (0xff000000 | (rgb[j + 2] << 16) | (rgb[j + 1] << 8) | rgb[j]) >>> 0;
          }
        } else if (kind === "f32" || kind === "pts") {
          if (ab.byteLength % 12) throw new Error(url + ": " + ab.byteLength + " bytes are no float32 x, y, z");
          data = new Float32Array(ab);
          if (kind === "pts") {
            var ts = performance.now();
            var sorted = lodSort(data);
            sorted.sortMs = performance.now() - ts;
            entry.data = sorted;
            entry.bytes = sorted.pos.byteLength + sorted.perm.byteLength;
            return sorted;
          }
        } else {
          if (ab.byteLength % 4) throw new Error(url + ": " + ab.byteLength + " bytes is no uint32 array");
          data = new Uint32Array(ab);
        }
        entry.data = data;
        entry.bytes = data.byteLength;
        return data;
      });
    entry.promise.catch(function () { delete cache[url + "|" + kind]; }); // a failed fetch may be retried
    cache[url + "|" + kind] = entry;
    return entry.promise;
  }

  function evict() { // drop buffers no view uses or loads any more
    var keep = {};
    Object.keys(views).forEach(function (k) {
      views[k].urls().forEach(function (u) { keep[u] = true; });
    });
    Object.keys(cache).forEach(function (u) { if (!keep[u.split("|")[0]]) delete cache[u]; });
  }

  function cachedBytes() { // the buffers held: the cache and the views' sorted colour copies
    var b = 0, seen = [];
    Object.keys(cache).forEach(function (u) { b += cache[u].bytes; });
    Object.keys(views).forEach(function (k) {
      views[k].layers.forEach(function (l) {
        if (l.colKey && seen.indexOf(l.col) < 0) { seen.push(l.col); b += l.col.byteLength; }
        if (l.solid) b += l.solid.byteLength;
      });
    });
    return b;
  }

  function trame() { return window.trame && window.trame.state ? window.trame : null; }

  function trigger(name, args) {
    var t = trame();
    if (!t || typeof t.trigger !== "function") return;
    try {
      var p = t.trigger(name, args);
      if (p && p.catch) p.catch(function (e) { console.error("camcmm cloudview: " + name, e); });
    } catch (e) {
      console.error("camcmm cloudview: " + name, e);
    }
  }

  function el(tag, cls, parent) {
    var e = document.createElement(tag);
    if (cls) e.className = cls;
    if (parent) parent.appendChild(e);
    return e;
  }

  // -- one view per state key -------------------------------------------------------------------
  var views = {};

  function View(name) {
    this.name = name;
    this.el = null;
    this.W = 0;
    this.H = 0;
    this.spec = null; // the state shown
    this.pendingRev = null; // the rev being loaded
    this.pendingUrls = [];
    this.layers = []; // {spec, n, pos, col, idx, packed}
    this.origin = [0, 0, 0];
    this.cam = null; // origin-relative {pos, fp, up, angle}
    this.camRev = null;
    this.serverCam = null;
    this.budget = 1000000; // points per interaction frame; adapted to the frame time
    this.forced = null; // setBudget(k): every interaction frame draws k points
    this.drawn = 0;
    this.total = 0;
    this.lastMs = 0;
    this.lastFull = false; // the frame in the buffers drew everything (its id-buffer is whole)
    this.shownRev = null; // rev of the last full frame
    this.error = "";
    this.raf = 0;
    this.restTimer = 0;
    this.camDirty = false;
    this.unwatch = null;
    this.legendKey = "";
    this.entriesKey = "";
    this.timing = null; // of the last content: ms from the state to loaded, first paint, all drawn
    this.painted = false; // a first picture was drawn (the "drawing …" spinner until then)
  }

  View.prototype.urls = function () {
    var out = this.pendingUrls.slice();
    this.layers.forEach(function (l) { out = out.concat(l.urls); });
    return out;
  };

  // --- DOM ---
  View.prototype.attach = function (host) {
    if (this.el === host && this.canvas && this.canvas.parentNode === host) return;
    this.detach();
    this.el = host;
    host.__cmmCloudView = this;
    host.classList.add("cmm-cv-host");
    this.gl = null;
    if (useWebGL()) { // a GPU draws; the 2-D canvas on top keeps the triad and takes the events
      this.glCanvas = el("canvas", "cmm-cv-canvas cmm-cv-gl", host);
      this.gl = makeGL(this, this.glCanvas);
    }
    this.canvas = el("canvas", "cmm-cv-canvas", host);
    this.canvas.setAttribute("data-testid", "cloudview-canvas");
    this.ctx = this.canvas.getContext("2d");
    this.labelBox = el("div", "cmm-cv-labels", host);
    this.svg = document.createElementNS("http://www.w3.org/2000/svg", "svg");
    this.svg.setAttribute("class", "cmm-cv-select");
    this.poly = document.createElementNS("http://www.w3.org/2000/svg", "polygon");
    this.svg.appendChild(this.poly);
    host.appendChild(this.svg);
    this.legendBox = el("div", "cmm-cv-legend", host);
    this.entriesBox = el("div", "cmm-cv-entries", host);
    this.noteBox = el("div", "cmm-cv-note", host);
    this.noteBox.setAttribute("data-testid", "cloudview-note");
    // "drawing …" with a spinner from the moment the view is on the page until its first frame
    // with the scene (the state, the buffers' download and sorting take seconds on a big cloud;
    // the view was blank meanwhile)
    this.busyBox = el("div", "cmm-cv-busy", host);
    this.busyBox.setAttribute("data-testid", "cloudview-busy");
    this.busyBox.setAttribute("role", "status");
    el("span", "cmm-cv-spinner", this.busyBox);
    el("span", "", this.busyBox).textContent = "drawing …";
    this.setBusy(!this.painted);
    var self0 = this;
    // the server's placeholder (rev 0, nothing in it) may stay if a page never draws here: the
    // spinner does not stay with it for ever
    setTimeout(function () { if (self0.el === host) self0.painted0(); }, PLACEHOLDER_MS);
    this.legendKey = this.entriesKey = "";
    this.labelEls = [];
    this.bindEvents();
    var self = this;
    this.resizeObs = new ResizeObserver(function () { self.resize(); });
    this.resizeObs.observe(host);
    this.resize();
    this.watch();
    this.applyOverlays();
  };

  View.prototype.detach = function () {
    if (!this.el) return;
    if (this.resizeObs) this.resizeObs.disconnect();
    if (this.unbind) this.unbind();
    if (this.gl) this.gl.release();
    this.gl = null;
    [this.glCanvas, this.canvas, this.labelBox, this.svg, this.legendBox, this.entriesBox, this.noteBox, this.busyBox].forEach(function (n) {
      if (n && n.parentNode) n.parentNode.removeChild(n);
    });
    if (this.el.__cmmCloudView === this) delete this.el.__cmmCloudView;
    this.el = null;
    this.W = this.H = 0;
    this.pix = this.zbuf = this.idLayer = this.idIndex = this.bg = this.image = this.scratch = null; // frame buffers go
    this.idValid = false;
  };

  View.prototype.resize = function () {
    if (!this.el) return;
    var w = Math.floor(this.el.clientWidth), h = Math.floor(this.el.clientHeight);
    if (w === this.W && h === this.H) return;
    this.W = w;
    this.H = h;
    if (w <= 0 || h <= 0) return; // hidden (v-show): drawn again when shown
    this.canvas.width = w;
    this.canvas.height = h;
    if (this.gl) {
      this.glCanvas.width = w;
      this.glCanvas.height = h;
    }
    this.image = this.ctx.createImageData(w, h);
    this.pix = new Uint32Array(this.image.data.buffer);
    this.zbuf = new Float32Array(w * h);
    this.idLayer = new Uint8Array(w * h);
    this.idIndex = new Int32Array(w * h);
    this.idDepth = new Float32Array(w * h); // depth of a translucent mesh's id: it is picked through its blending
    this.bg = new Uint32Array(w * h);
    for (var y = 0; y < h; y++) { // VTK's gradient: `top` at the top, the background at the bottom
      var t = h > 1 ? y / (h - 1) : 0;
      var c = packRGB([
        BG_TOP[0] + (BG_BOTTOM[0] - BG_TOP[0]) * t,
        BG_TOP[1] + (BG_BOTTOM[1] - BG_TOP[1]) * t,
        BG_TOP[2] + (BG_BOTTOM[2] - BG_TOP[2]) * t,
      ]);
      this.bg.fill(c, y * w, (y + 1) * w);
    }
    this.render(true);
  };

  // --- state ---
  View.prototype.watch = function () {
    if (this.unwatch) return;
    var t = trame(), self = this;
    if (!t) { // the trame client makes window.trame after the page's scripts ran
      if (!this.watchTimer) {
        this.watchTimer = setTimeout(function () { self.watchTimer = 0; if (self.el) self.watch(); }, 100);
      }
      return;
    }
    var off = t.state.watch([this.name], function (value) { self.onState(value); });
    this.unwatch = typeof off === "function" ? off : function () {};
  };

  View.prototype.onState = function (spec) {
    var self = this;
    if (!spec || typeof spec !== "object") {
      this.pendingRev = null;
      this.pendingUrls = [];
      this.spec = null;
      this.layers = [];
      this.applyOverlays();
      this.render(true);
      this.painted0();
      return;
    }
    if (this.spec && spec.rev === this.spec.rev && spec !== this.spec && this.pendingRev === null) {
      // same content: only the tool or the camera may have changed
      this.spec = spec;
      this.adoptCamera(false);
      this.applyOverlays();
      this.render(true);
      return;
    }
    var base = spec.base ? String(spec.base).replace(/\/?$/, "/") : ""; // a folder: "x" means "x/"
    var rev = spec.rev;
    var jobs = [], urls = [];
    var layers = (spec.layers || []).map(function (l) {
      var want = { spec: l, n: Math.max(0, l.n | 0), urls: [] };
      function need(key, name, kind) {
        if (!name) return;
        var url = base + name;
        want.urls.push(url);
        urls.push(url);
        jobs.push(fetchBuffer(url, kind).then(function (d) { want[key] = d; }));
      }
      if (l.kind === "points") {
        need("pts", l.positions, "pts");
      } else {
        need("pos", l.positions, "f32");
      }
      var reuse = l.kind === "points" && l.colors ? self.findCol(l.positions + "|" + l.colors) : null;
      if (reuse) {
        want.col = reuse; // already in the sorted order: no fetch, no copy
        want.colKey = l.positions + "|" + l.colors;
      } else {
        need("col", l.colors, "rgb");
      }
      need("idx", l.indices, "u32");
      return want;
    });
    this.pendingRev = rev;
    this.pendingUrls = urls;
    this.setNote("loading …");
    var arrived = performance.now();
    Promise.all(jobs).then(
      function () {
        if (self.pendingRev !== rev) return; // a newer state came meanwhile
        layers.forEach(function (l) { if (l.pts) { l.pos = l.pts.pos; l.perm = l.pts.perm; } });
        layers.forEach(function (l) { l.bad = checkLayer(l); });
        var bad = layers.map(function (l) { return l.bad; }).filter(Boolean);
        layers.forEach(function (l) {
          if (!l.perm || !l.col || l.colKey || l.bad) return;
          l.col = gather(l.col, l.perm);
          l.colKey = l.spec.positions + "|" + l.spec.colors;
          delete cache[base + l.spec.colors + "|rgb"]; // the sorted copy is kept instead
        });
        self.pendingRev = null;
        self.pendingUrls = [];
        self.error = bad.join("; ");
        if (bad.length) console.error("camcmm cloudview " + self.name + ": " + self.error);
        self.layers = layers.filter(function (l) { return !l.bad; });
        self.spec = spec;
        self.origin = vec3(spec.origin, [0, 0, 0]);
        self.adoptCamera(true);
        self.applyOverlays();
        var sortMs = 0;
        layers.forEach(function (l) { if (l.pts) sortMs += l.pts.sortMs || 0; });
        self.timing = { arrived: arrived, loaded_ms: performance.now() - arrived, sort_ms: sortMs, first_paint_ms: null, all_drawn_ms: null };
        self.firstPaint(arrived);
        evict();
      },
      function (err) {
        if (self.pendingRev !== rev) return;
        self.pendingRev = null;
        self.pendingUrls = [];
        self.error = String(err && err.message ? err.message : err);
        console.error("camcmm cloudview " + self.name + ": " + self.error);
        self.setNote(self.error);
        self.painted0(); // the note says what went wrong
      }
    );
  };

  View.prototype.findCol = function (key) { // a shown layer's colours in the sorted order
    for (var i = 0; i < this.layers.length; i++) if (this.layers[i].colKey === key) return this.layers[i].col;
    return null;
  };

  /* New content: more points than the budget are drawn budgeted first (on screen at once), and
     all of them in the task after that frame was shown. */
  View.prototype.firstPaint = function (arrived) {
    var self = this, timing = this.timing, pts = 0;
    this.layers.forEach(function (l) { if (l.spec.kind === "points") pts += l.n; });
    this.render(pts <= this.budget);
    timing.first_paint_ms = performance.now() - arrived;
    if (this.lastFull) return;
    requestAnimationFrame(function () {
      setTimeout(function () {
        if (self.timing === timing && !self.lastFull && !self.restTimer) self.render(true);
      }, 0);
    });
  };

  function checkLayer(l) { // one line naming the layer and the buffer, or ""
    var s = l.spec, n = l.n;
    var what = "layer " + s.id + " (" + s.kind + "): ";
    if (!l.pos) return what + "no positions";
    if (l.pos.length < 3 * n) return what + s.positions + " holds " + l.pos.length / 3 + " points, n=" + n;
    if (l.col && l.col.length < n) return what + s.colors + " holds " + l.col.length + " colours, n=" + n;
    if (s.kind === "mesh" || s.kind === "lines") {
      if (!l.idx) return what + "no indices";
      var k = s.kind === "mesh" ? 3 : 2;
      if (l.idx.length % k) return what + s.indices + ": " + l.idx.length + " indices is not a multiple of " + k;
      for (var i = 0; i < l.idx.length; i++) if (l.idx[i] >= n) return what + s.indices + ": index " + l.idx[i] + " >= n=" + n;
    } else if (s.kind !== "points") {
      return what + "unknown kind";
    }
    l.packed = packRGB(vec3(s.color, DEFAULT_COLOR));
    return "";
  }

  // --- camera ---
  View.prototype.adoptCamera = function (contentChanged) {
    var c = this.spec && this.spec.camera;
    if (c && c.position) {
      var o = this.origin;
      this.serverCam = {
        pos: sub(vec3(c.position, [0, 0, 1]), o),
        fp: sub(vec3(c.focal_point, [0, 0, 0]), o),
        up: vec3(c.view_up, [0, 1, 0]),
        angle: +c.view_angle > 0 && +c.view_angle < 180 ? +c.view_angle : 30,
      };
      if (c.rev !== this.camRev || !this.cam) {
        this.camRev = c.rev;
        this.cam = copyCam(this.serverCam);
      }
    } else if (!this.cam || (contentChanged && !this.serverCam)) {
      this.serverCam = this.fitCamera();
      this.cam = copyCam(this.serverCam);
    }
  };

  function copyCam(c) { return { pos: c.pos.slice(), fp: c.fp.slice(), up: c.up.slice(), angle: c.angle }; }

  View.prototype.fitCamera = function () { // VTK's ResetCamera from the iso direction
    var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    this.layers.forEach(function (l) {
      var p = l.pos, m = 3 * l.n;
      for (var i = 0; i < m; i += 3) {
        for (var k = 0; k < 3; k++) {
          var v = p[i + k];
          if (v < lo[k]) lo[k] = v;
          if (v > hi[k]) hi[k] = v;
        }
      }
    });
    if (!(lo[0] <= hi[0])) { lo = [-1, -1, -1]; hi = [1, 1, 1]; }
    var fp = mul(add(lo, hi), 0.5), r = Math.max(len(sub(hi, lo)) / 2, 1e-6), angle = 30;
    var d = r / Math.sin(angle * Math.PI / 360);
    return { pos: add(fp, mul(unit([1, 1, 1]), d)), fp: fp, up: unit([-1, -1, 2]), angle: angle };
  };

  View.prototype.basis = function () { // camera frame: right, up, forward, eye (origin-relative)
    var c = this.cam, f = unit(sub(c.fp, c.pos)), r = unit(cross(f, c.up));
    if (len(r) === 0) r = unit(cross(f, Math.abs(f[2]) < 0.9 ? [0, 0, 1] : [0, 1, 0]));
    return { r: r, u: cross(r, f), f: f, eye: c.pos, dist: len(sub(c.fp, c.pos)) };
  };

  View.prototype.azimuth = function (deg) {
    var c = this.cam, b = this.basis();
    c.pos = add(c.fp, rotate(sub(c.pos, c.fp), b.u, deg));
    c.up = b.u;
  };

  View.prototype.elevation = function (deg) { // a trackball: the view up turns with the camera
    var c = this.cam, b = this.basis();
    c.pos = add(c.fp, rotate(sub(c.pos, c.fp), b.r, -deg));
    c.up = rotate(b.u, b.r, -deg);
  };

  View.prototype.dolly = function (factor) { // > 1 comes closer, as VTK's camera.Dolly
    var c = this.cam;
    if (!(factor > 0)) return;
    c.pos = add(c.fp, mul(sub(c.pos, c.fp), 1 / factor));
  };

  /* The projection's scale F (pixels per unit of xc/d) and centre (cx, cy), one place for the
     drawing, the picking, the labels, the selection's mvp and the GPU backend. As VTK's
     perspective camera, F = (H/2)/tan(view_angle/2) about the view's centre, except that (a)
     while a colour legend is shown its strip on the right is left free: the scene is centred in
     the rest (width Wv = W - the strip), so an object framed by the server's camera does not
     open under the legend (the ball bar did); (b) where Wv < H the width is fitted instead of the
     height, F = (Wv/2)/tan(view_angle/2), as VTK's ResetCamera does for an aspect below 1 (the
     server's camera was framed for the server's window, not this one). */
  View.prototype.lens = function () {
    var W = Math.max(this.W, 1), H = Math.max(this.H, 1), Wv = Math.max(W - this.reserved(), 1);
    var t = Math.tan(this.cam.angle * Math.PI / 360);
    return { F: Math.min(H, Wv) / 2 / t, cx: Wv / 2, cy: H / 2 };
  };

  View.prototype.reserved = function () { // px on the right the legend covers (0 without one)
    var box = this.legendBox;
    if (!box || !this.el || box.style.display === "none" || !box.firstChild) return 0;
    var strip = this.W - box.offsetLeft + LEGEND_GAP; // from the legend's left edge, and a gap
    return strip > 0 ? Math.min(strip, this.W / 3) : 0;
  };

  View.prototype.pan = function (dx, dy) { // pixels; the scene follows the pointer
    var b = this.basis();
    var s = b.dist / this.lens().F;
    var m = add(mul(b.r, -dx * s), mul(b.u, dy * s));
    c.pos = add(c.pos, m);
    c.fp = add(c.fp, m);
  };

  View.prototype.worldCamera = function () {
    var o = this.origin, c = this.cam;
    return { position: add(c.pos, o), focal_point: add(c.fp, o), view_up: unit(c.up), view_angle: c.angle };
  };

  /* world mm -> clip, column-major: x_ndc = 2 px / W - 1, y_ndc = 1 - 2 py / H for the pixel
     (px, py) a point is drawn at; w = its depth along the view direction (> 0 in front). */
  View.prototype.mvp = function () {
    var b = this.basis(), o = this.origin, eye = add(b.eye, o), L = this.lens();
    var W = Math.max(this.W, 1), H = Math.max(this.H, 1), sx = 2 * L.F / W, sy = 2 * L.F / H;
    // the centre's offset from the middle, in NDC, times w (= the depth d): x_ndc = 2 px / W - 1
    var ox = 2 * L.cx / W - 1, oy = 1 - 2 * L.cy / H;
    var near = Math.max(b.dist * 1e-3, 1e-9), far = b.dist * 1e3;
    var A = (far + near) / (far - near), B = -2 * far * near / (far - near);
    var rows = [
      [sx * b.r[0] + ox * b.f[0], sx * b.r[1] + ox * b.f[1], sx * b.r[2] + ox * b.f[2], -sx * dot(b.r, eye) - ox * dot(b.f, eye)],
      [sy * b.u[0] + oy * b.f[0], sy * b.u[1] + oy * b.f[1], sy * b.u[2] + oy * b.f[2], -sy * dot(b.u, eye) - oy * dot(b.f, eye)],
      [A * b.f[0], A * b.f[1], A * b.f[2], -A * dot(b.f, eye) + B],
      [b.f[0], b.f[1], b.f[2], -dot(b.f, eye)],
    ];
    var out = [];
    for (var col = 0; col < 4; col++) for (var row = 0; row < 4; row++) out.push(rows[row][col]);
    return out;
  };

  // --- drawing ---
  View.prototype.render = function (full, idsOnly) {
    var t0 = performance.now();
    var W = this.W, H = this.H;
    if (!this.el || W <= 0 || H <= 0 || !this.pix) return 0;
    if (this.gl && !idsOnly) return this.renderGL(t0);
    this.idValid = !!full;
    var pix = this.pix, Z = this.zbuf;
    pix.set(this.bg);
    Z.fill(Infinity);
    if (full) { this.idLayer.fill(0); this.idDepth.fill(Infinity); }
    var drawn = 0, total = 0;
    if (this.cam && this.layers.length) {
      var b = this.basis(), L = this.lens();
      var P = {
        r: b.r, u: b.u, f: b.f, ro: -dot(b.r, b.eye), uo: -dot(b.u, b.eye), fo: -dot(b.f, b.eye),
        F: L.F, cx: L.cx, cy: L.cy,
        near: Math.max(b.dist * 1e-3, 1e-9), W: W, H: H,
      };
      var pointsTotal = 0;
      this.layers.forEach(function (l) { if (l.spec.kind === "points") pointsTotal += l.n; });
      var budget = full ? Infinity : this.forced !== null ? this.forced : this.budget;
      var frac = pointsTotal > budget ? budget / pointsTotal : 1;
      var self = this;
      var order = this.layers.map(function (l, i) { return i; });
      // opaque first; blended layers (opacity < 1) after, z-tested without writing depth
      order.sort(function (a, c) { return (self.layers[a].spec.opacity < 1) - (self.layers[c].spec.opacity < 1); });
      order.forEach(function (i) {
        var l = self.layers[i], s = l.spec, alpha = s.opacity === undefined || s.opacity === null ? 1 : +s.opacity;
        if (!(alpha > 0)) return;
        // a byte per pixel; a translucent mesh too (the Compare page's nominal at 0.55 is picked on)
        var ids = full && s.pickable !== false && (alpha >= 1 || s.kind === "mesh") && i < 255 ? i + 1 : 0;
        if (s.kind === "points") {
          var k = frac < 1 ? Math.max(1, Math.floor(l.n * frac)) : l.n;
          if (k < l.n && k > CHUNK) k -= k % CHUNK; // whole chunks: a uniform subsample (lodSort)
          var size = Math.max(1, Math.round(+s.point_size || 1));
          // a subsample covers the same area with bigger splats (at most twice as wide): fewer holes
          if (k < l.n) size = Math.min(2 * size, Math.round(size * Math.sqrt(l.n / k)));
          drawPoints(self, P, l, k, size, alpha, ids);
          drawn += k;
          total += l.n;
        } else if (s.kind === "mesh") {
          drawMesh(self, P, l, alpha, ids);
        } else {
          drawLines(self, P, l, alpha, ids);
        }
      });
    }
    if (idsOnly) return performance.now() - t0; // picking under the GL backend: the id-buffer only
    this.ctx.putImageData(this.image, 0, 0);
    if (this.cam) this.drawTriad();
    this.placeLabels();
    this.drawn = drawn;
    this.total = total;
    this.lastFull = !!full;
    if (this.spec && this.pendingRev === null) {
      if (full) this.shownRev = this.spec.rev;
      if (this.layers.length || this.spec.rev) this.painted0(); // not the server's empty placeholder
    }
    if (full && this.timing && this.timing.all_drawn_ms === null) this.timing.all_drawn_ms = performance.now() - this.timing.arrived;
    var ms = performance.now() - t0;
    this.lastMs = ms;
    if (!full && this.forced === null && drawn > 0) {
      // aim the next interaction frame at TARGET_MS (cost taken as proportional to the points)
      var want = drawn * TARGET_MS / Math.max(ms, 1);
      this.budget = Math.max(MIN_BUDGET, Math.round(0.5 * this.budget + 0.5 * want));
    }
    return ms;
  };

  /* The interaction frames' loop (opaque splats, no id-buffer, a colour per point):
     this loop is the frame time, so it is the general one below without its branches, with the
     projection folded into two homogeneous rows (X = (F r + cx f).p, Y = (cy f - F u).p, pixel =
     (X/d, Y/d)). Measured: about 20 % less time per frame than the general loop. */
  function drawPointsFast(view, P, pos, col, k, size) {
    var pix = view.pix, Z = view.zbuf, W = P.W, near = P.near, F = P.F, cx = P.cx, cy = P.cy;
    var f0 = P.f[0], f1 = P.f[1], f2 = P.f[2], fo = P.fo;
    var a0 = F * P.r[0] + cx * f0, a1 = F * P.r[1] + cx * f1, a2 = F * P.r[2] + cx * f2, ao = F * P.ro + cx * fo;
    var b0 = cy * f0 - F * P.u[0], b1 = cy * f1 - F * P.u[1], b2 = cy * f2 - F * P.u[2], bo = cy * fo - F * P.uo;
    var h0 = (size - 1) >> 1, Wx = P.W - size + 1, Hy = P.H - size + 1; // splats wholly inside
    var i, j, x, y, z, d, inv, fx, fy, p, q, c, sy, sx;
    for (i = 0, j = 0; i < k; i++, j += 3) {
      x = pos[j]; y = pos[j + 1]; z = pos[j + 2];
      d = f0 * x + f1 * y + f2 * z + fo;
      if (d < near) continue;
      inv = 1 / d;
      fx = (a0 * x + a1 * y + a2 * z + ao) * inv - h0; // the splat's top left
      fy = (b0 * x + b1 * y + b2 * z + bo) * inv - h0;
      if (!(fx >= 0 && fy >= 0 && fx < Wx && fy < Hy)) continue; // the rim's partial splats: skipped while moving
      c = col[i];
      p = (fy | 0) * W + (fx | 0);
      if (size === 2) {
        if (d < Z[p]) { Z[p] = d; pix[p] = c; }
        p++;
        if (d < Z[p]) { Z[p] = d; pix[p] = c; }
        p += W;
        if (d < Z[p]) { Z[p] = d; pix[p] = c; }
        p--;
        if (d < Z[p]) { Z[p] = d; pix[p] = c; }
      } else {
        for (sy = 0; sy < size; sy++, p += W) {
          for (sx = 0, q = p; sx < size; sx++, q++) if (d < Z[q]) { Z[q] = d; pix[q] = c; }
        }
      }
    }
  }

  /* Square splats of `size` px, z-buffered on the depth along the view direction, the id-buffer
     written in full frames. Specialised for 1 and 2 px (the common sizes). Each loop below spells
     out the same projection on purpose: they run for millions of points per frame, and a shared
     per-point function returning (depth, x, y) would allocate or go through a call V8 need not
     inline — the 2 M-point frame budget (~40 ms, docs/bigclouds.md) has no room for either. */
  function drawPoints(view, P, l, k, size, alpha, ids) {
    var pos = l.pos, col = l.col, packed = l.packed, pix = view.pix, Z = view.zbuf;
    if (!ids && alpha >= 1) {
      if (!col) col = l.solid || (l.solid = new Uint32Array(l.n).fill(packed)); // one colour: no branch per point
      drawPointsFast(view, P, pos, col, k, size);
      return;
    }
    var IL = view.idLayer, II = view.idIndex;
    var W = P.W, H = P.H, F = P.F, cx = P.cx, cy = P.cy, near = P.near;
    var r0 = P.r[0], r1 = P.r[1], r2 = P.r[2], ro = P.ro;
    var u0 = P.u[0], u1 = P.u[1], u2 = P.u[2], uo = P.uo;
    var f0 = P.f[0], f1 = P.f[1], f2 = P.f[2], fo = P.fo;
    var i, j, x, y, z, d, inv, fx, fy, sx, sy, p, c;
    if (alpha < 1) { // rare: blended, no depth write, no ids
      var a = alpha;
      for (i = 0, j = 0; i < k; i++, j += 3) {
        x = pos[j]; y = pos[j + 1]; z = pos[j + 2];
        d = f0 * x + f1 * y + f2 * z + fo;
        if (d < near) continue;
        inv = F / d;
        fx = cx + (r0 * x + r1 * y + r2 * z + ro) * inv;
        fy = cy - (u0 * x + u1 * y + u2 * z + uo) * inv;
        if (!(fx >= 0 && fy >= 0 && fx < W && fy < H)) continue;
        p = (fy | 0) * W + (fx | 0);
        if (d <= Z[p]) pix[p] = blend(pix[p], col ? col[i] : packed, a);
      }
      return;
    }
    var h0 = (size - 1) >> 1; // the splat spans [s - h0, s - h0 + size)
    if (size === 1) {
      for (i = 0, j = 0; i < k; i++, j += 3) {
        x = pos[j]; y = pos[j + 1]; z = pos[j + 2];
        d = f0 * x + f1 * y + f2 * z + fo;
        if (d < near) continue;
        inv = F / d;
        fx = cx + (r0 * x + r1 * y + r2 * z + ro) * inv;
        fy = cy - (u0 * x + u1 * y + u2 * z + uo) * inv;
        if (!(fx >= 0 && fy >= 0 && fx < W && fy < H)) continue;
        p = (fy | 0) * W + (fx | 0);
        if (d < Z[p]) {
          Z[p] = d;
          pix[p] = col ? col[i] : packed;
          if (ids) { IL[p] = ids; II[p] = i; }
        }
      }
      return;
    }
    if (size === 2) {
      var W1 = W - 1, H1 = H - 1;
      for (i = 0, j = 0; i < k; i++, j += 3) {
        x = pos[j]; y = pos[j + 1]; z = pos[j + 2];
        d = f0 * x + f1 * y + f2 * z + fo;
        if (d < near) continue;
        inv = F / d;
        fx = cx + (r0 * x + r1 * y + r2 * z + ro) * inv;
        fy = cy - (u0 * x + u1 * y + u2 * z + uo) * inv;
        if (!(fx >= 0 && fy >= 0 && fx < W1 && fy < H1)) { // the rim: pixel by pixel
          if (fx >= -1 && fy >= -1 && fx < W && fy < H) splat(view, P, fx | 0, fy | 0, fx < 0 ? -1 : 0, fy < 0 ? -1 : 0, 2, d, col ? col[i] : packed, ids, i);
          continue;
        }
        c = col ? col[i] : packed;
        p = (fy | 0) * W + (fx | 0);
        if (d < Z[p]) { Z[p] = d; pix[p] = c; if (ids) { IL[p] = ids; II[p] = i; } }
        p++;
        if (d < Z[p]) { Z[p] = d; pix[p] = c; if (ids) { IL[p] = ids; II[p] = i; } }
        p += W;
        if (d < Z[p]) { Z[p] = d; pix[p] = c; if (ids) { IL[p] = ids; II[p] = i; } }
        p--;
        if (d < Z[p]) { Z[p] = d; pix[p] = c; if (ids) { IL[p] = ids; II[p] = i; } }
      }
      return;
    }
    for (i = 0, j = 0; i < k; i++, j += 3) {
      x = pos[j]; y = pos[j + 1]; z = pos[j + 2];
      d = f0 * x + f1 * y + f2 * z + fo;
      if (d < near) continue;
      inv = F / d;
      fx = cx + (r0 * x + r1 * y + r2 * z + ro) * inv;
      fy = cy - (u0 * x + u1 * y + u2 * z + uo) * inv;
      if (!(fx >= -size && fy >= -size && fx < W + size && fy < H + size)) continue;
      sx = Math.floor(fx) - h0;
      sy = Math.floor(fy) - h0;
      splat(view, P, sx, sy, 0, 0, size, d, col ? col[i] : packed, ids, i);
    }
  }

  function splat(view, P, sx, sy, ox, oy, size, d, c, ids, i) { // clipped square
    var W = P.W, H = P.H, Z = view.zbuf, pix = view.pix;
    sx += ox; sy += oy;
    var x0 = Math.max(sx, 0), x1 = Math.min(sx + size, W), y0 = Math.max(sy, 0), y1 = Math.min(sy + size, H);
    for (var y = y0; y < y1; y++) {
      for (var x = x0, p = y * W + x0; x < x1; x++, p++) {
        if (d < Z[p]) {
          Z[p] = d;
          pix[p] = c;
          if (ids) { view.idLayer[p] = ids; view.idIndex[p] = i; }
        }
      }
    }
  }

  function blend(dst, src, a) {
    var b = 1 - a;
    var r = (dst & 255) * b + (src & 255) * a;
    var g = ((dst >>> 8) & 255) * b + ((src >>> 8) & 255) * a;
    var bl = ((dst >>> 16) & 255) * b + ((src >>> 16) & 255) * a;
    return (0xff000000 | ((bl + 0.5) << 16) | ((g + 0.5) << 8) | (r + 0.5)) >>> 0;
  }

  // the vertices on screen: pixel x, y and depth (NaN behind the near plane), one scratch per view
  function project(view, P, l) {
    var n = l.n, pos = l.pos;
    if (!view.scratch || view.scratch.length < 3 * n) view.scratch = new Float64Array(3 * n);
    var S = view.scratch, F = P.F, cx = P.cx, cy = P.cy, near = P.near;
    var r0 = P.r[0], r1 = P.r[1], r2 = P.r[2], ro = P.ro;
    var u0 = P.u[0], u1 = P.u[1], u2 = P.u[2], uo = P.uo;
    var f0 = P.f[0], f1 = P.f[1], f2 = P.f[2], fo = P.fo;
    for (var j = 0; j < 3 * n; j += 3) {
      var x = pos[j], y = pos[j + 1], z = pos[j + 2];
      var d = f0 * x + f1 * y + f2 * z + fo;
      if (d < near) { S[j + 2] = NaN; continue; }
      var inv = F / d;
      S[j] = cx + (r0 * x + r1 * y + r2 * z + ro) * inv;
      S[j + 1] = cy - (u0 * x + u1 * y + u2 * z + uo) * inv;
      S[j + 2] = d;
    }
    return S;
  }

  /* Triangles: edge functions over the clipped bounding box at pixel centres, depth
     interpolated perspective-correctly (1/d is affine on the screen), vertex colours affinely,
     flat Lambert shading from the face normal under a headlight (a directional light along the
     view direction, as VTK's), two-sided, with some ambient: shade = 0.3 + 0.7 |cos(normal, view)|. A triangle with a vertex behind the
     near plane is skipped. */
  function drawMesh(view, P, l, alpha, ids) {
    var S = project(view, P, l), idx = l.idx, pos = l.pos, col = l.col, packed = l.packed;
    var W = P.W, H = P.H, Z = view.zbuf, pix = view.pix, IL = view.idLayer, II = view.idIndex;
    var lx = P.f[0], ly = P.f[1], lz = P.f[2], T = idx.length / 3; // the headlight shines along the view
    for (var t = 0; t < T; t++) {
      var ia = idx[3 * t], ib = idx[3 * t + 1], ic = idx[3 * t + 2];
      var ax = S[3 * ia], ay = S[3 * ia + 1], ad = S[3 * ia + 2];
      var bx = S[3 * ib], by = S[3 * ib + 1], bd = S[3 * ib + 2];
      var qx = S[3 * ic], qy = S[3 * ic + 1], qd = S[3 * ic + 2];
      if (!(ad > 0 && bd > 0 && qd > 0)) continue;
      var area = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax);
      if (!(Math.abs(area) > 1e-12)) continue;
      var minx = Math.max(0, Math.floor(Math.min(ax, bx, qx))), maxx = Math.min(W - 1, Math.ceil(Math.max(ax, bx, qx)));
      var miny = Math.max(0, Math.floor(Math.min(ay, by, qy))), maxy = Math.min(H - 1, Math.ceil(Math.max(ay, by, qy)));
      if (minx > maxx || miny > maxy) continue;
      // face normal and Lambert under the headlight
      var pa = 3 * ia, pb = 3 * ib, pc = 3 * ic;
      var e1x = pos[pb] - pos[pa], e1y = pos[pb + 1] - pos[pa + 1], e1z = pos[pb + 2] - pos[pa + 2];
      var e2x = pos[pc] - pos[pa], e2y = pos[pc + 1] - pos[pa + 1], e2z = pos[pc + 2] - pos[pa + 2];
      var nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
      var nn = Math.sqrt(nx * nx + ny * ny + nz * nz);
      var shade = 0.3 + 0.7 * (nn > 0 ? Math.abs(nx * lx + ny * ly + nz * lz) / nn : 1);
      var ca = col ? col[ia] : packed, cb = col ? col[ib] : packed, cc = col ? col[ic] : packed;
      var rA = (ca & 255) * shade, gA = ((ca >>> 8) & 255) * shade, bA = ((ca >>> 16) & 255) * shade;
      var rB = (cb & 255) * shade, gB = ((cb >>> 8) & 255) * shade, bB = ((cb >>> 16) & 255) * shade;
      var rC = (cc & 255) * shade, gC = ((cc >>> 8) & 255) * shade, bC = ((cc >>> 16) & 255) * shade;
      var flat = ca === cb && ca === cc;
      var flatColor = (0xff000000 | ((bA + 0.5) << 16) | ((gA + 0.5) << 8) | (rA + 0.5)) >>> 0;
      var ia2 = 1 / area, za = 1 / ad, zb = 1 / bd, zc = 1 / qd;
      // barycentric weights of b and c: w1 = (p-a)x(c-a) / area, w2 = (b-a)x(p-a) / area, affine in x
      var w1dx = (qy - ay) * ia2, w2dx = (ay - by) * ia2;
      for (var y = miny; y <= maxy; y++) {
        var py = y + 0.5, px0 = minx + 0.5;
        var w1 = ((px0 - ax) * (qy - ay) - (py - ay) * (qx - ax)) * ia2;
        var w2 = ((bx - ax) * (py - ay) - (by - ay) * (px0 - ax)) * ia2;
        for (var x = minx, p = y * W + minx; x <= maxx; x++, p++, w1 += w1dx, w2 += w2dx) {
          var w0 = 1 - w1 - w2;
          if (w0 < 0 || w1 < 0 || w2 < 0) continue;
          var d = 1 / (w0 * za + w1 * zb + w2 * zc);
          if (!(d < Z[p])) continue;
          var c;
          if (flat) c = flatColor;
          else {
            c = (0xff000000 | (((w0 * bA + w1 * bB + w2 * bC) + 0.5) << 16) |
              (((w0 * gA + w1 * gB + w2 * gC) + 0.5) << 8) | ((w0 * rA + w1 * rB + w2 * rC) + 0.5)) >>> 0;
          }
          if (alpha < 1) {
            pix[p] = blend(pix[p], c, alpha);
            if (ids && d < view.idDepth[p]) { view.idDepth[p] = d; IL[p] = ids; II[p] = t; } // nearest face: the pick
            continue;
          }
          Z[p] = d;
          pix[p] = c;
          if (ids) { IL[p] = ids; II[p] = t; }
        }
      }
    }
  }

  /* Segments of line_width px (default 1), z-tested with a small bias so that a line on a
     surface shows (on_top: no test), depth interpolated along the segment. */
  function drawLines(view, P, l, alpha, ids) {
    var S = project(view, P, l), idx = l.idx, col = l.col, packed = l.packed, s = l.spec;
    var W = P.W, H = P.H, Z = view.zbuf, pix = view.pix, IL = view.idLayer, II = view.idIndex;
    var width = Math.max(1, Math.round(+s.line_width || 1)), top = !!s.on_top, h0 = (width - 1) >> 1;
    var E = idx.length / 2;
    for (var e = 0; e < E; e++) {
      var ia = idx[2 * e], ib = idx[2 * e + 1];
      var ax = S[3 * ia], ay = S[3 * ia + 1], ad = S[3 * ia + 2];
      var bx = S[3 * ib], by = S[3 * ib + 1], bd = S[3 * ib + 2];
      if (!(ad > 0 && bd > 0)) continue;
      var c = col ? col[ia] : packed;
      var steps = Math.ceil(Math.max(Math.abs(bx - ax), Math.abs(by - ay)));
      if (steps > 4 * (W + H)) steps = 4 * (W + H); // a segment from far off screen: coarser is fine
      for (var k = 0; k <= steps; k++) {
        var t = steps ? k / steps : 0;
        var fx = ax + (bx - ax) * t, fy = ay + (by - ay) * t;
        var d = 1 / ((1 - t) / ad + t / bd);
        var sx = Math.floor(fx) - h0, sy = Math.floor(fy) - h0;
        for (var yy = Math.max(sy, 0); yy < Math.min(sy + width, H); yy++) {
          for (var xx = Math.max(sx, 0); xx < Math.min(sx + width, W); xx++) {
            var p = yy * W + xx;
            if (!top && !(d <= Z[p] * 1.002)) continue;
            if (alpha < 1) { pix[p] = blend(pix[p], c, alpha); continue; }
            Z[p] = top ? Math.min(Z[p], d) : d;
            pix[p] = c;
            if (ids) { IL[p] = ids; II[p] = e; }
          }
        }
      }
    }
  }

  View.prototype.drawTriad = function () { // x red, y green, z blue, as VTK's axes actor
    var ctx = this.ctx, b = this.basis(), ox = 38, oy = this.H - 38, L = 26;
    var axes = [[1, 0, 0, "#d62728", "X"], [0, 1, 0, "#2ca02c", "Y"], [0, 0, 1, "#1f5fd6", "Z"]];
    axes.sort(function (a, c) { return dot(c, b.f) - dot(a, b.f); }); // the far ones first
    ctx.save();
    ctx.lineWidth = 2;
    ctx.font = "bold 11px sans-serif";
    ctx.textAlign = "center";
    ctx.textBaseline = "middle";
    axes.forEach(function (a) {
      var x = dot(a, b.r), y = -dot(a, b.u);
      ctx.strokeStyle = ctx.fillStyle = a[3];
      ctx.beginPath();
      ctx.moveTo(ox, oy);
      ctx.lineTo(ox + L * x, oy + L * y);
      ctx.stroke();
      ctx.fillText(a[4], ox + (L + 8) * x, oy + (L + 8) * y);
    });
    ctx.restore();
  };

  // --- overlays ---
  View.prototype.setBusy = function (on) {
    if (this.busyBox) this.busyBox.style.display = on ? "" : "none";
  };

  /* The first picture is up (a scene's frame, or the server said there is nothing to draw, or
     it failed): the spinner goes, for good (later contents keep the last picture meanwhile). */
  View.prototype.painted0 = function () {
    this.painted = true;
    this.setBusy(false);
  };

  View.prototype.setNote = function (text) {
    if (this.noteBox) {
      this.noteBox.textContent = text || "";
      this.noteBox.style.display = text ? "" : "none";
    }
  };

  View.prototype.applyOverlays = function () {
    if (!this.el) return;
    var s = this.spec || {};
    this.setNote(this.pendingRev !== null ? "loading …" : this.error || s.note || "");
    var legend = s.legend || null, key = JSON.stringify(legend);
    if (key !== this.legendKey) {
      this.legendKey = key;
      buildLegend(this.legendBox, legend);
    }
    var entries = s.entries || [], ekey = JSON.stringify(entries);
    if (ekey !== this.entriesKey) {
      this.entriesKey = ekey;
      var box = this.entriesBox;
      box.textContent = "";
      box.style.display = entries.length ? "" : "none";
      entries.forEach(function (e) {
        var row = el("div", "cmm-cv-entry", box);
        el("span", "cmm-cv-swatch", row).style.background = cssRGB(vec3(e.color, DEFAULT_COLOR));
        el("span", "", row).textContent = String(e.text);
      });
    }
    var labels = s.labels || [];
    while (this.labelEls.length > labels.length) this.labelBox.removeChild(this.labelEls.pop());
    while (this.labelEls.length < labels.length) {
      var lab = el("div", "cmm-cv-label", this.labelBox);
      el("span", "cmm-cv-dot", lab);
      el("span", "cmm-cv-text", lab);
      this.labelEls.push(lab);
    }
    var o = this.origin;
    this.labelPos = labels.map(function (lb, i) {
      return sub(vec3(lb.pos, [0, 0, 0]), o);
    });
    var els = this.labelEls;
    labels.forEach(function (lb, i) {
      var c = cssRGB(vec3(lb.color, [0, 0, 0]));
      els[i].lastChild.textContent = String(lb.text);
      els[i].lastChild.style.color = c;
      els[i].firstChild.style.background = c;
    });
    this.svg.style.pointerEvents = "none";
    this.canvas.style.cursor = s.tool === "lasso" || s.tool === "rect" ? "crosshair" : "";
    this.placeLabels();
  };

  /* Each label's dot at its point, its text above right of it; where two texts would overlap
     (two picks close on the screen) the later one is lifted above the other (its dot stays at
     its point): in screen order, bottom-most first, each text goes up until it is clear of every
     text placed before it, by LABEL_GAP. */
  View.prototype.placeLabels = function () {
    if (!this.labelEls || !this.labelEls.length || !this.cam) return;
    var b = this.basis(), W = this.W, H = this.H, L = this.lens(), F = L.F, shown = [];
    for (var i = 0; i < this.labelEls.length; i++) {
      var q = sub(this.labelPos[i], b.eye), d = dot(q, b.f), e = this.labelEls[i];
      if (!(d > 0)) { e.style.display = "none"; continue; }
      var x = L.cx + F * dot(q, b.r) / d, y = L.cy - F * dot(q, b.u) / d;
      e.style.display = x >= 0 && y >= 0 && x <= W && y <= H ? "" : "none";
      e.style.transform = "translate(" + x.toFixed(1) + "px," + y.toFixed(1) + "px)";
      if (e.style.display !== "none") shown.push({ e: e, x: x, y: y });
    }
    // the text's box relative to the dot: left 6 px, bottom 4 px above it (cmm-cv-text)
    shown.sort(function (a, c) { return c.y - a.y || a.x - c.x; });
    var placed = [];
    shown.forEach(function (s) {
      var t = s.e.lastChild, w = t.offsetWidth, h = t.offsetHeight, lift = 0;
      var x0 = s.x + 6, x1 = x0 + w;
      for (var moved = true, guard = 0; moved && guard < 64; guard++) {
        moved = false;
        var y1 = s.y - 4 - lift, y0 = y1 - h;
        for (var k = 0; k < placed.length; k++) {
          var p = placed[k];
          if (x0 < p.x1 + LABEL_GAP && p.x0 < x1 + LABEL_GAP && y0 < p.y1 + LABEL_GAP && p.y0 < y1 + LABEL_GAP) {
            lift = s.y - 4 - (p.y0 - LABEL_GAP); // its bottom just above that one's top
            moved = true;
          }
        }
      }
      t.style.bottom = (4 + lift).toFixed(1) + "px";
      t.classList.toggle("cmm-cv-lifted", lift > 0);
      placed.push({ x0: x0, x1: x1, y0: s.y - 4 - lift - h, y1: s.y - 4 - lift });
    });
  };

  /* VTK's scalar bar: a vertical gradient lo (bottom) to hi (top), the title above, the tick
     labels beside at their values. */
  function buildLegend(box, legend) {
    box.textContent = "";
    box.style.display = legend ? "" : "none";
    if (!legend) return;
    el("div", "cmm-cv-legend-title", box).textContent = String(legend.title || "");
    var body = el("div", "cmm-cv-legend-body", box);
    var bar = el("div", "cmm-cv-legend-bar", body);
    var stops = (legend.colors || []).map(function (c, i, all) {
      return cssRGB(c) + " " + (all.length > 1 ? (100 * i) / (all.length - 1) : 0).toFixed(2) + "%";
    });
    if (stops.length === 1) stops.push(stops[0].replace(/ [0-9.]+%$/, " 100%"));
    bar.style.background = stops.length ? "linear-gradient(to top, " + stops.join(", ") + ")" : "#ccc";
    var ticks = el("div", "cmm-cv-legend-ticks", body);
    var lo = +legend.lo, hi = +legend.hi;
    (legend.labels || []).forEach(function (t) {
      var f = hi !== lo ? (+t.value - lo) / (hi - lo) : 0.5;
      if (!(f >= -1e-9 && f <= 1 + 1e-9)) return;
      var tick = el("div", "cmm-cv-tick", ticks);
      tick.style.bottom = (100 * Math.min(Math.max(f, 0), 1)).toFixed(2) + "%";
      tick.textContent = String(t.text);
    });
  }

  // --- events ---
  View.prototype.requestFrame = function () {
    var self = this;
    if (this.raf) return;
    this.raf = requestAnimationFrame(function () {
      self.raf = 0;
      self.render(false);
    });
  };

  View.prototype.rest = function () { // the interaction is over (for now): everything, once
    var self = this;
    clearTimeout(this.restTimer);
    this.restTimer = setTimeout(function () {
      self.restTimer = 0;
      if (self.raf) { cancelAnimationFrame(self.raf); self.raf = 0; }
      self.render(true);
      if (self.camDirty) {
        self.camDirty = false;
        trigger("cv_camera", [self.name, self.worldCamera(), [self.W, self.H]]);
      }
    }, REST_MS);
  };

  View.prototype.moved = function () {
    this.camDirty = true;
    this.requestFrame();
    this.rest();
  };

  View.prototype.bindEvents = function () {
    var self = this, cv = this.canvas, drag = null, pickTimer = 0;
    function local(e) {
      var r = cv.getBoundingClientRect();
      return [e.clientX - r.left, e.clientY - r.top];
    }
    function tool() { var t = self.spec && self.spec.tool; return t === "lasso" || t === "rect" ? t : "rotate"; }
    function down(e) {
      if (!self.cam) return;
      clearTimeout(pickTimer); // a second click: a double-click, not two picks
      pickTimer = 0;
      var p = local(e), mode;
      if (e.button === 2 || e.button === 1 || (e.button === 0 && e.shiftKey)) mode = "pan";
      else if (e.button === 0) mode = tool() === "rotate" ? "rotate" : tool();
      else return;
      drag = { mode: mode, start: p, last: p, moved: false, poly: [p], button: e.button };
      try { cv.setPointerCapture(e.pointerId); } catch (err) { /* synthetic events */ }
      e.preventDefault(); // no text selection while dragging; it also keeps the focus where it was, so:
      var a = document.activeElement; // a field typed in before leaves it, as a click anywhere else does
      if (a && a !== document.body && typeof a.blur === "function") a.blur();
    }
    function move(e) {
      if (!drag) return;
      var p = local(e), dx = p[0] - drag.last[0], dy = p[1] - drag.last[1];
      if (!drag.moved && Math.abs(p[0] - drag.start[0]) + Math.abs(p[1] - drag.start[1]) > CLICK_SLOP) drag.moved = true;
      if (drag.mode === "rotate") {
        self.azimuth((-dx * 200) / Math.max(self.W, 1));
        self.elevation((dy * 200) / Math.max(self.H, 1));
        self.moved();
      } else if (drag.mode === "pan") {
        self.pan(dx, dy);
        self.moved();
      } else {
        var q = drag.poly[drag.poly.length - 1];
        if (drag.mode === "lasso" && Math.abs(p[0] - q[0]) + Math.abs(p[1] - q[1]) >= 3) drag.poly.push(p);
        self.showPolygon(drag.mode === "rect" ? rectOf(drag.start, p) : drag.poly.concat([p]));
      }
      drag.last = p;
    }
    function up(e) {
      if (!drag) return;
      var d = drag, p = local(e);
      drag = null;
      try { cv.releasePointerCapture(e.pointerId); } catch (err) { /* synthetic events */ }
      if (d.mode === "lasso" || d.mode === "rect") {
        self.showPolygon(null);
        if (!d.moved) return;
        var poly = d.mode === "rect" ? rectOf(d.start, p) : d.poly.concat([p]);
        if (poly.length >= 3) self.select(d.mode, poly);
        return;
      }
      if (!d.moved && d.button === 0 && !e.shiftKey) {
        pickTimer = setTimeout(function () { pickTimer = 0; self.pick(p[0], p[1]); }, DBLCLICK_MS);
      }
    }
    function wheel(e) {
      if (!self.cam) return;
      e.preventDefault();
      var dy = e.deltaMode === 1 ? e.deltaY * 33 : e.deltaMode === 2 ? e.deltaY * 400 : e.deltaY;
      self.dolly(Math.pow(1.1, -dy / 100));
      self.moved();
    }
    function dbl(e) {
      clearTimeout(pickTimer);
      pickTimer = 0;
      if (!self.serverCam) return;
      e.preventDefault();
      self.cam = copyCam(self.serverCam);
      self.camDirty = true;
      self.render(true);
      self.rest();
    }
    function menu(e) { e.preventDefault(); }
    cv.addEventListener("pointerdown", down);
    cv.addEventListener("pointermove", move);
    cv.addEventListener("pointerup", up);
    cv.addEventListener("pointercancel", up);
    cv.addEventListener("wheel", wheel, { passive: false });
    cv.addEventListener("dblclick", dbl);
    cv.addEventListener("contextmenu", menu);
    this.unbind = function () {
      clearTimeout(pickTimer);
      cv.removeEventListener("pointerdown", down);
      cv.removeEventListener("pointermove", move);
      cv.removeEventListener("pointerup", up);
      cv.removeEventListener("pointercancel", up);
      cv.removeEventListener("wheel", wheel);
      cv.removeEventListener("dblclick", dbl);
      cv.removeEventListener("contextmenu", menu);
    };
  };

  function rectOf(a, b) { return [[a[0], a[1]], [b[0], a[1]], [b[0], b[1]], [a[0], b[1]]]; }

  View.prototype.showPolygon = function (pts) {
    if (!pts) { this.poly.setAttribute("points", ""); this.svg.style.display = "none"; return; }
    this.svg.style.display = "block"; // the stylesheet hides it
    this.poly.setAttribute("points", pts.map(function (p) { return p[0].toFixed(1) + "," + p[1].toFixed(1); }).join(" "));
  };

  View.prototype.select = function (shape, pts) {
    var W = Math.max(this.W, 1), H = Math.max(this.H, 1);
    var ndc = pts.map(function (p) { return [(2 * p[0]) / W - 1, 1 - (2 * p[1]) / H]; });
    trigger("cv_select", [this.name, { shape: shape, polygon: ndc, mvp: this.mvp() }]);
  };

  /* The id-buffer of a full frame: the covered pixel nearest (x, y) within PICK_RADIUS. */
  View.prototype.pickAt = function (x, y) {
    if (!this.idValid) this.render(true, true);
    var W = this.W, H = this.H, IL = this.idLayer, II = this.idIndex, Z = this.zbuf;
    var cx = Math.floor(x), cy = Math.floor(y), best = -1, bestD = Infinity;
    for (var yy = Math.max(cy - PICK_RADIUS, 0); yy <= Math.min(cy + PICK_RADIUS, H - 1); yy++) {
      for (var xx = Math.max(cx - PICK_RADIUS, 0); xx <= Math.min(cx + PICK_RADIUS, W - 1); xx++) {
        var p = yy * W + xx;
        if (!IL[p]) continue;
        var d2 = (xx - cx) * (xx - cx) + (yy - cy) * (yy - cy);
        if (d2 < bestD || (d2 === bestD && Z[p] < Z[best])) { bestD = d2; best = p; }
      }
    }
    if (best < 0) return null;
    var layer = this.layers[IL[best] - 1], i = II[best], s = layer.spec, pos = layer.pos, o = this.origin;
    function at(k) { return [pos[3 * k], pos[3 * k + 1], pos[3 * k + 2]]; }
    if (s.kind === "points") return { layer: s.id, index: layer.perm ? layer.perm[i] : i, world: add(at(i), o) };
    var verts = s.kind === "mesh" ? [layer.idx[3 * i], layer.idx[3 * i + 1], layer.idx[3 * i + 2]] : [layer.idx[2 * i], layer.idx[2 * i + 1]];
    // the surface point under the pixel centre at its depth
    var b = this.basis(), L = this.lens(), F = L.F;
    var d = this.idDepth[best] < Infinity ? this.idDepth[best] : Z[best]; // a translucent mesh's own depth
    var px = (best % W) + 0.5, py = Math.floor(best / W) + 0.5;
    var q = add(b.eye, add(mul(b.f, d), add(mul(b.r, ((px - L.cx) * d) / F), mul(b.u, (-(py - L.cy) * d) / F))));
    var near = verts[0], nd = Infinity;
    verts.forEach(function (v) { var dd = len(sub(at(v), q)); if (dd < nd) { nd = dd; near = v; } });
    return { layer: s.id, index: near, world: add(s.kind === "mesh" ? q : at(near), o) };
  };

  View.prototype.pick = function (x, y) {
    var hit = this.pickAt(x, y);
    if (hit) trigger("cv_pick", [this.name, hit.layer, hit.index, hit.world]);
    return hit;
  };

  // --- for tests and benchmarks ---
  /* One interaction frame after moving the camera by `delta` ({azimuth, elevation} degrees,
     {dolly} factor, {pan: [dx, dy]} px; {full: true} draws everything): its time in ms. */
  View.prototype.frame = function (delta) {
    delta = delta || {};
    if (this.cam) {
      if (delta.azimuth) this.azimuth(+delta.azimuth);
      if (delta.elevation) this.elevation(+delta.elevation);
      if (delta.dolly) this.dolly(+delta.dolly);
      if (delta.pan) this.pan(+delta.pan[0], +delta.pan[1]);
    }
    if (!this.gl) return this.render(!!delta.full);
    var t0 = performance.now();
    this.render(!!delta.full);
    this.gl.gl.readPixels(0, 0, 1, 1, this.gl.gl.RGBA, this.gl.gl.UNSIGNED_BYTE, new Uint8Array(4)); // waits for the GPU
    return (this.lastMs = performance.now() - t0);
  };

  View.prototype.stats = function () {
    var own = 0;
    if (this.pix) own = this.pix.byteLength * 3 + this.zbuf.byteLength + this.idLayer.byteLength + this.idIndex.byteLength;
    return {
      points_drawn: this.drawn, points_total: this.total, last_frame_ms: this.lastMs,
      budget: this.forced !== null ? this.forced : this.budget, full: this.lastFull, backend: this.gl ? "webgl2" : "cpu",
      rev: this.spec ? this.spec.rev : null, shown_rev: this.shownRev, bytes: cachedBytes() + own,
      buffer_bytes: cachedBytes(), error: this.error, width: this.W, height: this.H, timing: this.timing || null,
    };
  };

  View.prototype.setBudget = function (k) { this.forced = k === null || k === undefined ? null : Math.max(1, Math.floor(+k) || 1); };

  // -- optional GPU backend (WebGL2) -------------------------------------------------------------
  /* Only where the browser has a hardware GPU: SwiftShader / llvmpipe (software GL) are slower
     than the CPU splatter above. window.CAMCMM_CLOUDVIEW_BACKEND = "cpu" | "webgl" overrides the
     choice (tests). Same picture: square points of point_size px, flat Lambert shading of the
     faces (0.3 + 0.7 |cos(normal, view)|, normal from the screen derivatives), vertex colours,
     opacity blended after the opaque layers, lines 1 px; every point drawn in every frame.
     Picking still reads the CPU id-buffer (one CPU pass at the click). */
  var glChoice = null;

  function useWebGL() {
    var pref = window.CAMCMM_CLOUDVIEW_BACKEND;
    if (pref === "cpu") return false;
    if (pref === "webgl") return true;
    if (glChoice !== null) return glChoice;
    glChoice = false;
    try {
      var gl = document.createElement("canvas").getContext("webgl2");
      if (gl) {
        var info = gl.getExtension("WEBGL_debug_renderer_info");
        var name = String(info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER));
        glChoice = !/swiftshader|llvmpipe|softpipe|software|basic render/i.test(name);
        var lose = gl.getExtension("WEBGL_lose_context");
        if (lose) lose.loseContext();
      }
    } catch (e) {
      glChoice = false;
    }
    return glChoice;
  }

  var VS = "#version 300 es\n" +
    "uniform mat4 uM; uniform mat4 uV; uniform float uSize;\n" +
    "in vec3 aPos; in vec4 aCol; out vec4 vCol; out vec3 vView;\n" +
    "void main() { gl_Position = uM * vec4(aPos, 1.0); gl_PointSize = uSize; vCol = aCol;\n" +
    "  vView = (uV * vec4(aPos, 1.0)).xyz; }\n";
  var FS_FLAT = "#version 300 es\nprecision highp float;\n" +
    "uniform float uAlpha; in vec4 vCol; in vec3 vView; out vec4 o;\n" +
    "void main() { o = vec4(vCol.rgb * uAlpha, uAlpha); }\n";
  var FS_LIT = "#version 300 es\nprecision highp float;\n" +
    "uniform float uAlpha; in vec4 vCol; in vec3 vView; out vec4 o;\n" +
    "void main() { vec3 n = normalize(cross(dFdx(vView), dFdy(vView)));\n" +
    "  float s = 0.3 + 0.7 * abs(n.z); o = vec4(vCol.rgb * s * uAlpha, uAlpha); }\n";

  function makeGL(view, canvas) {
    var gl = canvas.getContext("webgl2", { alpha: true, premultipliedAlpha: true, antialias: false });
    if (!gl) return null;
    function program(fs) {
      var p = gl.createProgram();
      [[gl.VERTEX_SHADER, VS], [gl.FRAGMENT_SHADER, fs]].forEach(function (src) {
        var sh = gl.createShader(src[0]);
        gl.shaderSource(sh, src[1]);
        gl.compileShader(sh);
        if (!gl.getShaderParameter(sh, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(sh));
        gl.attachShader(p, sh);
      });
      gl.bindAttribLocation(p, 0, "aPos");
      gl.bindAttribLocation(p, 1, "aCol");
      gl.linkProgram(p);
      if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
      return { p: p, uM: gl.getUniformLocation(p, "uM"), uV: gl.getUniformLocation(p, "uV"),
        uSize: gl.getUniformLocation(p, "uSize"), uAlpha: gl.getUniformLocation(p, "uAlpha") };
    }
    var g;
    try {
      g = { gl: gl, flat: program(FS_FLAT), lit: program(FS_LIT), buffers: new Map() };
    } catch (e) {
      console.error("camcmm cloudview: WebGL2 backend unavailable, drawing on the CPU", e);
      return null;
    }
    canvas.addEventListener("webglcontextlost", function (e) { // back to the CPU
      e.preventDefault();
      if (view.gl === g) { view.gl = null; view.render(true); }
    });
    g.buffer = function (array, target) { // one GL buffer per typed array (cached by identity)
      var b = g.buffers.get(array);
      if (!b) {
        b = gl.createBuffer();
        gl.bindBuffer(target, b);
        gl.bufferData(target, array, gl.STATIC_DRAW);
        g.buffers.set(array, b);
      }
      gl.bindBuffer(target, b);
      return b;
    };
    g.prune = function (keep) { // free the buffers of arrays no layer shows any more
      g.buffers.forEach(function (b, a) { if (keep.indexOf(a) < 0) { gl.deleteBuffer(b); g.buffers.delete(a); } });
    };
    g.release = function () { g.prune([]); };
    return g;
  }

  function columnMajor(rows) {
    var out = new Float32Array(16);
    for (var c = 0; c < 4; c++) for (var r = 0; r < 4; r++) out[4 * c + r] = rows[r][c];
    return out;
  }

  View.prototype.renderGL = function (t0) {
    var g = this.gl, gl = g.gl, W = this.W, H = this.H, self = this;
    this.idValid = false;
    gl.viewport(0, 0, W, H);
    gl.clearColor(0, 0, 0, 0); // the host's CSS gradient shows through
    gl.clearDepth(1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    var drawn = 0;
    if (this.cam && this.layers.length) {
      var b = this.basis(), c = this.cam, eye = b.eye;
      var L = this.lens(), sx = 2 * L.F / W, sy = 2 * L.F / H, ox = 2 * L.cx / W - 1, oy = 1 - 2 * L.cy / H;
      var bs = this.bounds(), near = Math.max(b.dist * 1e-3, 1e-9);
      var far = Math.max(len(sub(bs.centre, eye)) + bs.radius, 2 * near);
      near = Math.max(near, far * 1e-5); // 24-bit depth: keep far/near moderate
      var A = (far + near) / (far - near), B = -2 * far * near / (far - near);
      var view = [[b.r[0], b.r[1], b.r[2], -dot(b.r, eye)], [b.u[0], b.u[1], b.u[2], -dot(b.u, eye)],
        [b.f[0], b.f[1], b.f[2], -dot(b.f, eye)], [0, 0, 0, 1]];
      var clip = [view[0].map(function (v, i) { return v * sx + ox * view[2][i]; }),
        view[1].map(function (v, i) { return v * sy + oy * view[2][i]; }),
        view[2].map(function (v, i) { return A * v + (i === 3 ? B : 0); }), view[2]];
      var M = columnMajor(clip), V = columnMajor(view);
      gl.enable(gl.DEPTH_TEST);
      gl.depthFunc(gl.LEQUAL);
      gl.enable(gl.BLEND);
      gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA); // premultiplied colours
      var keep = [];
      var order = this.layers.filter(function (l) { return !(l.spec.opacity < 1); })
        .concat(this.layers.filter(function (l) { return l.spec.opacity < 1 && l.spec.opacity > 0; }));
      order.forEach(function (l) {
        var s = l.spec, alpha = s.opacity < 1 ? +s.opacity : 1, prog = s.kind === "mesh" ? g.lit : g.flat;
        gl.useProgram(prog.p);
        gl.uniformMatrix4fv(prog.uM, false, M);
        gl.uniformMatrix4fv(prog.uV, false, V);
        gl.uniform1f(prog.uSize, Math.max(1, Math.round(+s.point_size || 1)));
        gl.uniform1f(prog.uAlpha, alpha);
        gl.depthMask(alpha >= 1);
        if (s.on_top) gl.disable(gl.DEPTH_TEST);
        else gl.enable(gl.DEPTH_TEST);
        g.buffer(l.pos, gl.ARRAY_BUFFER);
        keep.push(l.pos);
        gl.enableVertexAttribArray(0);
        gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
        if (l.col) {
          g.buffer(l.col, gl.ARRAY_BUFFER); // packed 0xAABBGGRR: the bytes R, G, B, A
          keep.push(l.col);
          gl.enableVertexAttribArray(1);
          gl.vertexAttribPointer(1, 4, gl.UNSIGNED_BYTE, true, 0, 0);
        } else {
          gl.disableVertexAttribArray(1);
          var k = l.packed;
          gl.vertexAttrib4f(1, (k & 255) / 255, ((k >>> 8) & 255) / 255, ((k >>> 16) & 255) / 255, 1);
        }
        if (s.kind === "points") {
          gl.drawArrays(gl.POINTS, 0, l.n);
          drawn += l.n;
        } else {
          g.buffer(l.idx, gl.ELEMENT_ARRAY_BUFFER);
          keep.push(l.idx);
          gl.drawElements(s.kind === "mesh" ? gl.TRIANGLES : gl.LINES, l.idx.length, gl.UNSIGNED_INT, 0);
        }
      });
      gl.depthMask(true);
      g.prune(keep);
    }
    this.ctx.clearRect(0, 0, W, H);
    if (this.cam) this.drawTriad();
    this.placeLabels();
    this.drawn = this.total = drawn;
    this.lastFull = true;
    if (this.spec && this.pendingRev === null) {
      this.shownRev = this.spec.rev;
      if (this.layers.length || this.spec.rev) this.painted0();
    }
    if (this.timing && this.timing.all_drawn_ms === null) this.timing.all_drawn_ms = performance.now() - this.timing.arrived;
    this.lastMs = performance.now() - t0;
    return this.lastMs;
  };

  View.prototype.bounds = function () { // a bounding sphere of the shown content (sampled), per state
    if (this.boundsOf === this.layers) return this.boundsVal;
    var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity], k;
    this.layers.forEach(function (l) {
      var p = l.pos, m = 3 * l.n, step = Math.max(3, 3 * Math.floor(l.n / 100000)); // a sample is enough
      for (var i = 0; i < m; i += step) {
        for (k = 0; k < 3; k++) {
          if (p[i + k] < lo[k]) lo[k] = p[i + k];
          if (p[i + k] > hi[k]) hi[k] = p[i + k];
        }
      }
    });
    if (!(lo[0] <= hi[0])) { lo = [0, 0, 0]; hi = [0, 0, 0]; }
    this.boundsOf = this.layers;
    this.boundsVal = { centre: mul(add(lo, hi), 0.5), radius: len(sub(hi, lo)) * 0.55 + 1e-6 };
    return this.boundsVal;
  };

  // -- binding --------------------------------------------------------------------------------
  function scan() {
    var found = document.querySelectorAll("div.cmm-cloudview[data-cv]");
    for (var i = 0; i < found.length; i++) {
      var host = found[i], name = host.getAttribute("data-cv");
      if (!name) continue;
      var v = views[name] || (views[name] = new View(name));
      if (v.el !== host || !v.canvas || v.canvas.parentNode !== host) v.attach(host);
    }
    Object.keys(views).forEach(function (k) { // an element gone for good: let its frame buffers go
      var v = views[k];
      if (v.el && !v.el.isConnected) v.detach();
    });
  }

  var scanPending = false;
  function later() {
    if (scanPending) return;
    scanPending = true;
    Promise.resolve().then(function () { scanPending = false; scan(); });
  }

  function start() {
    new MutationObserver(later).observe(document.body, { childList: true, subtree: true });
    scan();
  }

  window.camcmmCloudView = {
    views: views,
    ready: function (name) {
      var v = views[name];
      return !!(v && v.spec && v.pendingRev === null && v.shownRev === v.spec.rev && v.lastFull);
    },
    scan: scan,
  };
  if (document.body) start();
  else document.addEventListener("DOMContentLoaded", start);
})();
