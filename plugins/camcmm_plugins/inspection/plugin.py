"""Plugin entry points (``inspect.align``, ``inspect.deviations``, ``inspect.compare``,
``inspect.material-ratio``): thin wrappers of the topic modules for the host, the CLI
and the GUI.

Output conventions (for a GUI built on these outputs):

- ``deviations``: a :class:`~camcmm.api.PointCloud` in *nominal* coordinates with the
  field ``deviation`` (mm; positive outside the material for a closed mesh, on the side
  the normals point to otherwise), the measured cloud's own fields, and colours on the
  diverging scale ±``colour_limit`` (blue below nominal, red above).
- ``stats``: see :func:`.stats.deviation_stats`; ``histogram``: ``edges`` and ``counts``;
  ``coverage``: the covered share (0..1) of the nominal *area*, details in
  ``coverage_info``, and ``coverage_cloud``: the nominal surface samples with the field
  ``covered`` (0/1) (and ``triangle`` for a mesh);
  ``material_ratio``: see :func:`.material_ratio.parameters` (``curve`` holds the
  Abbott-Firestone curve on 1001 material ratios).
- ``transform``: 4×4 measured -> nominal, ``[[s R, t], [0, 0, 0, 1]]``; ``scale`` = s.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import CadModel, GeometryError, InputError, ParameterError, PointCloud, TriangleMesh, read

from . import align as al
from . import chordal
from . import coverage as cov
from . import display as disp
from . import distance as dist
from . import material_ratio as mrmod
from . import stats as st

_ALIGN_KEYS = (
    "kernel",
    "kernel_k",
    "max_distance",
    "inlier_distance",
    "min_overlap",
    "region",
    "max_iterations",
    "max_points",
    "seed",
)


# --------------------------------------------------------------------------- helpers
def _json_input(value: Any, what: str) -> Any:
    """A JSON input given as data or as the path of a JSON file."""
    if value is None or isinstance(value, (dict, list, tuple, np.ndarray)):
        return value
    path = Path(value)
    try:
        return json.loads(path.read_text("utf-8"))
    except OSError as exc:
        raise InputError(f"{what} {str(path)!r}: cannot read it ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{what} {path.name}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{what} {path.name}: not valid JSON (not UTF-8 text at byte {exc.start})") from None


def _transform_input(value: Any) -> np.ndarray | None:
    v = _json_input(value, "transform")
    if isinstance(v, dict):
        v = v.get("transform")
    if v is None:
        return None
    T = np.asarray(v, dtype=float)
    if T.shape != (4, 4):
        raise InputError(f"transform must be a 4×4 matrix, got shape {T.shape}")
    return T


def _need_cloud(cloud: Any, what: str = "cloud") -> PointCloud:
    if not isinstance(cloud, PointCloud):
        name = getattr(cloud, "name", "")
        raise InputError(f"{what}{f' {name}' if name else ''}: expected a point cloud, got a {type(cloud).__name__}")
    if cloud.n_points < 10:
        raise InputError(f"{cloud.name}: {cloud.n_points} points are too few to inspect (need at least 10)")
    return cloud


def transformed_cloud(cloud: PointCloud, T: np.ndarray, name: str | None = None) -> PointCloud:
    """The cloud mapped by ``T`` (normals turned with it), fields kept."""
    normals = None
    if cloud.normals is not None:
        R = T[:3, :3] / np.cbrt(np.linalg.det(T[:3, :3]))
        normals = cloud.normals @ R.T
    return PointCloud(
        al.apply(T, cloud.points),
        cloud.colors,
        normals,
        dict(cloud.fields),
        dict(cloud.field_units),
        name or cloud.name,
        cloud.source_unit,
    )


def colour_limit(stats: dict[str, Any], tolerance: float | None) -> float:
    """±limit of the colour scale: the tolerance, else the larger of |p0.5| and |p99.5|."""
    if tolerance:
        return float(tolerance)
    lim = max(abs(stats["p0_5"]), abs(stats["p99_5"])) or stats["max_abs"]
    return float(lim) if lim > 0 else 1e-3


def deviation_colours(dev: np.ndarray, limit: float) -> np.ndarray:
    """RGB uint8 colours of the deviations on matplotlib's diverging RdBu_r over ±limit
    (the colour scale of camcmm.report's deviation maps).

    Looked up in the colour map's own 256-entry table the way matplotlib does (index
    ⌊256 u⌋, u = 1 taking the last entry; NaN its "bad" colour, black), without its
    (N, 4) float64 RGBA array: 320 MB for 10⁷ points."""
    from matplotlib import colormaps

    cmap = colormaps["RdBu_r"]
    lut = np.round(cmap(np.arange(cmap.N))[:, :3] * 255).astype(np.uint8)
    bad = np.round(np.asarray(cmap.get_bad())[:3] * 255 * cmap.get_bad()[3]).astype(np.uint8)
    d = np.asarray(dev, dtype=float)
    nan = np.isnan(d)
    u = np.clip(0.5 + 0.5 * np.where(nan, 0.0, d) / limit, 0.0, 1.0)
    out = lut[np.minimum((u * cmap.N).astype(np.int64), cmap.N - 1)]
    if nan.any():
        out[nan] = bad
    return out


def _nominal(nominal: Any) -> al.Nominal:
    if isinstance(nominal, al.Nominal):
        return nominal
    if isinstance(nominal, (TriangleMesh, PointCloud, CadModel)):
        return al.Nominal(nominal)
    raise InputError(f"nominal: expected a mesh, a CAD model or a point cloud, got a {type(nominal).__name__}")


# --------------------------------------------------------------------------- align
def run_alignment(cloud: PointCloud, nom: al.Nominal, method: str, pairs: Any = None, **params: Any) -> al.Alignment:
    args = {k: params[k] for k in _ALIGN_KEYS if params.get(k) is not None}
    p = _json_input(pairs, "pairs")
    if p is pairs or not method.startswith("pairs"):
        return al.align(cloud.points, nom, method=method, pairs=p, **args)
    # pairs read from a file: its errors name the file
    where = f"point pairs in {Path(pairs).name}"
    if not isinstance(p, dict) or "measured" not in p or "nominal" not in p:
        raise InputError(f'{where}: expected {{"measured": [[x, y, z], ...], "nominal": [[x, y, z], ...]}}')
    for key in ("measured", "nominal"):
        try:
            np.asarray(p[key], dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{where}: {key!r} must be a list of [x, y, z] numbers") from None
    try:
        return al.align(cloud.points, nom, method=method, pairs=p, **args)
    except (InputError, GeometryError) as exc:
        if str(exc).startswith("point pairs"):
            raise type(exc)(where + str(exc)[len("point pairs") :]) from None
        raise


def _alignment_outputs(a: al.Alignment) -> dict[str, Any]:
    d = a.to_dict()
    return {
        "transform": a.transform,
        "scale": a.scale,
        "rotation": a.rotation,
        "translation": a.translation,
        "rms": a.rms,
        "overlap": a.overlap,
        "converged": a.converged,
        "reason": a.reason,
        "alignment": d,
        "held_dofs": list(a.held_dofs),
    }


def _warn_held(ctx, a: al.Alignment) -> None:
    """Say which degrees of freedom the part's symmetry left undetermined (and held)."""
    if a.converged and a.held_dofs:
        ctx.warn(
            "the part's symmetry leaves these degrees of freedom undetermined by its shape; they were held at "
            "the start (coarse) alignment: " + "; ".join(a.held_dofs)
        )


def align(ctx, cloud, nominal, pairs=None, align: str = "icp", **params: Any) -> dict[str, Any]:
    """inspect.align: coarse + fine alignment; see :mod:`.align`."""
    cloud = _need_cloud(cloud)
    ctx.progress(0.05, "preparing the nominal")
    nom = _nominal(nominal)
    ctx.progress(0.2, f"aligning ({align})")
    a = run_alignment(cloud, nom, align, pairs, **params)
    if not a.converged:
        ctx.warn(f"alignment did not converge: {a.reason}")
    _warn_held(ctx, a)
    out = _alignment_outputs(a)
    out["aligned"] = transformed_cloud(cloud, a.transform, f"{cloud.name} aligned")
    return out


# --------------------------------------------------------------------------- deviations
def compute_deviations(
    ctx,
    cloud: PointCloud,
    nom: al.Nominal,
    tolerance: float | None = None,
    distance: str = "auto",
    neighbours: int = 12,
    coverage_distance: float | None = None,
    coverage_samples: int = 200_000,
    bins: int | None = None,
    residuals: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Deviations of ``cloud`` (already in nominal coordinates) and everything derived.

    ``residuals``: a dict that, against a plain mesh, receives ``e`` (|deviation|, mm) and
    ``rim`` (closest point on the mesh's boundary) — what an alignment's evaluation needs."""
    P = cloud.points
    face = None  # the CAD face of each point, for a CAD nominal
    if distance == "auto":
        distance = "mesh" if nom.mesh is not None else "plane"
    if distance == "mesh":
        if nom.mesh is None:
            raise ParameterError("distance 'mesh' needs a nominal mesh; for a reference cloud use plane or nn")
        if nom.cad is not None:
            ctx.progress(0.5, "signed distances to the exact CAD surface")
            dev, _, face, _, _ = nom.cad.closest(P)
            method = (
                "signed distance to the exact B-rep surface (closest triangle of the tessellation, closed-form "
                "projection onto its face; OpenCascade near edges and on free-form faces)"
            )
            extra = {"n_exact_by_opencascade": int(nom.cad.distance_engine.n_exact)}
            nominal_info = {**nom.cad.summary(), "mesh": nom.mesh.info.to_dict(), "chordal_error": 0.0}
        else:
            ctx.progress(0.5, "signed point-to-mesh distances")
            dev, det = nom.mesh.signed_distance(P, details=True, keep_closest=False)
            if residuals is not None:
                residuals.update(e=np.abs(dev), rim=det["rim"])
            method = "signed point-to-mesh (closest point, pseudo-normal sign, ray parity where unsure)"
            extra = {"n_sign_by_parity": det["n_parity"]}
            nominal_info = nom.mesh.info.to_dict()
            chord = chordal.chordal_error(nom.given)
            nominal_info["chordal_error"] = chord["error"] if chord else None
            if chord:
                nominal_info["chordal"] = chord
                if tolerance and chord["error"] > 0.1 * tolerance:
                    ctx.warn(
                        f"{nom.name}: the mesh's facets lie up to {chord['error'] * 1000:.3g} µm inside its "
                        f"{chord['surface']} (chordal error), more than a tenth of the tolerance {tolerance:g} mm: "
                        "every deviation carries up to that bias; compare with the exact surface (a STEP file) "
                        "or a finer mesh"
                    )
            # the mesh's own findings (a CAD model's tessellation is outward by construction,
            # and its distances do not rest on it)
            for note in nom.mesh.info.notes:
                ctx.warn(f"{nom.name}: {note}")
            if nom.mesh.info.n_flipped:
                ctx.warn(f"{nom.name}: {nom.mesh.info.n_flipped} triangles were wound the other way and were turned")
    else:
        if nom.cloud is None:
            raise ParameterError(f"distance {distance!r} needs a reference cloud; for a mesh use mesh")
        ctx.progress(0.5, f"cloud-to-cloud distances ({distance})")
        normals, how = dist.oriented_reference_normals(nom.cloud)
        if distance == "plane":
            dev, _ = dist.local_plane_distance(P, nom.cloud, neighbours, normals)
            method = f"signed distance to the local plane of {neighbours} reference points (normals: {how})"
        else:
            d, idx = dist.nearest_neighbour_distance(P, nom.cloud.points)
            s = np.einsum("ij,ij->i", P - nom.cloud.points[idx], normals[idx])
            dev = np.where(s < 0, -d, d)
            method = f"nearest reference point, signed by its normal (normals: {how})"
        extra = {}
        nominal_info = {"kind": "pointcloud", "n_points": nom.cloud.n_points, "normals": how}
    ctx.progress(0.7, "statistics")
    srt = st.sorted_finite(dev)  # one sort for the percentiles, histogram and material ratio
    stats = st.deviation_stats(dev, tolerance, presorted=srt)
    limit = colour_limit(stats, tolerance)
    hist = st.histogram(dev, bins if bins else "auto", limit=limit, presorted=srt)
    ctx.progress(0.75, "coverage")
    if nom.mesh is not None:
        c = cov.coverage(
            P, nom.mesh.V + nom.mesh.center, nom.mesh.F, coverage_distance, coverage_samples, return_samples=True
        )
    else:
        c = cov.coverage(P, distance=coverage_distance, reference_points=nom.ref_cloud.points, return_samples=True)
    fields_c = {"covered": c.pop("covered").astype(np.uint8)}
    if "triangle" in c:
        fields_c["triangle"] = c.pop("triangle")
    samples = PointCloud(c.pop("samples"), fields=fields_c, name=f"{nom.name} coverage samples")
    ctx.progress(0.85, "material ratio")
    mr = mrmod.parameters(dev, presorted=srt)
    del srt
    fields = dict(cloud.fields)
    units = dict(cloud.field_units)
    fields["deviation"] = dev
    units["deviation"] = "mm"
    if face is not None:
        fields["cad_face"] = face  # the 1-based index of the CAD face each point was compared with
    out_cloud = PointCloud(
        P, deviation_colours(dev, limit), cloud.normals, fields, units, f"{cloud.name} deviations", cloud.source_unit
    )
    return {
        "deviations": out_cloud,
        "stats": stats,
        "histogram": hist,
        "coverage": c["fraction"],
        "coverage_info": c,
        "coverage_cloud": samples,
        "material_ratio": mr,
        "colour_limit": limit,
        "distance_method": method,
        "nominal_info": nominal_info,
        **extra,
    }


def deviations(ctx, cloud, nominal, transform=None, **params: Any) -> dict[str, Any]:
    """inspect.deviations: deviations of a cloud that is aligned already (or by ``transform``)."""
    cloud = _need_cloud(cloud)
    ctx.progress(0.05, "preparing the nominal")
    nom = _nominal(nominal)
    T = _transform_input(transform)
    if T is not None:
        cloud = transformed_cloud(cloud, T)
    return compute_deviations(ctx, cloud, nom, **params)


def compare(ctx, cloud, nominal, pairs=None, align: str = "icp", **params: Any) -> dict[str, Any]:
    """inspect.compare: :func:`align` then :func:`deviations`, sharing the prepared nominal."""
    cloud = _need_cloud(cloud)
    ctx.progress(0.02, "preparing the nominal")
    nom = _nominal(nominal)
    dev_args = {
        k: params[k]
        for k in ("tolerance", "distance", "neighbours", "coverage_distance", "coverage_samples", "bins")
        if k in params
    }
    if (
        align == "none"
        and nom.mesh is not None
        and nom.cad is None
        and params.get("region") is None
        and dev_args.get("distance", "auto") in ("auto", "mesh")
    ):
        # nothing to fit, and the deviations' closest points are the evaluation's: one
        # pass over the cloud instead of two (10⁷ points: ~4 s less)
        ctx.progress(0.1, "aligning (none): the deviations give its rms and overlap")
        res: dict[str, Any] = {}
        dev_out = compute_deviations(ctx, cloud, nom, residuals=res, **dev_args)
        a = al.evaluation(np.eye(4), res["e"], res["rim"], nom, "none", [], params)
        out = _alignment_outputs(a)
        out.update(dev_out)
        return out
    ctx.progress(0.1, f"aligning ({align})")
    a = run_alignment(cloud, nom, align, pairs, **params)
    if not a.converged:
        ctx.warn(f"alignment did not converge: {a.reason}. The deviations below rest on an unreliable alignment.")
    _warn_held(ctx, a)
    moved = transformed_cloud(cloud, a.transform)
    out = _alignment_outputs(a)
    out.update(compute_deviations(ctx, moved, nom, **dev_args))
    return out


# --------------------------------------------------------------------------- material ratio
def load_heightmap(path: Any, unit: str = "mm", level: bool = False) -> np.ndarray:
    """A 2-D height map from a .npy file, in mm (NaN where there are no data)."""
    p = Path(path)
    if p.suffix.lower() != ".npy":
        raise InputError(f"{p.name}: height maps are read from .npy files (a 2-D array of heights)")
    try:
        z = np.load(p, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise InputError(f"{p.name}: cannot read it as a numpy array ({exc})") from None
    if z.ndim != 2 or z.dtype.kind not in "fiu":
        raise InputError(f"{p.name}: expected a 2-D array of numbers, got {z.dtype} with shape {z.shape}")
    factor = {"mm": 1.0, "um": 1e-3, "nm": 1e-6}[unit]
    z = z.astype(float) * factor
    return mrmod.level(z) if level else z


def material_ratio(
    ctx,
    source,
    field: str = "deviation",
    unit: str = "mm",
    level: bool = False,
    smc_at: list[float] | None = None,
    smr_at: list[float] | None = None,
) -> dict[str, Any]:
    """inspect.material-ratio of a height map (.npy) or of a cloud's field (results in mm, Smr in %)."""
    if isinstance(source, (str, Path)) and Path(source).suffix.lower() == ".npy":
        h = load_heightmap(source, unit, level)
        name = f"height map {Path(source).name} ({h.shape[1]}×{h.shape[0]}, unit {unit})"
    else:
        cloud = read(source) if isinstance(source, (str, Path)) else source
        if not isinstance(cloud, PointCloud):
            raise InputError(
                f"material ratio: expected a .npy height map or a point cloud, got a {type(cloud).__name__}"
            )
        if field == "z":
            h = cloud.points[:, 2]
        elif field in cloud.fields:
            h = np.asarray(cloud.fields[field], dtype=float)
            u = cloud.field_units.get(field, "mm")
            if u not in ("mm", ""):
                ctx.warn(f"field {field!r} is in {u}; results keep that unit")
        else:
            known = ", ".join(sorted(cloud.fields)) or "none"
            raise InputError(f"{cloud.name}: no field {field!r} (fields: {known}; or 'z')")
        name = f"{cloud.name} field {field}"
    ctx.progress(0.3, "material-ratio curve")
    curve = mrmod.material_ratio_curve(h)
    mr = mrmod.parameters(h)
    mr["source"] = name
    out = {k: mr[k] for k in ("Sk", "Spk", "Svk", "Smr1", "Smr2")} | {"material_ratio": mr}
    if smc_at:
        bad = [m for m in smc_at if not 0 <= m <= 100]
        if bad:
            raise ParameterError(f"smc_at: material ratios must lie in 0..100 %, got {bad[0]}")
        out["Smc"] = {f"{m:g}": float(curve.smc(m / 100.0)) for m in smc_at}
    if smr_at:
        out["Smr"] = {f"{c:g}": 100.0 * float(curve.smr(c)) for c in smr_at}
    return out


# --------------------------------------------------------------------------- what a viewer shows
def bands(ctx, deviations, *, tolerance: float | None) -> dict[str, Any]:
    """inspect.bands: each point of a deviations cloud below, within or above ±tolerance.
    The parameters' defaults are the manifest's (the host passes every one)."""
    if not tolerance:
        raise ParameterError("tolerance: give the tolerance (mm, > 0) the bands are drawn for")
    codes = disp.band_codes(disp.deviation_field(deviations), tolerance)
    counts = disp.band_counts(codes)
    return {"codes": codes, "counts": counts, "within": disp.within_share(counts)}


def section(
    ctx,
    deviations,
    nominal=None,
    *,
    axis: str,
    position: float | None,
    half_width: float | None,
    max_points: int,
    seed: int,
) -> dict[str, Any]:
    """inspect.section: a plane across an axis cutting the nominal and the deviations cloud
    (``position`` None: the middle of the cloud; ``half_width`` None: half its median
    point spacing, returned as ``spacing``)."""
    dev = disp.deviation_field(deviations)
    ax = disp.AXES.index(axis)
    if position is None:
        lo, hi = deviations.points[:, ax].min(), deviations.points[:, ax].max()
        position = 0.5 * (float(lo) + float(hi))
    spacing = None
    if half_width is None:
        spacing = disp.point_spacing(deviations.points)
        half_width = 0.5 * spacing
    # a CAD model is cut through its tessellation (within its deflection of the exact surface)
    mesh = nominal.mesh if isinstance(nominal, CadModel) else nominal if isinstance(nominal, TriangleMesh) else None
    cloud = nominal.points if isinstance(nominal, PointCloud) else None
    sec = disp.section(ax, position, deviations.points, dev, half_width, mesh, cloud, max_points, seed)
    return {"section": sec, "spacing": spacing}
