"""The artefact catalogue and the plan's artefact entries: the shipped
``resources/artefacts.yaml`` and the conversion between an Artefact dict (catalogue or
project store) and a plan entry, led by the fields the standard declares
(:class:`camcmm.standard.ArtefactKind`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from camcmm.assets import resources_dir
from camcmm.errors import InputError
from camcmm.standard import ArtefactKind
from camcmm.yamlfile import read_yaml

from .values import log


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
            out.append(
                {
                    "id": str(a["id"]),
                    "kind": str(a["kind"]),
                    "name": str(a.get("name") or a["id"]),
                    "nominal": dict(a.get("nominal") or {}),
                    "certificates": dict(a.get("certificates") or {}),
                    "source": "catalogue",
                }
            )
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


def plan_fields_to_artefact(
    kind: str, fields: dict[str, Any], aid: str, name: str, declared: ArtefactKind | None = None
) -> dict[str, Any]:
    """The inverse for the project store: the plan's artefact entry as an Artefact dict.

    A value the standard declares with a ``certificate`` becomes that certificate (a
    vector one certificate per element), with the U its ``uncertainty`` key holds; an
    undeclared value with a ``<key>_uncertainty`` beside it too; the rest is nominal."""
    k = float(fields.get("k") or 2.0)
    certs: dict[str, Any] = {}
    nominal: dict[str, Any] = {}
    uncertainty_keys = {f.uncertainty for f in (declared.fields if declared else ()) if f.uncertainty}
    for key, v in fields.items():
        if key == "k" or key in uncertainty_keys or key.endswith("_uncertainty") or v is None:
            continue
        spec = declared.field(key) if declared is not None else None
        u_key = spec.uncertainty if spec is not None and spec.uncertainty else f"{key}_uncertainty"
        u = float(fields.get(u_key) or 0.0)
        if spec is not None and spec.certificate and isinstance(v, list):
            nominal[key] = v
            for i, x in enumerate(v):
                certs[spec.certificate.format(i=i + 1)] = {"value": float(x), "uncertainty": u, "k": k}
        elif (spec is not None and spec.certificate) or u_key in fields:
            certs[(spec.certificate if spec is not None and spec.certificate else key)] = {
                "value": float(v),
                "uncertainty": u,
                "k": k,
            }
        elif key != "uncertainty":
            nominal[key] = v
    return {"id": aid, "kind": kind, "name": name, "nominal": nominal, "certificates": certs}
