"""The public plugin API: everything a plugin — built-in or a lab's — may import.

Built-in plugins import from ``camcmm.api`` only, never from other camcmm modules or
from each other; a test checks this. Importing it loads neither trame, VTK nor Open3D.

The names are grouped by topic in ``__all__``. Which of them are stable (kept, with the same
meaning, for every 1.x of :data:`API_VERSION`) is listed in docs/api.md, which a test
holds equal to ``__all__``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

# The one number rule (digits from the uncertainty, µm for deviations, no exponents): plugins
# write what a person reads with it, as ``from camcmm.api import numbers`` (provisional, API 1.7).
from . import numbers as numbers
from .cad import CadFace, CadModel, read_cad
from .cli.options import add_declared_options, declared_values
from .confine import PathRefused, document_path
from .confine import check as checked_path
from .conformity import combine, guarded_verdict, simple_verdict, verdict_words
from .devices import (
    Camera,
    Device,
    DeviceDisconnected,
    DeviceError,
    DeviceMonitor,
    DeviceStatus,
    DeviceTimeout,
    Events,
    Stage,
    port_errors,
    utc_iso,
)
from .devices import param as device_param
from .errors import CamcmmError, GeometryError, InputError, ParameterError, PluginError
from .host import Cancelled, RunContext, RunResult, default_host
from .io import check_calibration, read, read_calibration, read_stated, unit_decision, write, write_calibration
from .jsonable import to_jsonable, utc_now
from .limits import check_budget, check_count, check_disk, human_bytes, memory_limit
from .meshdistance import MeshDistance, spatial_order
from .model import Artefact, CameraModel, Certificate, HeightMap, Image, PointCloud, TriangleMesh
from .params import Param
from .project.record import record_result
from .project.select import project_values
from .report import Report, charts
from .standard import (
    ArtefactField,
    ArtefactKind,
    ParameterResult,
    PositionEvaluation,
    PositionSpec,
    QualityParameter,
    Standard,
    StandardDeclaration,
    TestDeclaration,
    TestResult,
)
from .units import UnitDecision, decide_unit, suggest_unit, to_mm_factor
from .yamlfile import YamlError, load_yaml, read_yaml

# -- the version of this API ------------------------------------------------------------
#: Major.minor of the plugin API. The major changes when a stable name is removed or
#: changes meaning; the minor when names are added. Plugins may check it at import.
API_VERSION = "1.7"


def get_algorithm(plugin_id: str) -> Callable[..., dict[str, Any]]:
    """An installed plugin as a callable ``f(**inputs_and_params) -> dict``.

    Inside a running plugin prefer ``ctx.algorithm(plugin_id)``, which also passes
    warnings on to the caller's result.
    """
    return default_host().algorithm(plugin_id)


def declared_value(plugin_id: str, name: str, value: Any, flag: str | None = None) -> Any:
    """``value`` coerced and checked by parameter ``name`` of ``plugin_id``'s declaration
    (plugin.yaml), for commands that call a plugin's numerics directly rather than through
    the host: one rule for the CLI, JSON runs and the GUI. None stays None (not given).
    A refusal is a ParameterError naming the option, e.g. ``--subpix-window: parameter
    'subpix_window' = 0 is below its minimum 1 px``; a plugin without that parameter is
    an InputError (``--nominal-radius: fit.line has no nominal radius``)."""
    if value is None:
        return None
    flag = flag or "--" + name.replace("_", "-")
    param = next((p for p in default_host().get(plugin_id).parameters if p.name == name), None)
    if param is None:
        raise InputError(f"{flag}: {plugin_id} has no {name.replace('_', ' ')}")
    try:
        return param.coerce(value)
    except ParameterError as exc:
        raise ParameterError(f"{flag}: {exc}") from None


__all__ = [
    # version
    "API_VERSION",
    # errors
    "CamcmmError",
    "GeometryError",
    "InputError",
    "ParameterError",
    "PathRefused",
    "PluginError",
    "YamlError",
    # data model
    "Artefact",
    "CameraModel",
    "Certificate",
    "HeightMap",
    "Image",
    "PointCloud",
    "TriangleMesh",
    # CAD nominals and distances to meshes
    "CadFace",
    "CadModel",
    "MeshDistance",
    "read_cad",
    "spatial_order",
    # files
    "check_calibration",
    "load_yaml",
    "read",
    "read_calibration",
    "read_yaml",
    "write",
    "write_calibration",
    # paths
    "checked_path",
    "document_path",
    # parameters and units
    "Param",
    "add_declared_options",
    "declared_value",
    "declared_values",
    "project_values",
    "record_result",
    "to_mm_factor",
    "UnitDecision",
    "decide_unit",
    "read_stated",
    "suggest_unit",
    "unit_decision",
    # running plugins
    "Cancelled",
    "RunContext",
    "RunResult",
    "default_host",
    "get_algorithm",
    # conformity
    "combine",
    "guarded_verdict",
    "simple_verdict",
    "verdict_words",
    # numbers as a person reads them
    "numbers",
    # reports
    "Report",
    "charts",
    # standards
    "ArtefactField",
    "ArtefactKind",
    "ParameterResult",
    "PositionEvaluation",
    "PositionSpec",
    "QualityParameter",
    "Standard",
    "StandardDeclaration",
    "TestDeclaration",
    "TestResult",
    # resource limits
    "check_budget",
    "check_count",
    "check_disk",
    "human_bytes",
    "memory_limit",
    # devices
    "Camera",
    "Device",
    "DeviceDisconnected",
    "DeviceError",
    "DeviceMonitor",
    "DeviceStatus",
    "DeviceTimeout",
    "Events",
    "Stage",
    "device_param",
    "port_errors",
    "utc_iso",
    # JSON and time
    "to_jsonable",
    "utc_now",
]
