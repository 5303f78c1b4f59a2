"""The artefact catalogue and the plan's artefact entries: the shipped
``resources/artefacts.yaml``, the fields the setup form shows per artefact kind, and the
conversion between an Artefact dict (catalogue or project store) and a plan entry."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ...errors import InputError
from ...yamlfile import read_yaml
from .values import log

#: The plan fields of each artefact kind (docs/standards.md), as the setup form shows
#: them: (key, label, unit, kind of value). Unknown kinds fall back to the catalogue's
#: own numbers.
ARTEFACT_FIELDS: dict[str, list[tuple[str, str, str, str]]] = {
    "sphere": [("diameter", "Diameter (calibrated)", "mm", "number"),
               ("uncertainty", "Its uncertainty U", "mm", "number"), ("k", "Coverage factor k", "", "number")],
    "ball_bar": [("length", "Length (calibrated)", "mm", "number"),
                 ("uncertainty", "Its uncertainty U", "mm", "number"), ("k", "Coverage factor k", "", "number"),
                 ("sphere_diameter", "Sphere diameter", "mm", "number")],
    "flat": [("length", "Length", "mm", "number"), ("width", "Width", "mm", "number"),
             ("flatness", "Flatness (calibrated)", "mm", "number"),
             ("flatness_uncertainty", "Its uncertainty U", "mm", "number")],
    "ball_plate": [("sphere_diameter", "Sphere diameter", "mm", "number"),
                   ("lengths", "Lengths L1, L2, L3 (calibrated)", "mm", "vector"),
                   ("uncertainty", "Their uncertainty U", "mm", "number"), ("k", "Coverage factor k", "", "number")],
}


def resources_dir() -> Path:
    """The repository's ``resources/`` folder (artefact catalogue, UI assets)."""
    import camcmm

    return Path(camcmm.__file__).resolve().parents[2] / "resources"


def load_catalogue(path: str | Path | None = None) -> list[dict[str, Any]]:
    """The shipped artefact catalogue (``resources/artefacts.yaml``) as Artefact dicts;
    an empty list (logged) when it is missing or unreadable."""
    path = Path(path) if path is not None else resources_dir() / "artefacts.yaml"
    try:
        doc = read_yaml(path) or {}
    except InputError as exc:
        log.warning("artefact catalogue %s: %s", path, exc)
        return []
    out = []
    for a in doc.get("artefacts") or []:
        if isinstance(a, dict) and a.get("id") and a.get("kind"):
            out.append({"id": str(a["id"]), "kind": str(a["kind"]), "name": str(a.get("name") or a["id"]),
                        "nominal": dict(a.get("nominal") or {}), "certificates": dict(a.get("certificates") or {}),
                        "source": "catalogue"})
    return out


def artefact_plan_fields(artefact: dict[str, Any]) -> dict[str, Any]:
    """An Artefact dict (catalogue or project) as the plan's artefact entry: nominal
    values, each certificate's value under its name, the first certificate's U and k as
    ``uncertainty``/``k`` and every certificate's U as ``<name>_uncertainty``."""
    out: dict[str, Any] = {k: v for k, v in (artefact.get("nominal") or {}).items() if k not in ("id", "name")}
    certs = artefact.get("certificates") or {}
    for i, (name, c) in enumerate(certs.items()):
        if not isinstance(c, dict) or "value" not in c:
            continue
        out[name] = c["value"]
        u = c.get("uncertainty")
        if u is not None:
            out[f"{name}_uncertainty"] = u
        if i == 0:
            if u is not None:
                out["uncertainty"] = u
            out["k"] = c.get("k", 2)
    return out


def _u_key(kind: str, key: str) -> str:
    """The plan key of a calibrated value's uncertainty (docs/standards.md)."""
    return "uncertainty" if (kind, key) in (("sphere", "diameter"), ("ball_bar", "length")) else f"{key}_uncertainty"


def plan_fields_to_artefact(kind: str, fields: dict[str, Any], aid: str, name: str) -> dict[str, Any]:
    """The inverse for the project store: the plan's artefact entry as an Artefact dict
    (values with an uncertainty, and the calibrated main value, as certificates; the
    rest nominal)."""
    k = float(fields.get("k") or 2.0)
    certs: dict[str, Any] = {}
    nominal: dict[str, Any] = {}
    main = {"sphere": "diameter", "ball_bar": "length", "flat": "flatness"}.get(kind)
    for key, v in fields.items():
        if key in ("k", "uncertainty") or key.endswith("_uncertainty") or v is None:
            continue
        if kind == "ball_plate" and key == "lengths" and isinstance(v, list):
            nominal[key] = v
            for i, x in enumerate(v):
                certs[f"length_{i + 1}"] = {"value": float(x), "uncertainty": float(fields.get("uncertainty") or 0.0),
                                            "k": k}
        elif key == main or _u_key(kind, key) in fields:
            certs[key] = {"value": float(v), "uncertainty": float(fields.get(_u_key(kind, key)) or 0.0), "k": k}
        else:
            nominal[key] = v
    return {"id": aid, "kind": kind, "name": name, "nominal": nominal, "certificates": certs}
