"""The positions each test asks for, with ids the GUI wizard shows as pictograms and
coordinates the virtual lab places its artefacts at.

Frame: origin at the centre of the measuring volume, +z towards the sensor. ``where``
is the artefact centre as fractions of the volume's edge lengths (-0.5 .. 0.5 each);
``direction`` a ball bar's or flat's long axis, ``normal`` the flat's measured face
(unit vectors up to scale). Part 3 adds ``camera`` (turntable camera azimuth and
elevation, deg) and ``rotation``/``tilt`` of the ball plate (deg).

Layouts follow the figures the thesis reproduces from VDI/VDE 2634 part 2 — sphere in
at least 10 arbitrary positions spread over the volume (fig. 2.16), ball bar in 7
orientations (fig. 2.17: a steep one, the four space diagonals, two horizontals; not
exactly vertical, because a sensor looking down cannot light or see the lower sphere
behind the upper one — the problem the thesis met in ch. 4.4), flat in
6 orientations (fig. 2.18) — and the thesis's part-3 adaptation: five camera positions
A-E for the sphere (ch. 4.5.1) and seven ball-plate orientations, the vertical one
replaced by a tilted one (fig. 4.4).
"""

from __future__ import annotations

from typing import Any

_SPHERE = [
    ((0.0, 0.0, 0.0), "centre of the volume"),
    ((-0.3, -0.3, -0.3), "front left, low"),
    ((0.3, -0.3, -0.3), "front right, low"),
    ((0.3, 0.3, -0.3), "back right, low"),
    ((-0.3, 0.3, -0.3), "back left, low"),
    ((-0.3, -0.3, 0.3), "front left, high"),
    ((0.3, -0.3, 0.3), "front right, high"),
    ((0.3, 0.3, 0.3), "back right, high"),
    ((-0.3, 0.3, 0.3), "back left, high"),
    ((0.0, 0.0, 0.35), "centre, high"),
]

_BALL_BAR = [
    ((0, 0.5, 0.866), "steep (60° to the horizontal), front low to back high, in the centre"),
    ((1, 1, 1), "space diagonal: front left low to back right high"),
    ((-1, 1, 1), "space diagonal: front right low to back left high"),
    ((1, -1, 1), "space diagonal: back left low to front right high"),
    ((-1, -1, 1), "space diagonal: back right low to front left high"),
    ((1, 0, 0), "horizontal, left to right, in the centre"),
    ((0, 1, 0), "horizontal, front to back, in the centre"),
]

_FLAT = [
    ((1, 1, 0), (0, 0, 1), "horizontal, along the diagonal front left to back right"),
    ((1, -1, 0), (0, 0, 1), "horizontal, along the diagonal back left to front right"),
    ((1, 0, 1), (-1, 0, 1), "tilted 45°, rising to the right"),
    ((-1, 0, 1), (1, 0, 1), "tilted 45°, rising to the left"),
    ((0, 1, 1), (0, -1, 1), "tilted 45°, rising to the back"),
    ((0, -1, 1), (0, 1, 1), "tilted 45°, rising to the front"),
]

_CAMERA = [0.0, 72.0, 144.0, 216.0, 288.0]
_PLATE = [(0.0, 0.0), (45.0, 0.0), (90.0, 0.0), (135.0, 0.0), (180.0, 0.0), (270.0, 0.0), (0.0, 30.0)]


def sphere(part: int) -> list[dict[str, Any]]:
    if part == 3:
        return [
            {
                "id": f"sphere-{i + 1:02d}",
                "label": f"Camera position {chr(65 + i)}",
                "hint": f"sphere in the centre; camera at azimuth {az:g}°, elevation 45°, same magnification",
                "where": [0.0, 0.0, 0.0],
                "camera": {"azimuth": az, "elevation": 45.0},
            }
            for i, az in enumerate(_CAMERA)
        ]
    return [
        {"id": f"sphere-{i + 1:02d}", "label": f"Sphere position {i + 1}", "hint": hint, "where": list(w)}
        for i, (w, hint) in enumerate(_SPHERE)
    ]


def ball_bar() -> list[dict[str, Any]]:
    return [
        {
            "id": f"ball-bar-{i + 1:02d}",
            "label": f"Ball bar orientation {i + 1}",
            "hint": hint,
            "where": [0.0, 0.0, 0.0],
            "direction": list(map(float, d)),
        }
        for i, (d, hint) in enumerate(_BALL_BAR)
    ]


def flat() -> list[dict[str, Any]]:
    return [
        {
            "id": f"flat-{i + 1:02d}",
            "label": f"Flat orientation {i + 1}",
            "hint": hint,
            "where": [0.0, 0.0, 0.0],
            "direction": list(map(float, d)),
            "normal": list(map(float, n)),
        }
        for i, (d, n, hint) in enumerate(_FLAT)
    ]


def ball_plate() -> list[dict[str, Any]]:
    out = []
    for i, (rot, tilt) in enumerate(_PLATE):
        hint = (
            f"plate flat, edge 1 turned {rot:g}° from arrow 1"
            if not tilt
            else f"plate tilted {tilt:g}° (replaces the vertical position the speckle projector cannot light)"
        )
        out.append(
            {
                "id": f"ball-plate-{i + 1:02d}",
                "label": f"Ball plate orientation {i + 1}",
                "hint": hint,
                "where": [0.0, 0.0, 0.0],
                "rotation": rot,
                "tilt": tilt,
            }
        )
    return out


def for_test(test: str, part: int) -> list[dict[str, Any]]:
    return {"sphere": lambda: sphere(part), "ball_bar": ball_bar, "flat": flat, "ball_plate": ball_plate}[test]()
