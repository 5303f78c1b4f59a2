"""An exact-by-construction batch for ``camcmm gdt batch`` (issue 28): ten blocks of
helpers/gdt_parts.py whose characteristics take chosen values part to part, plus two
parts that fail.

Each part is the block with

* its bore's axis offset (0.02, −0.01) mm at z = 0 and r·(0.8, 0.6) at z = 30 with
  r = POSITION[i]/2 ≥ 0.04 mm, so the position of H1 to A|B|C is 2·max = POSITION[i];
* its side D tilted by PERP_D[i]/28 (x = 80 + t·z, sampled z 1 … 29), so D's
  perpendicularity to A is PERP_D[i];
* its bore's diameter DIAMETER[i];

noise-free, delivered in a small pose of its own (a fraction of a degree, a tenth of a
mm) so that each is aligned (``--align datums``). The plan's datums A, B, C are least
squares (their exact planes: the frame is the plan's) and its ``point_noise`` (2 µm)
gives D's perpendicularity, an extreme of its points, a Monte Carlo u of about 2 µm: the
part whose perpendicularity is 0.0495 mm against 0.05 is **undecided** (simple verdict
conform, guarded undecided), the part whose position is 0.22 mm against 0.2 is **out of
tolerance**. Two more files fail: ``broken.xyz`` is not a cloud, ``nobore.xyz`` is a
part without the bore's points (feature H1 not evaluated).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from . import gdt_parts as g

#: The constructed values (mm) of the ten good parts, in production order.
POSITION = [0.10, 0.12, 0.09, 0.14, 0.11, 0.13, 0.08, 0.22, 0.12, 0.10]
PERP_D = [0.020, 0.025, 0.018, 0.030, 0.022, 0.0495, 0.024, 0.021, 0.027, 0.019]
DIAMETER = [10 + d for d in (-0.005, 0.003, 0.0, 0.006, -0.002, 0.004, -0.004, 0.001, 0.002, -0.003)]
#: Tolerances of the plan (mm): position, perpendicularity (zones), diameter 10 ± 0.01.
TOL_POSITION, TOL_PERP, DIA_LIMITS = 0.2, 0.05, (-0.01, 0.01)
GOOD = [f"part{i + 1:02d}" for i in range(10)]
OUT = "part08"  # position 0.22 > 0.2
UNDECIDED = "part06"  # perpendicularity 0.0495: within 0.05 by less than its U
#: The file order of the batch: the failing files among the good ones (the batch goes on).
ORDER = [*GOOD[:5], "broken", *GOOD[5:8], "nobore", *GOOD[8:]]
#: Part density (points per mm²): about a thousand points a part.
DENSITY, N_MIN = 0.05, 60


def plan_document() -> dict[str, Any]:
    """The batch's plan: position and diameter of the bore, perpendicularity of D."""
    chars = [
        {"id": "pos-H1", "type": "position", "feature": "H1", "datums": ["A", "B", "C"], "tolerance": TOL_POSITION},
        {"id": "perp-D", "type": "perpendicularity", "feature": "D", "datums": ["A"], "tolerance": TOL_PERP},
        {"id": "dia-H1", "type": "diameter", "feature": "H1", "lower": DIA_LIMITS[0], "upper": DIA_LIMITS[1]},
    ]
    doc = g.plan_document(characteristics=chars, point_noise=0.002)
    for f in "ABC":
        doc["features"][f]["association"] = "ls"
    return doc


def part(i: int) -> g.Part:
    """Good part i (0-based): the module docstring's values, in its own small pose."""
    r = POSITION[i] / 2
    rng = np.random.default_rng(100 + i)
    pose = g.pose(rng.normal(size=3), 0.1 + 0.1 * rng.random(), 0.1 * rng.uniform(-1, 1, 3))
    return g.block(
        density=DENSITY,
        n_min=N_MIN,
        pose=pose,
        bore_top=(0.8 * r, 0.6 * r),
        tilt_d=PERP_D[i] / 28.0,
        bore_diameter=DIAMETER[i],
        seed=i,
    )


def write(folder: str | Path) -> tuple[Path, list[Path]]:
    """plan.yaml and the batch's clouds (ORDER) in ``folder``: (plan, clouds)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    plan = folder / "plan.yaml"
    plan.write_text(g.plan_yaml(plan_document()), "utf-8")
    files = {name: part(i).write(folder / f"{name}.xyz") for i, name in enumerate(GOOD)}
    files["broken"] = folder / "broken.xyz"
    files["broken"].write_text("this is not a cloud\n", "utf-8")
    p = part(0)
    keep = p.surface != p.names.index("H1")
    files["nobore"] = folder / "nobore.xyz"
    np.savetxt(files["nobore"], p.points[keep], fmt="%.10f")
    return plan, [files[name] for name in ORDER]
