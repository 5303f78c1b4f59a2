"""CAD nominals: STEP and IGES B-reps read with OpenCascade (``cadquery-ocp-novtk``), their
faces as features' nominals, and exact distances to their surfaces.

    read_cad(path, deflection=None) -> CadModel          (camcmm.api.read_cad)
    CadModel.faces -> [CadFace]; .mesh; .triangle_face; .distance(points); .sample(face, n, seed)

One topic per module: :mod:`.read` (files -> shape in mm), :mod:`.faces` (types,
parameters, outward side), :mod:`.tessellate` (BRepMesh -> one mesh), :mod:`.distance`
(closest triangle -> closed-form projection -> OpenCascade), :mod:`.model` (CadModel).
OCP is imported only when a CAD file is read, so the core imports without it.
"""

from __future__ import annotations

from .faces import ANALYTIC, TYPES, CadFace
from .model import CadModel, read_cad
from .read import EXTENSIONS

__all__ = ["ANALYTIC", "EXTENSIONS", "TYPES", "CadFace", "CadModel", "read_cad"]
