"""Where the fitted points come from, for ``camcmm fit`` and the fit plugins alike.

* :func:`as_cloud`: a point cloud as it is; a triangle mesh becomes the point cloud of
  its vertices, with a note to pass on as a warning. Fitting a mesh's vertices is
  legitimate (a scan exported as STL, a CAD nominal whose vertices lie on the nominal
  surface), but it is not what the mesh's surface says: the faces are ignored and every
  vertex counts the same however much area it stands for, so a mesh tessellated finer
  in one region pulls the fit there.
* :func:`naming`: errors raised while ``camcmm fit`` fits a file name it,
  ``same.xyz: sphere fit: all 50 points coincide``, so that a batch of files tells which
  one failed. (The plugins leave naming to their callers, which know the context.)
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from camcmm.api import CamcmmError, InputError, PointCloud, TriangleMesh

#: The names camcmm gives clouds and meshes made in memory: they name no file, so they
#: are not put in front of an error.
DEFAULT_NAMES = ("", "cloud", "mesh")


def source_name(obj: Any) -> str:
    """The file (or cloud) name of ``obj`` to put in messages, "" when it has none."""
    name = getattr(obj, "name", "")
    return "" if not isinstance(name, str) or name in DEFAULT_NAMES else name


def as_cloud(obj: Any, element: str, name: str = "") -> tuple[Any, str | None]:
    """``obj`` as something the fits take — a PointCloud, or the (N, d) array or nested
    list given — and a note (one line, for a warning) when it had to be converted.

    A TriangleMesh becomes the PointCloud of its vertices (mm, same name and unit);
    anything else without points (an image...) raises InputError naming ``name`` or the
    object's own name.
    """
    name = name or source_name(obj)
    if isinstance(obj, TriangleMesh):
        cloud = PointCloud(obj.vertices, normals=obj.vertex_normals, name=obj.name, source_unit=obj.source_unit)
        note = (
            f"{name or 'the input'} is a triangle mesh: the {element} fit uses its {len(obj.vertices)} "
            f"vertices; its faces are ignored and each vertex counts the same whatever the area around it"
        )
        return cloud, note
    if hasattr(obj, "points") or isinstance(obj, (np.ndarray, list, tuple)):
        return obj, None
    raise InputError(f"{name or 'the input'}: not a point cloud or a mesh (it holds {type(obj).__name__})")


@contextmanager
def naming(name: str) -> Iterator[None]:
    """Put ``name: `` in front of a CamcmmError raised inside (same class, one line),
    unless the message names it already."""
    try:
        yield
    except CamcmmError as exc:
        msg = str(exc)
        if not name or msg.startswith(name) or name in msg.split(":", 1)[0]:
            raise
        try:
            renamed = type(exc)(f"{name}: {msg}")
        except TypeError:  # a subclass with its own constructor: keep it as it is
            raise exc from None
        raise renamed from None
