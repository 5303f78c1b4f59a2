"""The stereo system of a Monte Carlo study from the plugin's declared parameters.

``uncertainty.montecarlo`` declares the system field by field in its manifest (focal
lengths, pixel pitch, image size, radial distortion, baseline and the angle between
the optical axes, the grid, each influence factor's standard uncertainty and dof), with
the system of thesis ch. 3.3.1 and the uncertainties of its table 3.2 as defaults. The
GUI form, the CLI options and the JSON check come from that one declaration; this
module turns the values into the document :func:`.montecarlo.setup_from_dict` reads
(the form of ``resources/uncertainty/stereo_system.yaml``). Units as declared: the
pitch in µm, rotations in µrad and translations in µm (as table 3.2 states them),
converted to mm and rad here.

A ``spec`` (a YAML file or mapping) given to the plugin describes the whole system and
these parameters are then not used.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from camcmm.api import InputError

#: The declared parameters that describe the system (plugin.yaml); the rest run the study.
NAMES = (
    "focal_length",
    "pixel_pitch",
    "image_size",
    "k1",
    "k2",
    "baseline",
    "axes_angle",
    "grid_size",
    "grid_points",
    "u_feature_location",
    "u_focal_length",
    "u_rotation",
    "u_translation",
    "u_radial_distortion",
    "dof_focal_length",
    "dof_rotation",
    "dof_translation",
    "dof_radial_distortion",
)


def _whole(values: Any, name: str) -> list[int]:
    out = []
    for x in values:
        if not (isinstance(x, (int, float)) and math.isfinite(x) and x == int(x)):
            raise InputError(f"parameter {name!r}: {x!r} is not a whole number")
        out.append(int(x))
    return out


def system_document(values: Mapping[str, Any]) -> dict[str, Any]:
    """The Monte Carlo input document of the declared values (missing: one line)."""
    missing = [n for n in NAMES if values.get(n) is None]
    if missing:
        raise InputError(f"parameter {missing[0]!r}: missing (the stereo system needs every field, or a spec file)")
    v = dict(values)
    pitch_mm = float(v["pixel_pitch"]) / 1000.0
    size = _whole(v["image_size"], "image_size")
    cameras = [
        {
            "focal_length": float(v["focal_length"][i]),
            "pixel_pitch": pitch_mm,
            "image_size": size,
            "k": [float(v["k1"][i]), float(v["k2"][i]), 0.0],
        }
        for i in range(2)
    ]
    return {
        "unit": "um",
        "cameras": cameras,
        "stereo": {"baseline": float(v["baseline"]), "angle_deg": float(v["axes_angle"])},
        "grid": {"size": [float(x) for x in v["grid_size"]], "n": _whole(v["grid_points"], "grid_points")},
        "uncertainties": {
            "feature_location": float(v["u_feature_location"]),
            "focal_length": [float(x) for x in v["u_focal_length"]],
            "rotation": [float(x) / 1e6 for x in v["u_rotation"]],  # µrad -> rad (x / 1e6: exactly 1.52e-4)
            "translation": [float(x) / 1000.0 for x in v["u_translation"]],  # µm -> mm
            "radial_distortion": [float(x) for x in v["u_radial_distortion"]] + [0.0],
        },
        "dof": {
            "focal_length": float(v["dof_focal_length"]),
            "rotation": float(v["dof_rotation"]),
            "translation": float(v["dof_translation"]),
            "radial_distortion": float(v["dof_radial_distortion"]),
        },
    }
