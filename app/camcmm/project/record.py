"""Record a finished plugin run in a project: its clouds, meshes and height maps as files,
the run (outputs, provenance) as a result row — the one way `camcmm run --project` and the
plugins' own commands (`camcmm photogrammetry reconstruct --project`, `camcmm fuse csi
--project`) store what they computed.

Called only after the run succeeded, so a failed run leaves the project as it was; each
file is durable before the row that names it (see store.py).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .store import Project


def geometry_outputs(result: Any) -> list[tuple[str, Any]]:
    """The outputs of a run that are geometry objects (clouds, meshes, height maps), by name."""
    return [
        (k, v)
        for k, v in result.outputs.items()
        if hasattr(v, "n_points") or hasattr(v, "n_faces") or type(v).__name__ == "HeightMap"
    ]


def record_result(project_dir: str | Path, result: Any) -> int:
    """Store ``result`` (a :class:`camcmm.host.RunResult`) in the project at ``project_dir``
    (created if missing) and return the new result's id."""
    with Project.open_or_create(project_dir) as project:
        files = {k: project.add_object(v, f"{result.plugin_id}-{k}") for k, v in geometry_outputs(result)}
        return int(project.add_result(result, files=files))
