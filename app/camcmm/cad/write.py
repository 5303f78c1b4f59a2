"""Writing exact nominals as STEP: the analytic primitives camcmm itself needs (the demo's
ball), made with OpenCascade and written by ``STEPControl_Writer`` (AP214, mm)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import InputError


def write_step(shape: Any, path: str | Path) -> Path:
    """Write an OCP shape to ``path`` as STEP in mm; InputError naming the file on failure."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.Message import Message, Message_Gravity
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    p = Path(path)
    for printer in Message.DefaultMessenger_s().Printers():  # the writer's statistics are not for stdout
        printer.SetTraceLevel(Message_Gravity.Message_Fail)
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    writer = STEPControl_Writer()
    if writer.Transfer(shape, STEPControl_AsIs) != IFSelect_RetDone or writer.Write(str(p)) != IFSelect_RetDone:
        raise InputError(f"{p.name}: OpenCascade could not write the STEP file")
    return p


def sphere_step(path: str | Path, radius: float, centre: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Path:
    """A solid ball of ``radius`` mm about ``centre`` written as STEP to ``path``."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeSphere
    from OCP.gp import gp_Pnt

    if not radius > 0:
        raise InputError(f"sphere radius = {radius} mm must be positive")
    return write_step(BRepPrimAPI_MakeSphere(gp_Pnt(*map(float, centre)), float(radius)).Shape(), path)
