"""Picking in the "Compare with CAD" scene: which point or surface is under the mouse.

Functions of a VTK renderer and numpy arrays (mm; display pixels, x right, y up). VTK's
point picker takes the point nearest the pick ray, which may lie behind the surface the
operator sees; so a point is picked here from the camera's
projection and the last frame's depth buffer (a mesh is still picked by VTK's cell
picker). No trame, no state: testable with a bare off-screen renderer.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def world_to_display(renderer: Any, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Display coordinates (x right, y up, pixels of the render window) of ``points``,
    their distance in front of the camera (mm, along its view direction) and whether
    they are in front of it — the camera's composite projection, vectorised."""
    P = np.asarray(points, dtype=float)
    W, H = renderer.GetSize()
    W, H = max(int(W), 1), max(int(H), 1)
    ox, oy = renderer.GetOrigin()
    cam = renderer.GetActiveCamera()
    M = cam.GetCompositeProjectionTransformMatrix(W / H, -1, 1)
    A = np.array([[M.GetElement(i, j) for j in range(4)] for i in range(4)])
    h = P @ A[:3, :3].T + A[:3, 3]
    w = P @ A[3, :3] + A[3, 3]
    ok = w > 1e-12
    ws = np.where(ok, w, 1.0)
    ndc = h / ws[:, None]
    xy = np.column_stack([ox + (ndc[:, 0] + 1.0) * 0.5 * W, oy + (ndc[:, 1] + 1.0) * 0.5 * H])
    direction = np.asarray(cam.GetDirectionOfProjection(), dtype=float)
    dist = (P - np.asarray(cam.GetPosition(), dtype=float)) @ direction
    ok &= np.abs(ndc[:, 2]) <= 1.0
    return xy, dist, ok


def surface_distance(renderer: Any, x: float, y: float, r: int = 2) -> float | None:
    """The distance in front of the camera (mm) of the nearest thing drawn within ``r``
    pixels of display position (x, y), from the last frame's depth buffer; None where
    only the background was drawn (or nothing was rendered yet)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkFloatArray

    rw = renderer.GetRenderWindow()
    if rw is None:
        return None
    W, H = rw.GetSize()
    xi, yi = int(round(x)), int(round(y))
    x0, x1 = max(xi - r, 0), min(xi + r, W - 1)
    y0, y1 = max(yi - r, 0), min(yi + r, H - 1)
    if x1 < x0 or y1 < y0:
        return None
    arr = vtkFloatArray()
    if not rw.GetZbufferData(x0, y0, x1, y1, arr):
        return None
    z = vtk_to_numpy(arr)
    z = z[(z > 0.0) & (z < 1.0)]
    if not z.size:
        return None
    renderer.SetDisplayPoint(float(x), float(y), float(z.min()))
    renderer.DisplayToWorld()
    w = np.asarray(renderer.GetWorldPoint(), dtype=float)
    if abs(w[3]) < 1e-300:
        return None
    cam = renderer.GetActiveCamera()
    return float((w[:3] / w[3] - np.asarray(cam.GetPosition())) @ np.asarray(cam.GetDirectionOfProjection()))


def pick_point(
    renderer: Any, points: np.ndarray, x: float, y: float, radii: tuple[float, ...] = (7, 14), zbuffer: bool = True
) -> int | None:
    """The index of the point drawn at display position (x, y), or None.

    Candidates are the points projected within a few pixels of the click (the radius
    widened once if there are none). The depth drawn there (the last frame's depth
    buffer) tells how far the visible surface is; without one, the front-most
    candidate does. Of the candidates that far (within the depth a few pixels span
    there), the one nearest to the click on screen is taken — not a point behind the
    surface that shows through a gap.
    """
    P = np.asarray(points, dtype=float)
    if not len(P):
        return None
    xy, dist, ok = world_to_display(renderer, P)
    d2 = (xy[:, 0] - x) ** 2 + (xy[:, 1] - y) ** 2
    cam = renderer.GetActiveCamera()
    H = max(renderer.GetSize()[1], 1)
    surface = surface_distance(renderer, x, y) if zbuffer else None
    for r in radii:
        cand = np.nonzero(ok & (d2 <= r * r))[0]
        if not cand.size:
            continue
        front = float(dist[cand].min())
        if surface is not None and surface > front:
            front = surface
        if cam.GetParallelProjection():
            px = 2.0 * cam.GetParallelScale() / H
        else:
            px = 2.0 * max(front, 1e-9) * math.tan(math.radians(cam.GetViewAngle()) / 2.0) / H
        slab = 2.0 * r * px
        near = cand[np.abs(dist[cand] - front) <= slab] if surface is not None else cand[dist[cand] <= front + slab]
        if not near.size:
            near = cand[dist[cand] <= front + slab]
        if not near.size:
            continue
        return int(near[np.argmin(d2[near])])
    return None


def pick_surface(renderer: Any, actor: Any, x: float, y: float) -> np.ndarray | None:
    """The point of ``actor``'s surface under display position (x, y) (vtkCellPicker),
    or None."""
    hit = pick_cell(renderer, actor, x, y)
    return None if hit is None else hit[0]


def pick_cell(renderer: Any, actor: Any, x: float, y: float) -> tuple[np.ndarray, int] | None:
    """The point of ``actor``'s surface under display position (x, y) and the index of
    the cell (triangle) it lies on (vtkCellPicker), or None: a CAD face is found from its
    triangle."""
    from vtkmodules.vtkRenderingCore import vtkCellPicker

    picker = vtkCellPicker()
    picker.SetTolerance(0.0005)
    picker.PickFromListOn()
    picker.AddPickList(actor)
    if picker.Pick(float(x), float(y), 0.0, renderer) and picker.GetCellId() >= 0:
        return np.asarray(picker.GetPickPosition(), dtype=float), int(picker.GetCellId())
    return None
