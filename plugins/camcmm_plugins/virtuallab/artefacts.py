"""Scenes of the acceptance-test artefacts, built from primitives (mm).

Each builder returns ``(scene, truth)``: the primitives (measured ones carry points,
the others — stems, posts, plates — only occlude) and the true geometry.

* sphere: a sphere on a stem (the stem hides the underside, as on a real holder);
* ball bar: two spheres joined by a bar (bar points are part of the cloud);
* flat: the measured face of a flat;
* ball plate: three spheres on posts at the corners of a triangle with the three
  calibrated lengths (thesis fig. 4.3: L1 = |c1 c2|, L2 = |c2 c3|, L3 = |c3 c1|);
* sphere with scale spheres: the probing sphere with two ball-plate spheres beside it,
  as the thesis scaled its part-3 sphere reconstructions (ch. 4.5.1).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .scene import Cylinder, Rectangle, Sphere, _unit, orthonormal

DOWN = np.array([0.0, 0.0, -1.0])


def _sphere_truth(s: Sphere) -> dict[str, Any]:
    return {"label": s.label, "center": s.center.tolist(), "diameter": 2 * s.radius}


def sphere(center, diameter: float, stem: bool = True) -> tuple[list, dict]:
    r = diameter / 2
    c = np.asarray(center, float)
    scene: list = [Sphere(c, r, "sphere")]
    if stem:  # a holder from below: hides the bottom cap
        scene.append(Cylinder(c + DOWN * 0.8 * r, c + DOWN * 2.5 * r, 0.3 * r, "stem", measured=False))
    return scene, {"kind": "sphere", "spheres": [_sphere_truth(scene[0])], "diameter": diameter, "center": c.tolist()}


def ball_bar(center, direction, length: float, sphere_diameter: float, bar: bool = True) -> tuple[list, dict]:
    r = sphere_diameter / 2
    a = _unit(direction)
    c = np.asarray(center, float)
    s1, s2 = Sphere(c - a * length / 2, r, "sphere 1"), Sphere(c + a * length / 2, r, "sphere 2")
    scene: list = [s1, s2]
    if bar and length > 2 * r:
        rb = 0.2 * r  # bar radius; it meets the spheres inside their surface
        scene.append(Cylinder(s1.center + a * np.sqrt(r**2 - rb**2), s2.center - a * np.sqrt(r**2 - rb**2), rb, "bar"))
    return scene, {
        "kind": "ball_bar",
        "spheres": [_sphere_truth(s1), _sphere_truth(s2)],
        "length": length,
        "sphere_diameter": sphere_diameter,
        "center": c.tolist(),
        "direction": a.tolist(),
    }


def flat(center, axis, normal, length: float, width: float) -> tuple[list, dict]:
    rect = Rectangle(np.asarray(center, float), axis, normal, length, width, "flat")
    return [rect], {
        "kind": "flat",
        "center": rect.center.tolist(),
        "axis": rect.axis.tolist(),
        "normal": rect.normal.tolist(),
        "length": length,
        "width": width,
    }


def triangle(lengths) -> np.ndarray:
    """Corners (3, 2) of a triangle with |c1c2| = L1, |c2c3| = L2, |c3c1| = L3, centred."""
    l1, l2, l3 = (float(x) for x in lengths)
    x3 = (l1**2 + l3**2 - l2**2) / (2 * l1)
    y3 = np.sqrt(max(l3**2 - x3**2, 0.0))
    if not y3 > 0:
        raise ValueError(f"lengths {lengths} do not form a triangle")
    pts = np.array([[0.0, 0.0], [l1, 0.0], [x3, y3]])
    return pts - pts.mean(axis=0)


def ball_plate(
    center, lengths, sphere_diameter: float, rotation: float = 0.0, tilt: float = 0.0, plate: bool = True
) -> tuple[list, dict]:
    """Three spheres on posts above a plate; ``rotation`` (deg) about the plate normal,
    then ``tilt`` (deg) of the normal from +z about the x axis."""
    r = sphere_diameter / 2
    c = np.asarray(center, float)
    rot = np.radians(rotation)
    t = np.radians(tilt)
    normal = np.array([0.0, -np.sin(t), np.cos(t)])
    u0, v0 = np.array([1.0, 0, 0]), np.cross(normal, [1.0, 0, 0])
    u = np.cos(rot) * u0 + np.sin(rot) * v0
    v = np.cross(normal, u)
    corners = triangle(lengths)
    height = 1.6 * r  # sphere centres above the plate
    spheres = [Sphere(c + p[0] * u + p[1] * v + height * normal, r, f"sphere {i + 1}") for i, p in enumerate(corners)]
    scene: list = list(spheres)
    if plate:
        span = np.ptp(corners, axis=0)
        scene.append(Rectangle(c, u, normal, span[0] + 4 * r, span[1] + 4 * r, "plate", measured=False))
        scene += [
            Cylinder(s.center - normal * 0.8 * r, s.center - normal * height, 0.3 * r, "post", measured=False)
            for s in spheres
        ]
    return scene, {
        "kind": "ball_plate",
        "spheres": [_sphere_truth(s) for s in spheres],
        "lengths": [float(x) for x in lengths],
        "sphere_diameter": sphere_diameter,
        "center": c.tolist(),
        "normal": normal.tolist(),
    }


def sphere_with_scale(center, diameter: float, scale_diameter: float) -> tuple[list, dict]:
    """The probing sphere plus two scale spheres (ball-plate spheres) beside it, lower."""
    scene, truth = sphere(center, diameter)
    c = np.asarray(center, float)
    R, r = diameter / 2, scale_diameter / 2
    gap = R + r + 0.4 * diameter
    for i, off in enumerate(([gap, 0.0, r - R], [0.0, gap, r - R])):
        s = Sphere(c + off, r, f"scale sphere {i + 1}")
        scene.append(s)
        scene.append(Cylinder(s.center + DOWN * 0.8 * r, s.center + DOWN * 3 * r, 0.3 * r, "post", measured=False))
        truth["spheres"].append(_sphere_truth(s))
    truth["kind"] = "sphere_with_scale"
    truth["scale_diameter"] = scale_diameter
    return scene, truth


def axes_from(direction, normal=None) -> tuple[np.ndarray, np.ndarray]:
    """A long axis and a normal facing +z as far as the axis allows."""
    a = _unit(direction)
    if normal is None:
        up = np.array([0.0, 0, 1])
        n = up - (up @ a) * a
        if np.linalg.norm(n) < 1e-9:
            n = orthonormal(a)[0]
        return a, _unit(n)
    return a, _unit(normal)
