"""STUDY.yaml of the speckle on/off study (thesis ch. 6.2): what to measure and where.

::

    name: AM artefacts, speckle on/off
    work: speckle.work            # finished cases are kept here (default <file stem>.work)
    artefacts:                    # names of virtuallab.am-artefact, with optional sizes (mm)
      - am_pyramid
      - {name: am_sphere, sizes: {diameter: 20, centre_height: 6}}
    materials: [nylon12, abs, ti6al4v]
    conditions: [off, on]         # speckle off / on (default both)
    capture:                      # either simulated ...
      simulated: {n_images: 30, arc_deg: 270, elevation: 45, downscale: 10}
    # ... or real image folders, one per case (relative to the study file):
    #   images:
    #     - {artefact: am_pyramid, material: nylon12, condition: off, folder: img/pyr-ny-off,
    #        pairs: {measured: [[x,y,z] x3], nominal: [[x,y,z] x3]}}   # optional picked pairs
    reconstruct: {max_image_size: 600}
    align: {method: auto}         # auto: pairs+similarity (camera centres or picked pairs),
                                  # else global+similarity
    coverage: {distance: 0.0, samples: 100000}   # 0: 3 point spacings

Checked on reading, before anything is created or listed (one validation of the whole
document; each problem one line naming the file, the key path and the value): every key
known and of its type; the capture, reconstruction, alignment and coverage settings by
the declarations of the plugins they are passed to (``virtuallab.turntable-series``,
``photogrammetry.reconstruct``, ``inspect.align``, ``inspect.deviations``: one rule for
the study file, the CLI and the GUI); artefact sizes finite numbers of at most
``MAX_SIZE`` mm; every path (``work``, each ``capture.images[i].folder``) through
``camcmm.api.document_path`` (relative to the study file; refused outside the folders of a
confined run); the work folder creatable (not a file, not under a file, writable); each
image folder holding at least ``MIN_IMAGES`` files that carry an image signature.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from pathlib import Path
from typing import Any

from camcmm.api import (
    CamcmmError,
    InputError,
    ParameterError,
    checked_path,
    declared_value,
    document_path,
    read_yaml,
)

ARTEFACTS = ("am_pyramid", "am_recess", "am_sphere", "am_pillars")
MATERIALS = ("nylon12", "abs", "ti6al4v")
CONDITIONS = ("off", "on")
#: The keys of a study file, of an artefact entry, of an image entry and of its pairs.
KEYS = ("name", "work", "artefacts", "materials", "conditions", "capture", "reconstruct", "align", "coverage")
ARTEFACT_KEYS = ("name", "sizes")
IMAGE_KEYS = ("artefact", "material", "condition", "folder", "pairs")
#: The thesis's set-up (ch. 6.2.2): 30 images through 270°, elevation ~45°, F/11; the
#: image size reduced for speed; the speckle's grain kept at ~3 px at that size.
SIMULATED = {
    "n_images": 30,
    "arc_deg": 270.0,
    "elevation": 45.0,
    "downscale": 10.0,
    "f_number": 11.0,
    "supersample": 1,
    "distance": 100.0,
    "diffuser": 0.05,
    "magnification": 0.3,
    "seed": 0,
}
RECONSTRUCT = {"max_image_size": 600, "dense": True}
#: The settings of photogrammetry.reconstruct a study may give: not ``scale`` (the
#: alignment to the CAD sets the scale; a lengths file would be a path inside the study)
#: nor ``scheduler`` (only the server's configured schedulers may be used).
RECONSTRUCT_KEYS = (
    "max_image_size",
    "dense",
    "matching",
    "camera_model",
    "dense_max_image_size",
    "turntable_angles",
    "turntable_window",
)
#: inspect.align's settings; the inlier distance is wider than its default (1 % of the
#: part's size, ~0.6 mm) because AM parts and photogrammetry deviate by up to 0.37 mm
#: (table 6.1, nylon without speckle; the virtual nylon's clouds ~0.4-0.6 mm) and the
#: alignment counts as a match only while that spread is within a quarter of it
ALIGN = {"method": "auto", "inlier_distance": 2.5}
ALIGN_KEYS = (
    "method",
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
#: coverage key -> inspect.deviations parameter (distance 0: three point spacings)
COVERAGE = {"distance": "coverage_distance", "samples": "coverage_samples"}
#: Largest magnitude of an artefact size (mm): the AM artefacts are tens of mm; beyond
#: this a size is a slip (a unit, a digit), and 1e300 overflows the mesh's cross products.
MAX_SIZE = 10_000.0
#: Fewest images of a real image folder (a reconstruction needs three views).
MIN_IMAGES = 3
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
#: The first bytes of each image format the capture reads (PNG, JPEG, TIFF both byte
#: orders, BMP): a file named like an image without one is refused by name.
SIGNATURES = (b"\x89PNG\r\n\x1a\n", b"\xff\xd8\xff", b"II*\x00", b"MM\x00*", b"BM")
#: Longest study name (characters).
MAX_NAME = 200


class _Doc:
    """The study file being validated: every refusal is one line ``FILE: KEY: why``."""

    def __init__(self, path: Path):
        self.path = path
        self.name = path.name

    def fail(self, key: str, why: str) -> InputError:
        return InputError(f"{self.name}: {key}: {why}")

    def mapping(self, v: Any, key: str, keys: tuple[str, ...]) -> dict[str, Any]:
        """``v`` as a mapping whose keys are all in ``keys`` (None: empty)."""
        if v is None:
            return {}
        if not isinstance(v, dict):
            raise self.fail(key, f"must be a mapping ({', '.join(keys)}), got {_short(v)}")
        for k in v:
            if k not in keys:
                raise self.fail(f"{key}.{k}" if key else str(k), f"is not a key here; use {', '.join(keys)}")
        return v

    def declared(self, plugin: str, param: str, v: Any, key: str) -> Any:
        """``v`` checked by parameter ``param`` of ``plugin``'s declaration (its type,
        limits, choices): ``FILE: KEY: parameter 'param' = v is below its minimum ...``."""
        if v is None:
            raise self.fail(key, "is empty; give a value or leave the key out")
        try:
            return declared_value(plugin, param, v, flag=f"{self.name}: {key}")
        except ParameterError as exc:  # a value in a document: bad input, as every other key
            raise InputError(str(exc)) from None


def _short(v: Any, n: int = 60) -> str:
    s = repr(v)
    return s if len(s) <= n else s[: n - 3] + "..."


def _cond(v: Any) -> Any:
    """YAML 1.1 reads a bare on / off as true / false."""
    return {True: "on", False: "off"}.get(v, v) if isinstance(v, bool) else v


def _choice(doc: _Doc, v: Any, known: tuple[str, ...], what: str, key: str) -> str:
    if what == "condition":
        v = _cond(v)
    if not isinstance(v, str) or v not in known:
        raise doc.fail(key, f"unknown {what} {_short(v)} (use {', '.join(known)})")
    return v


def _names(doc: _Doc, value: Any, known: tuple[str, ...], what: str, key: str) -> list[Any]:
    """A list (or one item) of names, none twice; absent: all of ``known``."""
    if value is None:
        return list(known)
    items = value if isinstance(value, list) else [value]
    if not items:
        raise doc.fail(key, f"lists no {what}; leave the key out for all ({', '.join(known)})")
    return items


def _unique(doc: _Doc, names: list[str], key: str, what: str) -> None:
    seen: set[str] = set()
    for i, n in enumerate(names):
        if n in seen:
            raise doc.fail(f"{key}[{i}]", f"{what} {n!r} is listed twice")
        seen.add(n)


def _size(doc: _Doc, v: Any, key: str) -> None:
    """An artefact size: a finite number of at most MAX_SIZE mm, or a list of them."""
    if isinstance(v, list) and v:
        for i, x in enumerate(v):
            _size(doc, x, f"{key}[{i}]")
        return
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or abs(v) > MAX_SIZE:
        raise doc.fail(key, f"must be a size in mm (a finite number, at most {MAX_SIZE:g}), got {_short(v)}")


def _artefacts(doc: _Doc, value: Any) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for i, a in enumerate(_names(doc, value, ARTEFACTS, "artefact", "artefacts")):
        key = f"artefacts[{i}]" if isinstance(value, list) else "artefacts"
        if isinstance(a, dict):
            a = doc.mapping(a, key, ARTEFACT_KEYS)
            name = _choice(doc, a.get("name"), ARTEFACTS, "artefact", f"{key}.name")
            sizes = a.get("sizes") or {}
            if not isinstance(sizes, dict):
                raise doc.fail(f"{key}.sizes", f"must be a mapping of sizes in mm, got {_short(sizes)}")
            for k, v in sizes.items():
                if not isinstance(k, str):
                    raise doc.fail(f"{key}.sizes", f"size names are words, got {_short(k)}")
                _size(doc, v, f"{key}.sizes.{k}")
            out.append({"name": name, "sizes": dict(sizes)})
        else:
            out.append({"name": _choice(doc, a, ARTEFACTS, "artefact", key), "sizes": {}})
    _unique(doc, [a["name"] for a in out], "artefacts", "artefact")
    return out


def _listed(doc: _Doc, value: Any, known: tuple[str, ...], what: str, key: str) -> list[str]:
    items = _names(doc, value, known, what, key)
    out = [_choice(doc, v, known, what, f"{key}[{i}]" if isinstance(value, list) else key) for i, v in enumerate(items)]
    _unique(doc, out, key, what)
    return out


def _work(doc: _Doc, value: Any) -> Path:
    """The work folder: through document_path (confined runs refuse a folder outside),
    then one that can be created and written — checked here, before anything is."""
    if value is None:
        value = f"{doc.path.stem}.work"
    if not isinstance(value, str) or not value.strip() or "\x00" in value:
        raise doc.fail("work", f"must be a folder name, got {_short(value)}")
    work = Path(document_path(value, doc.path, "work")).resolve()
    if work.exists() and not work.is_dir():
        raise doc.fail("work", f"{value} is a file, not a folder")
    parent = work
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise doc.fail("work", f"{value} cannot be created: {parent} is a file")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise doc.fail("work", f"{value} cannot be written: no permission in {parent}")
    return work


def _pairs(doc: _Doc, v: Any, key: str) -> dict[str, list[list[float]]] | None:
    """Picked point pairs: measured and nominal, the same number (>= 3) of [x, y, z]."""
    if v is None:
        return None
    v = doc.mapping(v, key, ("measured", "nominal"))
    out: dict[str, list[list[float]]] = {}
    for side in ("measured", "nominal"):
        pts = v.get(side)
        if not isinstance(pts, list) or len(pts) < 3:
            raise doc.fail(f"{key}.{side}", f"must list at least 3 points [x, y, z], got {_short(pts)}")
        for j, q in enumerate(pts):
            ok = isinstance(q, list) and len(q) == 3
            if not ok or any(isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) for x in q):
                raise doc.fail(f"{key}.{side}[{j}]", f"must be [x, y, z] in finite numbers (mm), got {_short(q)}")
        out[side] = [[float(x) for x in q] for q in pts]
    if len(out["measured"]) != len(out["nominal"]):
        raise doc.fail(key, f"measured has {len(out['measured'])} points, nominal {len(out['nominal'])}")
    return out


def _is_image(f: Path) -> bool:
    try:
        with open(f, "rb") as fh:
            head = fh.read(8)
    except OSError:
        return False
    return any(head.startswith(s) for s in SIGNATURES)


def _folder(doc: _Doc, value: Any, key: str) -> Path:
    """An image folder: named, allowed, existing, holding MIN_IMAGES images."""
    if not isinstance(value, str) or not value.strip() or "\x00" in value:
        raise doc.fail(key, f"must be a folder of images, got {_short(value)}")
    folder = Path(document_path(value, doc.path, key)).resolve()
    if not folder.is_dir():
        raise doc.fail(
            key, f"image folder {value!r} does not exist" if not folder.exists() else f"{value!r} is not a folder"
        )
    try:
        files = sorted(f for f in folder.iterdir() if f.suffix.lower() in IMAGE_EXTENSIONS and f.is_file())
    except OSError as exc:
        raise doc.fail(key, f"{value!r} cannot be listed ({type(exc).__name__})") from None
    if len(files) < MIN_IMAGES:
        raise doc.fail(key, f"{value!r} holds {len(files)} image(s); a case needs at least {MIN_IMAGES}")
    for f in files:
        if not _is_image(f):
            raise doc.fail(key, f"{f.name} in {value!r} is not an image (no PNG, JPEG, TIFF or BMP signature)")
    return folder


def _capture(doc: _Doc, value: Any) -> dict[str, Any]:
    cap = doc.mapping(value if value is not None else {"simulated": {}}, "capture", ("simulated", "images"))
    if len(cap) != 1:
        raise doc.fail("capture", "must give either 'simulated' settings or 'images' folders")
    if "simulated" in cap:
        given = doc.mapping(cap["simulated"], "capture.simulated", tuple(SIMULATED))
        sim = dict(SIMULATED)
        for k, v in given.items():
            sim[k] = doc.declared("virtuallab.turntable-series", k, v, f"capture.simulated.{k}")
        return {"simulated": sim, "images": None}
    entries = cap["images"]
    if entries is None:
        entries = []
    if not isinstance(entries, list):
        raise doc.fail("capture.images", f"must list image folders, one per case, got {_short(entries)}")
    folders: dict[str, dict[str, Any]] = {}
    for i, e in enumerate(entries):
        key = f"capture.images[{i}]"
        e = doc.mapping(e, key, IMAGE_KEYS)
        a = _choice(doc, e.get("artefact"), ARTEFACTS, "artefact", f"{key}.artefact")
        m = _choice(doc, e.get("material"), MATERIALS, "material", f"{key}.material")
        c = _choice(doc, e.get("condition"), CONDITIONS, "condition", f"{key}.condition")
        cid = case_id(a, m, c)
        if cid in folders:
            raise doc.fail(key, f"case {cid} has an image folder already")
        pairs = _pairs(doc, e.get("pairs"), f"{key}.pairs")
        folders[cid] = {"folder": str(_folder(doc, e.get("folder"), f"{key}.folder")), "pairs": pairs}
    return {"simulated": None, "images": folders}


def _settings(doc: _Doc, value: Any, key: str, keys: tuple[str, ...], plugin: str, rename=None) -> dict[str, Any]:
    """A settings mapping checked key by key by ``plugin``'s declared parameters."""
    out = {}
    for k, v in doc.mapping(value, key, keys).items():
        out[k] = doc.declared(plugin, (rename or {}).get(k, k), v, f"{key}.{k}")
    return out


def load(path: str | Path) -> dict[str, Any]:
    """The study as a dict with resolved paths and defaults; InputError (one line naming
    the file, the key and the value) on bad input, before anything is created."""
    p = Path(checked_path(path, "study"))
    if not p.is_file():
        raise InputError(f"{path}: no such study file")
    doc = _Doc(p)
    d = read_yaml(p, name=p.name)
    if not isinstance(d, dict):
        raise InputError(f"{p.name}: expected a mapping (artefacts, materials, capture ...), got {_short(d)}")
    doc.mapping(d, "", KEYS)
    name = d.get("name", p.stem)
    if not isinstance(name, (str, int, float)) or isinstance(name, bool) or not str(name).strip():
        raise doc.fail("name", f"must be a text, got {_short(name)}")
    if len(str(name)) > MAX_NAME:
        raise doc.fail("name", f"is longer than {MAX_NAME} characters")
    # the work folder first: in a confined run a folder outside is refused before any
    # other path of the study is looked at, and nothing is created until all is checked
    work = _work(doc, d.get("work"))
    arts = _artefacts(doc, d.get("artefacts"))
    mats = _listed(doc, d.get("materials"), MATERIALS, "material", "materials")
    conds = _listed(doc, d.get("conditions"), CONDITIONS, "condition", "conditions")
    given = dict(doc.mapping(d.get("align"), "align", ALIGN_KEYS))
    method = given.pop("method", ALIGN["method"])  # auto: pairs when there are any (cases.py)
    align = _settings(doc, given, "align", ALIGN_KEYS, "inspect.align")
    align["method"] = "auto" if method == "auto" else doc.declared("inspect.align", "align", method, "align.method")
    given = dict(doc.mapping(d.get("coverage"), "coverage", tuple(COVERAGE)))
    if given.get("distance") == 0 and not isinstance(given["distance"], bool):
        given.pop("distance")  # 0: three point spacings, inspect.deviations' default
    cov = _settings(doc, given, "coverage", tuple(COVERAGE), "inspect.deviations", COVERAGE)
    study: dict[str, Any] = {
        "file": str(p.resolve()),
        "name": str(name),
        "work": str(work),
        "artefacts": arts,
        "materials": mats,
        "conditions": conds,
        "reconstruct": {
            **RECONSTRUCT,
            **_settings(doc, d.get("reconstruct"), "reconstruct", RECONSTRUCT_KEYS, "photogrammetry.reconstruct"),
        },
        "align": {**ALIGN, **align},
        "coverage": {"distance": 0.0, "samples": 100000, **cov},
    }
    study.update(_capture(doc, d.get("capture")))
    study["cases"] = [
        {"id": case_id(a["name"], m, c), "artefact": a["name"], "sizes": a["sizes"], "material": m, "condition": c}
        for a in arts
        for m in mats
        for c in conds
    ]
    if study["images"] is not None:
        missing = [c["id"] for c in study["cases"] if c["id"] not in study["images"]]
        if missing:
            raise doc.fail("capture.images", f"no image folder for case {missing[0]}")
    return study


def check_cad(ctx, study: dict[str, Any]) -> None:
    """Build each artefact's CAD once (virtuallab.am-artefact, milliseconds) so sizes that
    make no part (a sphere centred above itself) are refused before any case runs."""
    for i, a in enumerate(study["artefacts"]):
        try:
            ctx.algorithm("virtuallab.am-artefact")(artefact=a["name"], sizes=a["sizes"] or None)
        except CamcmmError as exc:
            raise InputError(f"{Path(study['file']).name}: artefacts[{i}].sizes: {exc}") from None


def case_id(artefact: Any, material: Any, condition: Any) -> str:
    return f"{artefact}-{material}-{condition}"


def case_key(study: dict[str, Any], case: dict[str, Any]) -> str:
    """A hash of everything a case's result depends on: a finished case is reused only
    when it matches (a changed setting recomputes it)."""
    src = study["simulated"] if study["simulated"] is not None else study["images"][case["id"]]
    blob = json.dumps([case, src, study["reconstruct"], study["align"], study["coverage"]], sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]
