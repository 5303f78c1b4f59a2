"""The acceptance-test wizard's page: pictograms (inline SVG drawn here) and the
Vuetify layout around a :class:`camcmm.gui.wizard.WizardPage`.

Three steps in tabs: **1 Setup** (standard, measuring system, MPEs, artefacts from the
catalogue or entered), **2 Positions** (per test a grid of position cards: pictogram,
status, values and verdict, Import / Redo / Show, counters "7 of 10 sphere
positions"), **3 Result** (parameters with value, MPE, U and both verdicts; Report).

Pictograms: the measuring volume as a box in cabinet projection (x to the right, y
away from the operator, z up; origin in the centre, as the standard plugin gives its
positions) with the artefact where the standard wants it — the sphere as a shaded
ball with its shadow and a drop line to the floor (the other positions faint), the
ball bar as a bar between two balls, the flat as a plate with its measured face's
normal, the ball plate as a triangle of balls, a camera position as a camera looking
at the sphere. :func:`pictogram` needs neither trame nor a browser.
"""

from __future__ import annotations

import html as _html
import math
from typing import Any

import numpy as np

# -- pictograms -------------------------------------------------------------------------------
_K, _ANGLE = 0.5, math.radians(30.0)  # cabinet projection: depth halved, receding at 30 deg
_EDGE = "#78909c"
_HIDDEN = "#b0bec5"
_FLOOR = "#eceff1"
_BLUE = "#1565c0"
_SCALE = 100.0  # the longest edge of the volume is drawn 100 units long


def _proj(p: Any) -> tuple[float, float]:
    x, y, z = (float(c) for c in p)
    return x + _K * y * math.cos(_ANGLE), -(z + _K * y * math.sin(_ANGLE))


class _Svg:
    def __init__(self, uid: str):
        self.uid = uid
        self.parts: list[str] = []
        self.xs: list[float] = []
        self.ys: list[float] = []
        self.defs: list[str] = []

    def _pt(self, p: Any) -> tuple[float, float]:
        x, y = _proj(p)
        self.xs.append(x)
        self.ys.append(y)
        return x, y

    def line(self, a: Any, b: Any, color: str = _EDGE, width: float = 1.0, dash: str = "", cap: str = "round") -> None:
        (x1, y1), (x2, y2) = self._pt(a), self._pt(b)
        d = f' stroke-dasharray="{dash}"' if dash else ""
        self.parts.append(f'<line x1="{x1:.1f}" y1="{y1:.1f}" x2="{x2:.1f}" y2="{y2:.1f}" stroke="{color}" '
                          f'stroke-width="{width:.2f}" stroke-linecap="{cap}"{d}/>')

    def poly(self, pts: list[Any], fill: str, stroke: str = "none", width: float = 1.0, opacity: float = 1.0) -> None:
        xy = [self._pt(p) for p in pts]
        s = " ".join(f"{x:.1f},{y:.1f}" for x, y in xy)
        self.parts.append(f'<polygon points="{s}" fill="{fill}" fill-opacity="{opacity:.2f}" stroke="{stroke}" '
                          f'stroke-width="{width:.2f}" stroke-linejoin="round"/>')

    def ball(self, c: Any, r: float, color: str = _BLUE, faint: bool = False) -> None:
        x, y = self._pt(c)
        self.xs += [x - r, x + r]
        self.ys += [y - r, y + r]
        if faint:
            self.parts.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r:.1f}" fill="#cfd8dc" stroke="#b0bec5" '
                              'stroke-width="0.6"/>')
            return
        gid = f"g-{self.uid}"
        if not self.defs:
            self.defs.append(f'<radialGradient id="{gid}" cx="0.35" cy="0.3" r="0.75">'
                             f'<stop offset="0" stop-color="#ffffff"/><stop offset="0.35" stop-color="#64b5f6"/>'
                             f'<stop offset="1" stop-color="{color}"/></radialGradient>')
        self.parts.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r:.1f}" fill="url(#{gid})" stroke="#0d47a1" '
                          'stroke-width="0.8"/>')

    def text(self, p: Any, s: str, size: float = 9.0, color: str = "#78909c", anchor: str = "middle") -> None:
        x, y = self._pt(p)
        self.parts.append(f'<text x="{x:.1f}" y="{y:.1f}" font-size="{size:.1f}" fill="{color}" '
                          f'text-anchor="{anchor}" font-family="sans-serif">{_html.escape(s)}</text>')

    def render(self, title: str, pad: float = 6.0) -> str:
        x0, x1 = min(self.xs) - pad, max(self.xs) + pad
        y0, y1 = min(self.ys) - pad, max(self.ys) + pad
        defs = f"<defs>{''.join(self.defs)}</defs>" if self.defs else ""
        return (f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{x0:.1f} {y0:.1f} {x1 - x0:.1f} {y1 - y0:.1f}" '
                f'width="100%" height="100%" preserveAspectRatio="xMidYMid meet" role="img" '
                f'aria-label="{_html.escape(title)}"><title>{_html.escape(title)}</title>{defs}'
                + "".join(self.parts) + "</svg>")


def _unit(v: Any, default=(1.0, 0.0, 0.0)) -> np.ndarray:
    a = np.asarray(v if v is not None else default, dtype=float)
    n = float(np.linalg.norm(a))
    return a / n if n > 0 else np.asarray(default, dtype=float)


def _box(svg: _Svg, h: np.ndarray, back: bool) -> None:
    """The measuring volume: back=True draws the floor and the hidden edges (before the
    artefact), back=False the visible edges (after it)."""
    hx, hy, hz = h
    c = {(sx, sy, sz): (sx * hx, sy * hy, sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)}
    hidden = (-1, 1, -1)  # back, bottom, left: behind the box in this view
    edges = [(a, b) for a in c for b in c if a < b and sum(x != y for x, y in zip(a, b)) == 1]
    if back:
        svg.poly([c[(-1, -1, -1)], c[(1, -1, -1)], c[(1, 1, -1)], c[(-1, 1, -1)]], _FLOOR)
        for a, b in edges:
            if hidden in (a, b):
                svg.line(c[a], c[b], _HIDDEN, 0.8, "3 2")
    else:
        for a, b in edges:
            if hidden not in (a, b):
                svg.line(c[a], c[b], _EDGE, 1.0)
        svg.text((hx + 6, -hy, -hz), "x", anchor="start")
        svg.text((-hx - 4, -hy, hz + 2), "z", anchor="end")
        svg.text((-hx - 3, hy, -hz - 3), "y", anchor="end")


def _shadow_disc(svg: _Svg, c: np.ndarray, r: float, floor: float) -> None:
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    pts = [(c[0] + r * math.cos(a), c[1] + r * math.sin(a), floor) for a in t]
    svg.poly(pts, "#90a4ae", opacity=0.35)


def _drop(svg: _Svg, c: np.ndarray, floor: float) -> None:
    svg.line(c, (c[0], c[1], floor), "#90a4ae", 0.7, "2 2")


def pictogram(test: str, position: dict[str, Any], volume: Any, artefact: dict[str, Any] | None = None,
              others: list[dict[str, Any]] | None = None, uid: str = "p") -> str:
    """An inline SVG of one position of a test in the measuring volume (mm).

    ``position`` is a position of ``std.requirements()`` (``where`` as fractions of the
    volume, ``direction``, ``normal``, ``rotation``/``tilt``, ``camera``); ``artefact``
    the plan's artefact entry (sizes, drawn to scale but never smaller than visible);
    ``others`` the test's other positions (drawn faint for the sphere)."""
    vol = np.asarray(volume, dtype=float)
    s = _SCALE / float(vol.max())
    h = vol * s / 2
    a = artefact or {}
    floor = -h[2]
    where = np.asarray(position.get("where") or [0, 0, 0], dtype=float) * vol * s
    svg = _Svg(uid)
    title = f"{position.get('label') or position.get('id', '')}: {position.get('hint', '')}".strip(": ")
    _box(svg, h, back=True)
    min_r = 3.0
    cam = position.get("camera") if isinstance(position.get("camera"), dict) else None

    if test == "sphere" and cam is not None:  # part 3: the camera moves around the sphere
        r = max(float(a.get("diameter") or 0.1 * vol.max()) / 2 * s, min_r)
        el = math.radians(float(cam.get("elevation", 45.0)))
        dist = 0.95 * float(np.linalg.norm(h))
        for o in others or []:
            oc = o.get("camera") if isinstance(o.get("camera"), dict) else None
            if oc is None or o.get("id") == position.get("id"):
                continue
            az = math.radians(float(oc.get("azimuth", 0.0)))
            p = where + dist * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
            svg.ball(p, 2.0, faint=True)
        _shadow_disc(svg, where, r, floor)
        _drop(svg, where, floor)
        svg.ball(where, r)
        az = math.radians(float(cam.get("azimuth", 0.0)))
        p = where + dist * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        svg.line(p, where, "#ef6c00", 0.9, "3 2")
        x, y = svg._pt(p)
        svg.xs += [x - 8, x + 8]
        svg.ys += [y - 6, y + 6]
        svg.parts.append(f'<g transform="translate({x:.1f},{y:.1f})"><rect x="-7" y="-5" width="14" height="10" rx="2" '
                         'fill="#ef6c00"/><circle cx="0" cy="0" r="3.2" fill="#fff3e0" stroke="#bf360c" '
                         'stroke-width="0.8"/><rect x="-4" y="-7.5" width="6" height="2.5" fill="#ef6c00"/></g>')
    elif test == "sphere":
        r = max(float(a.get("diameter") or 0.1 * vol.max()) / 2 * s, min_r)
        for o in others or []:
            if o.get("id") == position.get("id"):
                continue
            oc = np.asarray(o.get("where") or [0, 0, 0], dtype=float) * vol * s
            svg.ball(oc, 2.2, faint=True)
        _shadow_disc(svg, where, r, floor)
        _drop(svg, where, floor)
        svg.ball(where, r)
    elif test == "ball_bar":
        d = _unit(position.get("direction"))
        length = float(a.get("length") or 0.5 * vol.max()) * s
        r = max(float(a.get("sphere_diameter") or 0.1 * vol.max()) / 2 * s, min_r)
        ends = [where - d * length / 2, where + d * length / 2]
        svg.line((ends[0][0], ends[0][1], floor), (ends[1][0], ends[1][1], floor), "#b0bec5", 2.5)
        for e in ends:
            _shadow_disc(svg, e, r, floor)
            _drop(svg, e, floor)
        ends.sort(key=lambda e: -e[1])  # far ball first
        svg.line(ends[0], ends[1], "#455a64", 2.6)
        for e in ends:
            svg.ball(e, r)
    elif test == "flat":
        u = _unit(position.get("direction"))
        n = _unit(position.get("normal"), (0.0, 0.0, 1.0))
        w = np.cross(n, u)
        w = w / (np.linalg.norm(w) or 1.0)
        length = float(a.get("length") or 0.8 * vol.max()) * s
        width = float(a.get("width") or 0.3 * vol.max()) * s
        corners = [where + su * u * length / 2 + sw * w * width / 2 for su, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        svg.poly([(c[0], c[1], floor) for c in corners], "#90a4ae", opacity=0.35)
        svg.poly(corners, "#42a5f5", "#0d47a1", 1.0, 0.55)
        tip = where + n * 0.28 * _SCALE
        svg.line(where, tip, "#c62828", 1.4)
        x, y = svg._pt(tip)
        svg.parts.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="2.2" fill="#c62828"/>')
    elif test == "ball_plate":
        lengths = [float(x) for x in (a.get("lengths") or [6.0, 8.0, 10.0])][:3]
        l1, l2, l3 = lengths
        x3 = (l1**2 + l3**2 - l2**2) / (2 * l1)
        y3 = math.sqrt(max(l3**2 - x3**2, 0.0))
        tri = np.array([[0.0, 0.0, 0.0], [l1, 0.0, 0.0], [x3, y3, 0.0]])
        tri -= tri.mean(axis=0)
        rot = math.radians(float(position.get("rotation") or 0.0))
        tilt = math.radians(float(position.get("tilt") or 0.0))
        rz = np.array([[math.cos(rot), -math.sin(rot), 0], [math.sin(rot), math.cos(rot), 0], [0, 0, 1]])
        rx = np.array([[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]])
        pts = (rx @ rz @ tri.T).T * s + where
        r = max(float(a.get("sphere_diameter") or 0.1 * vol.max()) / 2 * s, min_r)
        plate = pts + (pts - pts.mean(axis=0)) * 0.45
        svg.poly([(p[0], p[1], floor) for p in plate], "#90a4ae", opacity=0.3)
        svg.poly(list(plate), "#cfd8dc", "#78909c", 0.9, 0.9)
        svg.line(pts[0], pts[1], "#ef6c00", 1.0)  # edge 1 (L1): the arrow the rotation is measured from
        for p in sorted(pts, key=lambda p: -p[1]):
            svg.ball(p, r)
    else:  # a test this page does not know: the volume and a marker at the position
        svg.ball(where, min_r)
    _box(svg, h, back=False)
    return svg.render(title)


def pictograms(requirements: list[dict[str, Any]], plan: dict[str, Any]) -> dict[str, str]:
    """``{"test/position": svg}`` for every position of a test's requirements."""
    vol = (plan.get("system") or {}).get("measuring_volume") or [100, 100, 100]
    arts = plan.get("artefacts") or {}
    out = {}
    for r in requirements:
        for p in r["positions"]:
            uid = f"{r['test']}-{p['id']}".replace("_", "-")
            out[f"{r['test']}/{p['id']}"] = pictogram(r["test"], p, vol, arts.get(r["test"]), r["positions"], uid)
    return out


# -- the layout ---------------------------------------------------------------------------------
VERDICT_COLORS = ("{pass: 'success', fail: 'error', inconclusive: 'warning', incomplete: 'grey'}")


def _tid(name: str) -> list[str]:
    return [f'data-testid="{name}"']


def _dyn_tid(expr: str) -> list[str]:
    return [f':data-testid="{expr}"']


def _verdict_color(expr: str) -> tuple[str]:
    return (f"({VERDICT_COLORS})[{expr}] || 'grey'",)


def _set_form(path: str) -> str:
    """A JS statement that replaces ``wz_form`` by a copy with ``$event`` at ``path``.

    trame's template state hands out plain objects: writing into a nested property
    (``v-model="wz_form.x"``) would neither re-render nor reach the server, and a field
    would fall back to the old value on blur. Assigning a new top-level object does
    both. ``path`` items are JS expressions for the keys (``"'mpe'"``, ``"f.key"``)."""
    def build(obj: str, keys: list[str]) -> str:
        if not keys:
            return "$event"
        k = keys[0]
        return f"Object.assign({{}}, {obj}, {{[{k}]: {build(f'({obj} || {{}})[{k}]', keys[1:])}}})"

    return "wz_form = " + build("wz_form", [p.strip() for p in path.split("|")])


def build_panel(page: Any, accept: str = "") -> None:
    """The wizard's panel inside the current layout context (shown on the page
    ``page === 'acceptance'``); wires the widgets to ``page`` (a WizardPage)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    # -- handlers (thin: the logic is in the WizardPage) --------------------------------------
    def on_standard(std, form):
        page.choose_standard(std, form)

    def on_pick(test, choice, form):
        page.pick_artefact(test, choice, form)

    def on_start(form):
        page.start(form)

    async def on_upload(test, position, files):
        await page.upload_async(test, position, files)

    def on_redo(test, position):
        page.redo(test, position)

    def on_show(test, position):
        page.show(test, position)

    async def on_report():
        await page.report_async()

    with html.Div(v_if="page === 'acceptance'", classes="pa-3",
                  style="flex: 0 0 55%; max-width: 55%; height: calc(100vh - 48px - 24px); overflow-y: auto; "
                        "border-right: 1px solid rgba(0,0,0,0.12);",
                  raw_attrs=_tid("wizard")):
        v.VAlert(v_if="wz_error", text=("wz_error",), type="error", density="compact", classes="mb-2",
                 raw_attrs=_tid("wz-error"))
        with v.VTabs(v_model=("wz_step", "setup"), density="compact", color="primary", classes="mb-2",
                     raw_attrs=_tid("wz-steps")):
            v.VTab("1 · Setup", value="setup", raw_attrs=_tid("wz-tab-setup"))
            v.VTab("2 · Positions", value="positions", disabled=("!wz_active",), raw_attrs=_tid("wz-tab-positions"))
            v.VTab("3 · Result", value="result", disabled=("!wz_active",), raw_attrs=_tid("wz-tab-result"))

        # -- 1 setup ------------------------------------------------------------------------
        with html.Div(v_if="wz_step === 'setup'", raw_attrs=_tid("wz-setup")):
            with v.VAlert(v_if="wz_active && wz_locked", type="info", density="compact", variant="tonal",
                          classes="mb-2"):
                html.Span("A test is running in this project: {{ wz_progress_text }}. ")
                v.VBtn("Set up a new test", size="small", variant="text", color="primary", click="wz_locked = false",
                       raw_attrs=_tid("wz-unlock"))
            v.VAlert(v_if="!wz_standards.length", type="warning", density="compact", classes="mb-2",
                     text="No standard plugin is installed (kind 'standard'); `camcmm plugins` lists what is there.")
            v.VAlert(v_if="wz_setup_error", text=("wz_setup_error",), type="error", density="compact",
                     classes="mb-2", raw_attrs=_tid("wz-setup-error"))
            with v.VRow(dense=True):
                with v.VCol(cols=12, md=7):
                    v.VSelect(model_value=("wz_form.standard",), items=("wz_standards",), label="Standard",
                              density="compact", variant="outlined", disabled=("wz_locked",), hide_details=True,
                              update_modelValue=(on_standard, "[$event, wz_form]"), raw_attrs=_tid("wz-standard"))
                with v.VCol(cols=12, md=5):
                    v.VTextField(model_value=("wz_form.system_name",), update_modelValue=_set_form("'system_name'"),
                                 label="Measuring system", density="compact",
                                 variant="outlined", disabled=("wz_locked",), hide_details=True,
                                 raw_attrs=_tid("wz-system-name"))
            html.Div("Measuring volume", classes="text-caption mt-3 mb-2")
            with v.VRow(dense=True):
                for i, axis in enumerate("xyz"):
                    with v.VCol(cols=4):
                        v.VTextField(model_value=(f"wz_form.volume[{i}]",),
                                     update_modelValue=_set_form(f"'volume' | {i}").replace(
                                         "Object.assign({}, (wz_form || {})['volume']",
                                         "Object.assign([], (wz_form || {})['volume']"),
                                     label=axis, suffix="mm",
                                     density="compact", variant="outlined", disabled=("wz_locked",),
                                     hide_details=True, raw_attrs=_tid(f"wz-volume-{axis}"))
            html.Div("Maximum permissible errors (from the system's specification)", classes="text-caption mt-3 mb-2")
            with v.VRow(dense=True):
                with v.VCol(v_for="f in wz_mpe_fields", key="f.key", cols=6, md=3):
                    v.VTextField(model_value=("wz_form.mpe[f.key]",), update_modelValue=_set_form("'mpe' | f.key"),
                                 label=("f.label",), suffix="mm",
                                 density="compact", variant="outlined", disabled=("wz_locked",), hide_details=True,
                                 raw_attrs=_dyn_tid("'wz-mpe-' + f.key"))
            html.Div("Artefacts", classes="text-caption mt-3 mb-2")
            with v.VCard(v_for="t in wz_form_tests", key="t.test", variant="outlined", classes="mb-2",
                         raw_attrs=_dyn_tid("'wz-artefact-' + t.test")):
                with v.VCardText(classes="pb-1"):
                    with html.Div(classes="d-flex align-center ga-2 mb-2"):
                        html.Span("{{ t.label }}", classes="text-subtitle-2")
                        v.VChip("{{ t.min_count }} positions{{ t.repeats > 1 ? ' × ' + t.repeats + ' repeats' : '' }}",
                                size="x-small", variant="tonal")
                        v.VCheckbox(v_if="!t.required", model_value=("wz_form.include",),
                                    update_modelValue=_set_form("'include'"), value=("t.test",), multiple=True,
                                    label="include (optional)", density="compact", hide_details=True,
                                    disabled=("wz_locked",))
                    with html.Div(v_if="t.required || (wz_form.include || []).includes(t.test)"):
                        v.VSelect(model_value=("(wz_form.artefacts[t.test] || {})._choice",), items=("t.options",),
                                  label="From the catalogue", density="compact", variant="outlined",
                                  disabled=("wz_locked",), hide_details=True, classes="mb-2",
                                  update_modelValue=(on_pick, "[t.test, $event, wz_form]"),
                                  raw_attrs=_dyn_tid("'wz-catalogue-' + t.test"))
                        with v.VRow(dense=True):
                            with v.VCol(v_for="f in t.fields", key="f.key", cols=6, md=3):
                                v.VTextField(model_value=("(wz_form.artefacts[t.test] || {})[f.key]",),
                                             update_modelValue=_set_form("'artefacts' | t.test | f.key"),
                                             label=("f.label",),
                                             suffix=("f.unit",), density="compact", variant="outlined",
                                             disabled=("wz_locked",), hide_details=True,
                                             raw_attrs=_dyn_tid("'wz-field-' + t.test + '-' + f.key"))
            with v.VExpansionPanels(classes="mb-2", raw_attrs=_tid("wz-advanced")):
                with v.VExpansionPanel(title="More plan options (YAML, docs/standards.md)"):
                    with v.VExpansionPanelText():
                        v.VTextarea(model_value=("wz_form.options",), update_modelValue=_set_form("'options'"),
                                    rows=3, auto_grow=True, density="compact", variant="outlined",
                                    disabled=("wz_locked",), hide_details=True,
                                    placeholder="outliers: vdi2634\nscaling: {sphere: radii, ball_plate: lengths}\n"
                                                "repeats: 3\nunit: mm", raw_attrs=_tid("wz-options"))
            with html.Div(classes="d-flex ga-2 mt-2"):
                v.VBtn("Start the test", color="primary", prepend_icon="mdi-play", disabled=("wz_locked",),
                       click=(on_start, "[wz_form]"), raw_attrs=_tid("wz-start"))
                v.VBtn("Go to the positions", v_if="wz_active", variant="text", click="wz_step = 'positions'",
                       raw_attrs=_tid("wz-goto-positions"))

        # -- 2 positions --------------------------------------------------------------------
        with html.Div(v_if="wz_step === 'positions' && wz_active", raw_attrs=_tid("wz-positions")):
            html.Div("{{ wz_title }}", classes="text-subtitle-2 mb-1")
            with html.Div(classes="d-flex flex-wrap ga-2 mb-2"):
                v.VChip("{{ p.text }}", v_for="p in wz_progress", key="p.test", size="small",
                        color=("p.complete ? 'success' : 'primary'",), variant=("p.complete ? 'flat' : 'tonal'",),
                        prepend_icon=("p.complete ? 'mdi-check-circle' : 'mdi-progress-clock'",),
                        raw_attrs=_dyn_tid("'wz-counter-' + p.test"))
                v.VSpacer()
                v.VBtn("Result", v_if="wz_complete", size="small", color="success", append_icon="mdi-arrow-right",
                       click="wz_step = 'result'", raw_attrs=_tid("wz-goto-result"))
            with v.VCard(v_if="wz_detail", variant="tonal", color="primary", classes="mb-2",
                         raw_attrs=_tid("wz-detail")):
                with v.VCardText(classes="py-2"):
                    html.Div("Last shown: {{ wz_detail.title }} ({{ wz_detail.file }}) — deviation colour map "
                             "in the 3D view", classes="text-subtitle-2")
                    with html.Div(classes="d-flex flex-wrap ga-1 mt-1"):
                        v.VChip("{{ r.name }}: {{ r.value }}", v_for="r in wz_detail.rows", key="r.name",
                                size="x-small", variant="outlined")
                    html.Div("{{ w }}", v_for="(w, i) in wz_detail.warnings", key="i",
                             classes="text-caption text-warning")
            with html.Div(v_for="b in wz_blocks", key="b.test", classes="mb-3",
                          raw_attrs=_dyn_tid("'wz-block-' + b.test")):
                with html.Div(classes="d-flex align-center ga-2 mb-1"):
                    html.Span("{{ b.label }}", classes="text-subtitle-1")
                    v.VChip("{{ b.progress.done }} of {{ b.progress.total }}", size="small",
                            color=("b.progress.complete ? 'success' : 'primary'",), variant="tonal")
                v.VProgressLinear(model_value=("100 * b.progress.done / Math.max(b.progress.total, 1)",),
                                  color=("b.progress.complete ? 'success' : 'primary'",), height=4, rounded=True,
                                  classes="mb-2")
                with html.Div(style="display: grid; grid-template-columns: repeat(auto-fill, minmax(185px, 1fr)); "
                                    "gap: 8px;"):
                    _card(v, html, accept, on_upload, on_redo, on_show)

        # -- 3 result -------------------------------------------------------------------------
        with html.Div(v_if="wz_step === 'result' && wz_active", raw_attrs=_tid("wz-result")):
            with html.Div(classes="d-flex align-center ga-3 mb-2"):
                html.Span("Verdict", classes="text-h6")
                v.VChip("{{ (wz_verdict || 'incomplete').toUpperCase() }}", size="large", variant="flat",
                        color=_verdict_color("wz_verdict"), raw_attrs=_tid("wz-verdict"))
                html.Span("guarded (ISO 14253-1):", classes="text-caption")
                v.VChip("{{ (wz_verdict_guarded || 'incomplete').toUpperCase() }}", size="small", variant="tonal",
                        color=_verdict_color("wz_verdict_guarded"), raw_attrs=_tid("wz-verdict-guarded"))
            html.Div("{{ wz_progress_text }}", classes="text-caption mb-2")
            with v.VTable(density="compact", raw_attrs=_tid("wz-parameters")):
                with html.Thead():
                    with html.Tr():
                        for h in ("Parameter", "Value", "MPE", "U (k=2)", "Simple", "Guarded", "n"):
                            html.Th(h)
                with html.Tbody():
                    with html.Tr(v_for="p in wz_parameters", key="p.key", raw_attrs=_dyn_tid("'wz-param-' + p.key")):
                        with html.Td(title=("p.note",)):
                            html.Div("{{ p.name }}")
                            html.Div("{{ p.note }}", v_if="p.note", classes="text-caption text-medium-emphasis")
                        html.Td("{{ p.value }}", classes="text-right text-no-wrap")
                        html.Td("{{ p.mpe }}", classes="text-right text-no-wrap")
                        html.Td("{{ p.U }}", classes="text-right text-no-wrap")
                        with html.Td():
                            v.VChip("{{ p.verdict }}", size="x-small", variant="flat", color=_verdict_color("p.verdict"))
                        with html.Td():
                            v.VChip("{{ p.verdict_guarded }}", size="x-small", variant="tonal",
                                    color=_verdict_color("p.verdict_guarded"))
                        html.Td("{{ p.n }}")
            with v.VExpansionPanels(v_if="wz_summary_warnings.length", classes="my-2"):
                with v.VExpansionPanel(title=("'Warnings (' + wz_summary_warnings.length + ')'",)):
                    with v.VExpansionPanelText():
                        html.Div("{{ w }}", v_for="(w, i) in wz_summary_warnings", key="i", classes="text-caption")
            with html.Div(classes="d-flex align-center flex-wrap ga-2 mt-3"):
                v.VBtn("Report", color="primary", prepend_icon="mdi-file-document-outline",
                       loading=("wz_reporting",), disabled=("wz_reporting",), click=on_report,
                       raw_attrs=_tid("wz-report"))
                html.A("{{ l.title }}", v_for="l in wz_report_links", key="l.kind", href=("l.url",),
                       target="_blank", download=("l.kind === 'html' ? undefined : l.name",),
                       classes="text-body-2 mx-2", raw_attrs=_dyn_tid("'wz-report-' + l.kind"))
            html.Div("The report is stored in the project with the summary result; Report again after a redo.",
                     classes="text-caption mt-1")


def _card(v: Any, html: Any, accept: str, on_upload, on_redo, on_show) -> None:
    with v.VCard(v_for="c in b.cards", key="c.key", variant="outlined",
                 color=("c.status === 'done' ? (c.verdict === 'fail' ? 'error' : 'success') : "
                        "(c.status === 'error' ? 'error' : undefined)",),
                 raw_attrs=_dyn_tid("'card-' + c.id") + [':data-status="c.status"']):
        with html.Div(classes="d-flex align-center px-2 pt-1"):
            html.Span("{{ c.label }}", classes="text-body-2 font-weight-medium text-high-emphasis")
            v.VSpacer()
            v.VChip("{{ c.verdict }}", v_if="c.status === 'done'", size="x-small", variant="flat",
                    color=_verdict_color("c.verdict"), raw_attrs=_tid("card-verdict"))
            v.VChip("to do", v_if="c.status === 'pending'", size="x-small", variant="tonal",
                    raw_attrs=_tid("card-pending"))
            v.VChip("error", v_if="c.status === 'error'", size="x-small", variant="flat", color="error")
            v.VChip("{{ c.repeats.filter(r => r.status === 'done').length }}/{{ c.n_repeats }}",
                    v_if="c.status === 'partial'", size="x-small", variant="tonal", color="primary")
        html.Div(v_html="wz_svgs[c.key]", style="height: 104px;", classes="px-2 text-center", title=("c.hint",))
        html.Div("{{ c.hint }}", classes="text-caption text-medium-emphasis px-2",
                 style="line-height: 1.2; min-height: 2.4em;")
        v.VProgressLinear(v_if="wz_busy[c.key]", indeterminate=True, color="primary", classes="mt-1")
        with html.Div(v_if="c.status === 'done' || c.status === 'partial'", classes="px-2 pt-1",
                      raw_attrs=_tid("card-values")):
            with html.Template(v_for="r in c.repeats", key="r.repeat"):
                with html.Div(v_if="r.status === 'done'", classes="d-flex flex-wrap ga-1 align-center"):
                    html.Span("#{{ r.repeat }}", v_if="c.n_repeats > 1", classes="text-caption")
                    v.VChip("{{ x.symbol }} {{ x.text }}", v_for="x in r.values", key="x.param", size="x-small",
                            variant="tonal", color=_verdict_color("x.verdict"))
                html.Div("{{ r.fit }}", v_if="r.status === 'done'", classes="text-caption text-medium-emphasis")
        v.VAlert(v_if="c.error", text=("c.error",), type="error", density="compact", variant="tonal",
                 classes="mx-2 mt-1 text-caption", raw_attrs=_tid("card-error"))
        with html.Div(v_if="(c.status !== 'done' || wz_redo === c.key) && !wz_busy[c.key]", classes="px-2 pt-2"):
            v.VFileInput(label=("c.status === 'done' ? 'Redo: choose a file' : 'Import measurement'",),
                         accept=accept, density="compact", variant="outlined", hide_details=True,
                         prepend_icon="", prepend_inner_icon="mdi-file-import",
                         update_modelValue=(on_upload, "[c.test, c.id, $event]"),
                         raw_attrs=_tid("card-file") + [':key="c.key + \'-\' + (c.repeats.map(r => r.measurement).join())'
                                                        ' + \'-\' + c.error"'])
        with v.VCardActions(v_if="c.status === 'done' || c.status === 'partial'", classes="py-1"):
            v.VBtn("Show", size="small", variant="text", prepend_icon="mdi-palette",
                   click=(on_show, "[c.test, c.id]"), raw_attrs=_tid("card-show"))
            v.VBtn("Redo", size="small", variant="text", prepend_icon="mdi-restore", v_if="wz_redo !== c.key",
                   click=(on_redo, "[c.test, c.id]"), raw_attrs=_tid("card-redo"))
            v.VBtn("Cancel", size="small", variant="text", v_if="wz_redo === c.key", click="wz_redo = null")


def page_switch(v: Any) -> None:
    """The toolbar's page toggle: Inspect | Acceptance test (the drawer belongs to Inspect)."""
    with v.VBtnToggle(v_model=("page", "inspect"), mandatory=True, density="compact", variant="outlined",
                      divided=True, color="primary", classes="ml-4",
                      update_modelValue="main_drawer = ($event === 'inspect')", raw_attrs=_tid("page-switch")):
        v.VBtn("Inspect", value="inspect", prepend_icon="mdi-cube-scan", raw_attrs=_tid("page-inspect"))
        v.VBtn("Acceptance test", value="acceptance", prepend_icon="mdi-clipboard-check-outline",
               raw_attrs=_tid("page-acceptance"))
