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

Bad input (an unknown artefact or material, a missing image folder) is refused in one
line naming the file and the value.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from camcmm.api import InputError, read_yaml

ARTEFACTS = ("am_pyramid", "am_recess", "am_sphere", "am_pillars")
MATERIALS = ("nylon12", "abs", "ti6al4v")
CONDITIONS = ("off", "on")
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
#: inspect.align's settings; the inlier distance is wider than its default (1 % of the
#: part's size, ~0.6 mm) because AM parts and photogrammetry deviate by up to 0.37 mm
#: (table 6.1, nylon without speckle; the virtual nylon's clouds ~0.4-0.6 mm) and the
#: alignment counts as a match only while that spread is within a quarter of it
ALIGN = {"method": "auto", "inlier_distance": 2.5}


def _cond(v: Any) -> Any:
    """YAML 1.1 reads a bare on / off as true / false."""
    return {True: "on", False: "off"}.get(v, v) if isinstance(v, bool) else v


def _names(value: Any, known: tuple[str, ...], what: str, where: str) -> list:
    items = value if isinstance(value, list) else [value]
    if what == "condition":
        items = [_cond(v) for v in items]
    for v in items:
        name = v.get("name") if isinstance(v, dict) else v
        if name not in known:
            raise InputError(f"{where}: unknown {what} {name!r} (use {', '.join(known)})")
    return items


def load(path: str | Path) -> dict[str, Any]:
    """The study as a dict with resolved paths and defaults; InputError on bad input."""
    p = Path(path)
    where = p.name
    if not p.is_file():
        raise InputError(f"{path}: no such study file")
    d = read_yaml(p)
    if not isinstance(d, dict):
        raise InputError(f"{where}: expected a mapping (artefacts, materials, capture ...)")
    arts = []
    for a in _names(d.get("artefacts") or list(ARTEFACTS), ARTEFACTS, "artefact", where):
        if isinstance(a, dict):
            arts.append({"name": a["name"], "sizes": dict(a.get("sizes") or {})})
        else:
            arts.append({"name": a, "sizes": {}})
    mats = [str(m) for m in _names(d.get("materials") or list(MATERIALS), MATERIALS, "material", where)]
    conds = [str(c) for c in _names(d.get("conditions") or list(CONDITIONS), CONDITIONS, "condition", where)]
    cap = d.get("capture") or {"simulated": {}}
    if not isinstance(cap, dict) or not ({"simulated", "images"} & set(cap)):
        raise InputError(f"{where}: capture must give 'simulated' settings or 'images' folders")
    study: dict[str, Any] = {
        "file": str(p.resolve()),
        "name": str(d.get("name") or p.stem),
        "work": str((p.parent / str(d.get("work") or f"{p.stem}.work")).resolve()),
        "artefacts": arts,
        "materials": mats,
        "conditions": conds,
        "reconstruct": {**RECONSTRUCT, **(d.get("reconstruct") or {})},
        "align": {**ALIGN, **(d.get("align") or {})},
        "coverage": {"distance": 0.0, "samples": 100000, **(d.get("coverage") or {})},
    }
    if "simulated" in cap:
        sim = {**SIMULATED, **(cap.get("simulated") or {})}
        unknown = set(sim) - set(SIMULATED)
        if unknown:
            raise InputError(f"{where}: unknown simulated setting {sorted(unknown)[0]!r}")
        study["simulated"] = sim
        study["images"] = None
    else:
        folders: dict[str, dict[str, Any]] = {}
        for e in cap["images"] or []:
            e = {**e, "condition": _cond(e.get("condition"))}
            key = case_id(e.get("artefact"), e.get("material"), e.get("condition"))
            _names(e.get("artefact"), ARTEFACTS, "artefact", where)
            _names(e.get("material"), MATERIALS, "material", where)
            _names(e.get("condition"), CONDITIONS, "condition", where)
            folder = (p.parent / str(e.get("folder", ""))).resolve()
            if not folder.is_dir():
                raise InputError(f"{where}: image folder {e.get('folder')!r} of {key} does not exist")
            folders[key] = {"folder": str(folder), "pairs": e.get("pairs")}
        study["simulated"] = None
        study["images"] = folders
    study["cases"] = [
        {"id": case_id(a["name"], m, c), "artefact": a["name"], "sizes": a["sizes"], "material": m, "condition": c}
        for a in arts
        for m in mats
        for c in conds
    ]
    if study["images"] is not None:
        missing = [c["id"] for c in study["cases"] if c["id"] not in study["images"]]
        if missing:
            raise InputError(f"{where}: no image folder for case {missing[0]}")
    return study


def case_id(artefact: Any, material: Any, condition: Any) -> str:
    return f"{artefact}-{material}-{condition}"


def case_key(study: dict[str, Any], case: dict[str, Any]) -> str:
    """A hash of everything a case's result depends on: a finished case is reused only
    when it matches (a changed setting recomputes it)."""
    src = study["simulated"] if study["simulated"] is not None else study["images"][case["id"]]
    blob = json.dumps([case, src, study["reconstruct"], study["align"], study["coverage"]], sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]
