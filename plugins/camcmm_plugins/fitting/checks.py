"""Does the fitted element describe the points? Warnings for a fit that is not silent.

A least-squares fit always returns *an* element: a cylinder through a sphere, a line
through a ball of points. Four checks, each on the points the fit used, each a
one-line warning (``FitResult.warnings``, the JSON ``warnings`` of ``camcmm fit`` and of
the fit plugins):

* **Form against noise and size.** The form rms is compared with the noise the points
  show around the element *locally*: each point's residual vector (point minus its
  foot on the element) against the mean of its neighbours' (neighbours found among the
  feet, so the noise does not choose them). With the right element the residuals are
  the noise and the two agree (ratio ~1 whatever the sampling density); with the wrong
  one the residuals are a smooth misfit that neighbours share, and the ratio is large.
  A real part's form deviation is smooth too, so the warning also needs the form rms to
  be a sizeable fraction of the points' extent (:data:`FORM_FRACTION`): form errors of
  measured parts are far below it, a wrong element's misfit is far above.
* **Ill-determined direction.** A line's direction or a plane's normal comes from the
  points' principal axes: when the two largest (line) or two smallest (plane) singular
  values of the centred points are comparable, the direction is a toss-up between
  them, however small its standard uncertainty looks with many points.
* **No redundancy.** As few points as the element needs (two for a line, three for a
  plane or circle, four for a sphere, five for a cylinder, six for a cone, seven for a
  torus): the element passes through
  them, the form is zero and the uncertainties are undefined whatever the part is like.
* **Large uncertainty.** The standard uncertainty (fit covariance) of a radius (a
  torus' major and minor radii too) relative to the radius, or of a direction or a
  cone's apex angle in degrees. A torus on too short an arc around its axis to fix the
  major radius shows here, with the arc the points cover.
* **Degenerate cone or torus.** A cone whose apex angle is under 2° is nearly a
  cylinder (its apex lies far outside the points and is ill-determined, however exact
  the points), over 170° nearly a plane; points beyond the apex lie on the other nappe,
  which the cone's distance does not describe. A torus whose minor radius reaches the
  major one is self-intersecting (a spindle torus).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._geometry import N_MIN, dot

#: Form rms above this many times the local noise estimate counts as systematic: the
#: estimate scatters by ~10 % for a few hundred points, and the right element gives 1.
NOISE_FACTOR = 3.0
#: ... and only when it is also above this fraction of the points' RMS spread about their
#: centroid: form deviations of real parts are well below 1 % of their size (0.1 mm on a
#: 10 mm sphere is a gross one); a wrong element leaves 5-100 %.
FORM_FRACTION = 0.01
#: A line whose points spread across more than this fraction of their spread along it
#: (second / first singular value), or a plane whose points are thicker than this
#: fraction of their narrower width (third / second): the direction is ill-determined.
SPREAD_RATIO = 0.3
#: Form rms above this fraction of the points' RMS spread is a warning whatever the noise:
#: points scattered that far about the element are not described by it (a circle through
#: a flat patch, a cylinder through a sparse sphere).
GROSS_FRACTION = 0.1
#: Standard uncertainty of a radius above this fraction of the radius.
MAX_REL_U_RADIUS = 0.05
#: Standard uncertainty of a direction (line, axis, normal) above this angle, degrees.
MAX_U_DIRECTION_DEG = 1.0
#: A cone's full apex angle (degrees) below which it is nearly a cylinder, above which
#: nearly a plane: the apex is extrapolated from ~1/tan(angle/2) times the points' extent
#: (57 times at 2°), the axis tilt of a 170° cone moves the points by ~tan(5°) = 0.09 of it.
CONE_CYLINDER_DEG = 2.0
CONE_PLANE_DEG = 170.0
#: Neighbours per point for the local noise estimate, how many points to estimate it at,
#: and how many (strided) points to look for neighbours among.
K_NEIGHBOURS = 8
NOISE_SAMPLE = 4000
TREE_SAMPLE = 50_000


def residual_vectors(element: str, params: dict[str, Any], x: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(N, d) vectors from each point's foot on the element to the point, mm; ``r`` (N,)
    the signed residuals (their lengths, for the elements with one residual direction)."""
    if element == "line":
        p, a = params["point"], params["direction"]
        y = x - p
        return y - np.outer(y @ a, a)
    if element == "plane":
        return np.outer(r, params["normal"])
    if element == "sphere" or (element == "circle" and x.shape[1] == 2):
        y = x - params["center"]
        return r[:, None] * y / np.maximum(np.linalg.norm(y, axis=1), 1e-300)[:, None]
    if element == "circle":
        c, n, rad = params["center"], params["normal"], params["radius"]
        y = x - c
        q = y - np.outer(y @ n, n)
        u = q / np.maximum(np.linalg.norm(q, axis=1), 1e-300)[:, None]
        return y - rad * u
    if element == "cylinder":
        p, a = params["point"], params["axis"]
        y = x - p
        q = y - np.outer(y @ a, a)
        return r[:, None] * q / np.maximum(np.linalg.norm(q, axis=1), 1e-300)[:, None]
    if element in ("cone", "torus"):
        # along the surface normal in the point's meridian half-plane (w radial, a axial)
        a = params["axis"]
        y = x - (params["apex"] if element == "cone" else params["center"])
        z = y @ a
        q = y - np.outer(z, a)
        rho = np.linalg.norm(q, axis=1)
        w = q / np.maximum(rho, 1e-300)[:, None]
        if element == "cone":
            psi = np.radians(params["angle"] / 2)
            nrm = np.cos(psi) * w - np.sin(psi) * a
        else:
            er, ez = rho - params["major_radius"], z
            h = np.maximum(np.hypot(er, ez), 1e-300)
            nrm = (er / h)[:, None] * w + (ez / h)[:, None] * a
        return r[:, None] * nrm
    raise ValueError(element)


def local_noise(feet: np.ndarray, v: np.ndarray, m: int, k: int = K_NEIGHBOURS) -> float:
    """RMS noise (mm, as a distance) from the differences between each point's residual
    vector ``v`` (N, d) and the mean of its k nearest neighbours' (neighbours among the
    ``feet``). For independent Gaussian noise with ``m`` components per residual (1 on a
    surface or a curve in the plane, 2 on a curve in space), |v_i - mean_k v_j|² is
    (1 + 1/k) σ² times a chi-square with m degrees of freedom, σ² the variance per
    component; the median is used, scaled by the chi-square median, so that the few
    points where a wrong element's misfit changes steeply do not pass for noise."""
    from scipy.spatial import cKDTree

    qstep = max(1, len(feet) // NOISE_SAMPLE)
    q = np.arange(0, len(feet), qstep)
    _, idx = cKDTree(feet).query(feet[q], k=k + 1)
    nb = v[idx[:, 1:]].mean(axis=1)
    d2 = np.sum((v[q] - nb) ** 2, axis=1)
    return float(np.sqrt(m * np.median(d2) / CHI2_MEDIAN[m] / (1.0 + 1.0 / k)))


#: Medians of the chi-square distribution with 1 and 2 degrees of freedom.
CHI2_MEDIAN = {1: 0.454936423119572, 2: 1.386294361119891}


def _fmt(v: float) -> str:
    return f"{v:.3g}"


def fit_warnings(
    element: str,
    params: dict[str, Any],
    std: dict[str, Any],
    x: np.ndarray,
    r: np.ndarray,
    method: str = "ls",
    axes_rms: np.ndarray | None = None,
) -> list[str]:
    """Warnings for the element ``params`` fitted to the points ``x`` (N, d) mm it used,
    with residuals ``r`` (N,) mm (distances from the element, signed or not) and standard
    uncertainties ``std`` (see the module docstring). Empty when the element describes
    the points. ``axes_rms``: the points' RMS spread along their principal axes (mm,
    largest first) when the caller has it (computed here otherwise)."""
    out: list[str] = []
    n, d = x.shape
    if n <= N_MIN[element]:
        # the element (generically) passes through that few points: its zero form and
        # undefined uncertainties would read as a perfect part
        out.append(
            f"{element} fit: only {n} points, the fewest a {element} needs: no redundancy, so the form "
            f"and the uncertainties say nothing about the part; measure more points"
        )
    if n < 3:
        return out
    if axes_rms is None:
        xc = x - x.mean(axis=0)
        # RMS spread along the principal axes (mm), largest first; only ratios of them are
        # used, so the 3x3 scatter matrix is accurate enough
        sv = np.sqrt(np.clip(np.linalg.eigvalsh(xc.T @ xc / n), 0.0, None))[::-1]
    else:
        sv = np.asarray(axes_rms, dtype=float)
    spread = float(np.sqrt(np.sum(sv**2)))
    if not spread > 0:
        return out
    if element == "line" and sv[1] > SPREAD_RATIO * sv[0]:
        out.append(
            f"line fit: the points spread {_fmt(sv[1])} mm across against {_fmt(sv[0])} mm along the "
            f"line (RMS): the direction is ill-determined; the points do not look like a line"
        )
    if element == "plane" and sv[2] > SPREAD_RATIO * sv[1]:
        out.append(
            f"plane fit: the points are {_fmt(sv[2])} mm thick against {_fmt(sv[1])} mm wide (RMS): the "
            f"normal is ill-determined; the points do not look like a plane"
        )
    rms = float(np.sqrt(dot(r, r) / len(r)))
    if rms > FORM_FRACTION * spread:
        ratio = None
        if n > 2 * K_NEIGHBOURS:
            step = max(1, n // TREE_SAMPLE)
            xs, rs = x[::step], r[::step]
            v = residual_vectors(element, params, xs, rs)
            m = 2 if element in ("line", "circle") and d == 3 else 1
            noise = local_noise(xs - v, v, m)
            ratio = rms / noise if noise > 0 else np.inf
        systematic = ratio is not None and ratio > NOISE_FACTOR
        if systematic or rms > GROSS_FRACTION * spread:
            head = f"{element} fit: form rms {_fmt(rms)} mm is {_fmt(100 * rms / spread)} % of the points' extent"
            if systematic and ratio is not None:
                out.append(
                    f"{head} and {_fmt(ratio)} times the point-to-point noise ({_fmt(noise)} mm): the "
                    f"residuals are systematic; the points may not be a {element}"
                )
            else:
                out.append(
                    f"{head}: the {element} describes the points poorly (the wrong element, or noise "
                    f"as large as the part)"
                )
    out += _revolution_warnings(element, params, x)
    if method == "ls":
        for key in ("radius", "major_radius", "minor_radius"):
            u_r = std.get(key)
            rad = params.get(key)
            if u_r is not None and rad and np.isfinite(u_r) and u_r > MAX_REL_U_RADIUS * abs(rad):
                name = key.replace("_", " ")
                arc = ""
                if element == "torus" and key == "major_radius":
                    arc = f"; the points cover {_fmt(_arc_deg(x, params['center'], params['axis']))}° around the axis"
                out.append(
                    f"{element} fit: the {name} {_fmt(rad)} mm is ill-determined (standard uncertainty "
                    f"{_fmt(u_r)} mm, {_fmt(100 * u_r / abs(rad))} %{arc})"
                )
        u_a = std.get("angle")
        if element == "cone" and u_a is not None and np.isfinite(u_a) and u_a > MAX_U_DIRECTION_DEG:
            out.append(f"cone fit: the apex angle is ill-determined (standard uncertainty {_fmt(u_a)}°)")
        for key in ("direction", "axis", "normal"):
            u = std.get(key)
            if u is None:
                continue
            u = float(np.linalg.norm(np.asarray(u, dtype=float)))
            if np.isfinite(u) and np.degrees(u) > MAX_U_DIRECTION_DEG:
                out.append(f"{element} fit: the {key} is ill-determined (standard uncertainty {_fmt(np.degrees(u))}°)")
    return out


def _arc_deg(x: np.ndarray, centre: np.ndarray, axis: np.ndarray) -> float:
    """Degrees of arc around ``axis`` through ``centre`` that points (N, 3) cover: 360
    minus the widest empty gap between their azimuths."""
    b1 = np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))])
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(axis, b1)
    y = x - centre
    az = np.sort(np.arctan2(y @ b2, y @ b1))
    gaps = np.diff(np.concatenate([az, [az[0] + 2 * np.pi]]))
    return float(np.degrees(2 * np.pi - gaps.max()))


def _revolution_warnings(element: str, params: dict[str, Any], x: np.ndarray) -> list[str]:
    """The degenerate cones and tori of the module docstring."""
    out: list[str] = []
    if element == "cone":
        angle = params["angle"]
        if angle < CONE_CYLINDER_DEG:
            dist = float(np.linalg.norm(x.mean(axis=0) - params["apex"]))
            out.append(
                f"cone fit: the apex angle {_fmt(angle)}° is nearly 0: the points lie nearly on a cylinder and the "
                f"apex, {_fmt(dist)} mm away from them, is ill-determined; fit a cylinder"
            )
        elif angle > CONE_PLANE_DEG:
            out.append(
                f"cone fit: the apex angle {_fmt(angle)}° is nearly 180°: the points lie nearly on a plane and the "
                f"axis and apex are ill-determined; fit a plane"
            )
        below = int(np.count_nonzero((x - params["apex"]) @ params["axis"] < 0))
        if below:
            out.append(
                f"cone fit: {below} points lie beyond the apex, on the other nappe, which the cone's distance "
                f"does not describe; fit each side separately"
            )
    if element == "torus" and params["minor_radius"] >= params["major_radius"]:
        out.append(
            f"torus fit: the minor radius {_fmt(params['minor_radius'])} mm reaches the major radius "
            f"{_fmt(params['major_radius'])} mm: a self-intersecting (spindle) torus; the points may not be a torus"
        )
    return out


#: Sphere extraction with a nominal radius (``extract_sphere``, ``fit sphere --extract``,
#: ``segment.sphere``): the sphere found must have a radius within this fraction of the
#: nominal. The nominal radius of a reference ball is known to far better than 1 %, the
#: refinement lets the radius float, and even an uncorrected fringe scanner lands within
#: 2 % (50.7 mm on the 50 mm ball of test_fringe_kimthyung); what is 20 % off is another
#: object (the mount, a ball of another size) or the whole cloud (a wrong nominal or a
#: wrong unit: factors of 25.4 or 1000). The same fraction drops candidates in
#: ``segment_spheres`` (its ``radius_tolerance``).
EXTRACT_RADIUS_TOLERANCE = 0.2
#: ... found on at least this many points (as ``segment_spheres``' ``min_points``): fewer
#: cannot show that they lie on a sphere rather than on whatever else passes there.
EXTRACT_MIN_POINTS = 30


def nominal_sphere_mismatch(
    radius: float,
    u_radius: float,
    n_points: int,
    nominal: float,
    tolerance: float = EXTRACT_RADIUS_TOLERANCE,
    min_points: int = EXTRACT_MIN_POINTS,
) -> str | None:
    """Why a sphere extracted with the ``nominal`` radius (mm) is not the sphere asked for,
    or None when it is: its least-squares ``radius`` (mm, standard uncertainty
    ``u_radius`` mm) on ``n_points`` points. Accepted when the radius is within
    ``tolerance`` × nominal of the nominal, on at least ``min_points`` points, with
    3 u(r) within that tolerance too: a radius less certain than that could be the
    nominal by chance (a small noisy patch), so the comparison would say nothing —
    widening the tolerance by 3 u instead would accept exactly those patches."""
    band = tolerance * nominal
    if n_points < min_points:
        return f"only {n_points} points on it (at least {min_points} needed)"
    if not np.isfinite(radius) or abs(radius - nominal) > band:
        return f"its radius is {_fmt(radius)} mm, not within ±{_fmt(100 * tolerance)} % of {_fmt(nominal)} mm"
    if not np.isfinite(u_radius) or 3 * u_radius > band:
        return (
            f"its radius {_fmt(radius)} mm is ill-determined (standard uncertainty {_fmt(u_radius)} mm; 3 u must be "
            f"within the ±{_fmt(100 * tolerance)} % tolerance)"
        )
    return None
