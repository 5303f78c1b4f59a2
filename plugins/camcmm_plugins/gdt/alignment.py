"""Aligning a measured cloud to the plan's coordinates (``camcmm gdt evaluate --align``).

:func:`align` returns the rigid transform T (4×4, measured -> plan coordinates) and an
``info`` dict (``method``, ``transform``, ``rms`` mm, ``iterations``, ``converged``,
``free``: the degrees of freedom the method left undetermined, held where the start put
them, ``start``: the coarse start when one was needed, ``n_points``, ``features``). The
methods:

* ``best-fit``: with a nominal (mesh, reference cloud or CAD model) the cloud is aligned
  to it by ``inspect.align`` (robust point-to-plane ICP). Without one, to the nominal
  surfaces of the plan's features: iterated point-to-surface least squares (Gauss-Newton
  on the six rigid parameters) over the points within each feature's band and extent
  (:func:`.features.select`, re-selected at every iteration). "Best fit restricted to
  regions": the plan's ``alignment: {features: [A, H1], boxes: [[[x0,y0,z0],[x1,y1,z1]], ...]}``
  limits the fit to those features and to the points in those boxes (plan coordinates).
* ``datums``: the datum reference frame (ISO 5459) of the plan's datums
  (``alignment: {datums: [A, B, C]}``, by default the longest datum list a characteristic
  names) from :func:`.datums.datum_frame` becomes the part's coordinates; the datum
  features' points are re-selected in the new pose and the frame built again until the
  transform settles (1e-9 mm). The degrees of freedom the datums leave free keep the
  best fit's values (the iteration starts from a best fit).
* ``3-2-1``: classical alignment on least-squares elements: a primary plane fixes three
  degrees of freedom (its normal, its offset), a secondary plane, line or axis two (its
  direction about the primary normal, its offset across), a tertiary plane, point,
  sphere, circle or axis one (the offset along the remaining direction); or, plane-hole-
  slot, a secondary hole (a point, sphere, circle, or an axis along the primary normal)
  two (its position in the plane) and a tertiary hole one (the turn towards it):
  ``alignment: {features: [A, B, C]}`` or ``[A, H1, H2]`` (default: the first three
  single-feature datums).
* ``rps``: reference point system. The plan names reference points, each on a feature and
  fixing given plan directions::

      rps:
        R1: {feature: H1, fixes: [x, y]}             # bore: its axis point at the nominal point
        R2: {feature: H2, fixes: [y]}
        R3: {feature: A, fixes: [z], at: [10, 10, 0]}  # a plane: the surface point at `at`
        R4: {feature: A, fixes: [z], at: [70, 10, 0]}
        R5: {feature: A, fixes: [z], at: [40, 50, 0]}
        R6: {feature: C, fixes: [x], at: [0, 30, 15]}   # (x is fixed by R1 too: least squares)

  The measured reference point of a plane is where the line through ``at`` along its
  nominal normal meets the associated plane; of a cylinder or cone the point of its axis
  nearest ``at`` (default the nominal ``point``/``apex``); of a sphere or circle its
  centre; of a point feature the point. The transform minimises the sum of squared
  differences measured − nominal along each fixed direction (exact with six independent
  fixes; more are a least-squares fit; fewer leave degrees of freedom free, reported).
* ``none``: the cloud is in plan coordinates already.

A part delivered in a scanner's frame (rotated, far from the plan) first gets a coarse
start (:mod:`.coarse`; ``start: auto`` when fewer than half of the plan's features find
points within their bands as the cloud lies, or when a best fit from there is doubtful —
under half the points within the bands, or under 85 % of those within 8 mm of the
surfaces —, that fit then one of the candidates; ``coarse`` always; ``none`` never): the
cloud's principal axes onto those of points sampled on the nominal surfaces of the plan's
features (within their boxes and extents; or of the nominal geometry when given), each of
the four sign choices refined by ``inspect.align`` ICP and then by best fits in bands
narrowing from 8 mm, the one with most points within the bands kept (FPFH + RANSAC
registration when none holds half the points); the fine method starts from there.

The machinery: :mod:`.bestfit` (the point-to-surface fit, rigid-motion geometry),
:mod:`.coarse`, :mod:`.references` (3-2-1, RPS); the datum frame is :mod:`.datums`'.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError, PointCloud, get_algorithm

from .bestfit import (
    SETTLED_MM,
    SURFACE_TYPES,
    apply,
    associate,
    best_fit_surfaces,
    plan_name,
    plan_size,
    rms_to_nominals,
    settle,
    surface_distance_normal,
    transform_summary,
    unit_factor,
)
from .coarse import coarse_start, doubtful, enough_in_bands, sample_nominal
from .model import ALIGNMENTS, Plan
from .references import rps_alignment, rps_points, three_two_one

__all__ = [
    "align",
    "apply",
    "best_fit_surfaces",
    "coarse_start",
    "datum_alignment",
    "options",
    "rps_alignment",
    "rps_points",
    "sample_nominal",
    "surface_distance_normal",
    "three_two_one",
    "transform_summary",
]


# --------------------------------------------------------------------------- settings
def options(plan: Plan) -> dict[str, Any]:
    """The plan's ``alignment`` mapping (features, boxes, datums, start), checked."""
    src = plan.source and plan.source.split("/")[-1] or "plan"
    raw = plan.options.get("alignment") or {}
    if not isinstance(raw, dict):
        raise InputError(f"{src}: alignment: expected a mapping (features, boxes, datums), got {raw!r:.60}")
    out: dict[str, Any] = {}
    for key in ("features", "datums"):
        if key in raw:
            v = raw[key]
            names = [v] if isinstance(v, str) else v
            if not isinstance(names, list) or not all(isinstance(n, str) for n in names) or not names:
                raise InputError(f"{src}: alignment.{key}: expected a list of names, got {v!r:.60}")
            known = plan.features if key == "features" else plan.datums
            for n in names:
                if n not in known:
                    raise InputError(f"{src}: alignment.{key}: unknown {key[:-1]} {n!r}")
            out[key] = tuple(names)
    if "boxes" in raw:
        try:
            boxes = np.asarray(raw["boxes"], dtype=float)
        except (TypeError, ValueError):
            boxes = np.zeros(0)
        if (
            boxes.ndim != 3
            or boxes.shape[1:] != (2, 3)
            or not np.isfinite(boxes).all()
            or (boxes[:, 0] > boxes[:, 1]).any()
        ):
            raise InputError(f"{src}: alignment.boxes: expected a list of [[xmin,ymin,zmin],[xmax,ymax,zmax]] boxes")
        out["boxes"] = boxes * unit_factor(plan)
    for key in sorted(set(raw) - {"features", "datums", "boxes"}):
        raise InputError(f"{src}: alignment.{key}: unknown key; use features, boxes or datums")
    return out


# --------------------------------------------------------------------------- datums
def datum_labels(plan: Plan, opts: dict[str, Any]) -> tuple[str, ...]:
    """The datums of the datum alignment: ``alignment.datums``, else the longest datum list
    a characteristic names (the first of those), else the declared datums (up to three)."""
    if "datums" in opts:
        return tuple(opts["datums"])
    lists = [c.datums for c in plan.characteristics if c.datums]
    if lists:
        return max(lists, key=len)
    if not plan.datums:
        raise InputError(f"{plan_name(plan)}: datums: the datum alignment needs datums; the plan declares none")
    return tuple(list(plan.datums)[:3])


def datum_alignment(
    plan: Plan, points: np.ndarray, T0: np.ndarray, labels: tuple[str, ...], cad: Any = None, max_iterations: int = 30
) -> tuple[np.ndarray, dict[str, Any]]:
    """The DRF of ``labels`` as the part's coordinates, iterated from ``T0`` until it settles."""
    from . import datums as dmod

    fids = sorted({f for lab in labels for f in plan.datums[lab]})
    state: dict[str, Any] = {"free": []}

    def step(T: np.ndarray) -> np.ndarray:
        X = apply(T, points)
        frame = dmod.datum_frame(plan, {f: associate(plan, X, plan.features[f], cad) for f in fids}, labels)
        state["free"] = list(frame.free)
        return np.asarray(frame.transform, float) @ T

    T, it, converged = settle(step, T0, plan_size(plan), max_iterations, 10 * SETTLED_MM)
    free = state["free"]
    return T, {
        "kind": f"datum reference frame {'|'.join(labels)} (ISO 5459)",
        "datums": list(labels),
        "iterations": it,
        "converged": converged,
        "free": free,
    }


# --------------------------------------------------------------------------- the entry
def align(
    method: str,
    plan: Plan,
    points: np.ndarray,
    nominal: Any = None,
    cad: Any = None,
    start: str = "auto",
    seed: int = 0,
    max_iterations: int = 50,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Align ``points`` (N, 3 mm, as measured) to the plan's coordinates by ``method``
    (:data:`.model.ALIGNMENTS`); returns (T 4×4 measured -> plan, info). ``nominal`` a
    TriangleMesh / PointCloud / CAD model in plan coordinates (best fit goes to it);
    ``cad`` the CAD model whose faces ``face`` features name. ``start``: auto | coarse |
    none (see the module docstring)."""
    if method not in ALIGNMENTS:
        raise InputError(f"align: unknown method {method!r}; use one of {', '.join(ALIGNMENTS)}")
    P = np.asarray(points, dtype=float)
    opts = options(plan)
    T = np.eye(4)
    info: dict[str, Any] = {"method": method}
    stages: list[dict[str, Any]] = []
    if method != "none":
        need = start == "coarse"
        why = "asked for"
        tried: list[tuple[str, np.ndarray]] = []
        if start == "auto":
            ok, why = enough_in_bands(plan, P, cad)
            need = not ok
            if ok:  # near enough for a fit: is where it ends believable?
                T, why = doubtful(plan, P, cad, max_iterations)
                need = bool(why)
                tried = [("as delivered", T)]
        if need:
            T, cinfo = coarse_start(plan, P, nominal, seed, cad, tried)
            stages.append({"stage": "coarse start", "why": why, **cinfo})
    if method == "best-fit" and nominal is not None:
        # a CAD model as it is: inspect.align pairs points with its exact surface, not
        # with its tessellation (whose facets would bias the pose by their chordal error)
        mesh = nominal
        params: dict[str, Any] = {"align": "icp", "seed": seed}
        if "boxes" in opts:
            if len(opts["boxes"]) > 1:
                raise InputError(f"{plan_name(plan)}: alignment.boxes: a best fit to a nominal takes one box (region)")
            params["region"] = [float(v) for v in opts["boxes"][0].ravel()]
        out = get_algorithm("inspect.align")(cloud=PointCloud(apply(T, P), name="measured"), nominal=mesh, **params)
        T = np.asarray(out["transform"], float) @ T
        a = out["alignment"]
        stages.append({"stage": "fine", "kind": "inspect.align icp to the nominal", "rms": out["rms"]})
        info.update(
            rms=float(out["rms"]),
            iterations=int(a.get("iterations", 0)),
            converged=bool(out["converged"]),
            free=list(out.get("held_dofs", [])),
        )
    elif method == "best-fit":
        T, fine = best_fit_surfaces(plan, P, T, opts.get("features"), opts.get("boxes"), cad, max_iterations)
        stages.append({"stage": "fine", **fine})
        info.update({k: fine[k] for k in ("rms", "iterations", "converged", "free", "n_points")})
    elif method in ("datums", "3-2-1", "rps"):
        # a best fit first (when the plan has surfaces to fit to): the pose within the
        # bands, and the values of the degrees of freedom the method leaves free
        if any(s.type in SURFACE_TYPES for s in plan.features.values()):
            T, pre = best_fit_surfaces(plan, P, T, cad=cad, max_iterations=max_iterations)
            stages.append({"stage": "best fit (start)", **pre})
        if method == "datums":
            T, fine = datum_alignment(plan, P, T, datum_labels(plan, opts), cad)
        elif method == "3-2-1":
            ids = opts.get("features") or tuple(f[0] for f in plan.datums.values() if len(f) == 1)[:3]
            T, fine = three_two_one(plan, P, T, tuple(ids), cad)
        else:
            T, fine = rps_alignment(plan, P, T, cad)
        stages.append({"stage": "fine", **fine})
        info.update({k: fine[k] for k in ("iterations", "converged", "free")})
        info["rms"] = rms_to_nominals(plan, apply(T, P), cad)
    else:
        info.update(rms=rms_to_nominals(plan, P, cad), iterations=0, converged=True, free=[])
    info["transform"] = T.tolist()
    info.update(transform_summary(T))
    info["stages"] = stages
    return T, info
