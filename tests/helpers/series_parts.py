"""A small series of sphere caps with known diameters, for the Series view's task and
browser tests (issue 28).

Each part is the upper 120° cap of a sphere of radius 10 + δ about the origin (the plan's
coordinates: ``--align none``), 1500 points with 1 µm noise. The plan's diameter
characteristic ``dia-S1`` has limits ±0.01 mm: its deviation is 2δ, so by construction
δ = 0 and 0.002 mm conform, δ = 0.005 mm lies on the upper limit (ISO 14253-1: undecided
whatever the noise, as |value − limit| ≈ u < U) and δ = 0.008 mm is out (0.016 mm). The
surface profile ``prof-S1`` (0.05 mm) conforms on every part.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

#: δ (mm) of each part, in production order, and the verdict of dia-S1 it makes.
DELTAS = {"part1": 0.0, "part2": 0.002, "part3": 0.005, "part4": 0.008}
EXPECTED = {"part1": "conform", "part2": "conform", "part3": "undecided", "part4": "not conform"}
RADIUS = 10.0


def plan() -> dict[str, Any]:
    return {
        "unit": "mm",
        "band": 0.5,
        "features": {"S1": {"type": "sphere", "centre": [0.0, 0.0, 0.0], "diameter": 2 * RADIUS}},
        "datums": {},
        "characteristics": [
            {"id": "dia-S1", "type": "diameter", "feature": "S1", "lower": -0.01, "upper": 0.01},
            {"id": "prof-S1", "type": "surface-profile", "feature": "S1", "tolerance": 0.05},
        ],
    }


def cap(delta: float, n: int = 1500, noise: float = 0.001, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    z = rng.uniform(math.cos(math.radians(60)), 1.0, n)
    phi = rng.uniform(0, 2 * math.pi, n)
    s = np.sqrt(1 - z * z)
    d = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
    return d * (RADIUS + delta + rng.normal(0, noise, n))[:, None]


def write(folder: str | Path) -> tuple[Path, list[Path]]:
    """plan.yaml and part1.xyz … part4.xyz in ``folder``: (plan, clouds)."""
    import yaml

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / "plan.yaml"
    p.write_text(yaml.safe_dump(plan(), sort_keys=False, default_flow_style=None), "utf-8")
    clouds = []
    for i, (name, delta) in enumerate(DELTAS.items()):
        f = folder / f"{name}.xyz"
        np.savetxt(f, cap(delta, seed=i + 1), fmt="%.9f")
        clouds.append(f)
    return p, clouds
