"""Files camcmm ships beside its code: the artefact catalogue, uncertainty examples, UI assets.

They live in the repository's top-level ``resources/`` folder and are installed as the
package data ``camcmm/resources`` (see ``pyproject.toml``), so an installed wheel finds
them as well as a source checkout does.
"""

from __future__ import annotations

from pathlib import Path


def resources_dir() -> Path:
    """The folder of camcmm's shipped resources (``artefacts.yaml``, ``uncertainty/`` …)."""
    import importlib.resources

    try:
        installed = Path(str(importlib.resources.files("camcmm") / "resources"))
    except (ModuleNotFoundError, TypeError):  # camcmm not importable as a package: the checkout
        installed = None
    if installed is not None and installed.is_dir():
        return installed
    # an editable install or a source checkout: the repository's own folder
    return Path(__file__).resolve().parents[2] / "resources"


__all__ = ["resources_dir"]
