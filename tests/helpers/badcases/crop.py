"""Bad crops and segmentations (issue 29): ``camcmm run crop.box|crop.plane|crop.lasso|
segment.components`` with each parameter wrong — a corner missing or the wrong way round,
both box forms at once, a vector of the wrong length or with NaN, a zero normal, a polygon
of fewer than three vertices or an odd count, a view matrix of 15 numbers or without a w
row, an eps of 0, a component that does not exist, a crop or an eps that keeps no point.
Each must be one line naming the parameter (or the cloud, when nothing is kept). Ids
start with ``crop-``."""

from __future__ import annotations

from helpers.badinputs import Case, _sphere, ply_binary

SQUARE = "-0.5,-0.5,0.5,-0.5,0.5,0.5,-0.5,0.5"
ORTHO = "0.1,0,0,0,0,0.1,0,0,0,0,0.1,0,0,0,0,1"  # x/10, column-major


def cases() -> list[Case]:
    good = {"c.ply": ply_binary(_sphere(500))}  # a 10 mm sphere about the origin
    out: list[Case] = []

    def rc(cid: str, plugin: str, args: tuple[str, ...], names: tuple[str, ...]) -> None:
        out.append(Case(f"crop-{cid}", ("run", plugin, "c.ply", *args, "--json"), good, names))

    box = "crop.box"
    rc("box-max-below-min", box, ("--min", "0,5,0", "--max", "9,4,9"), ("max",))
    rc("box-max-missing", box, ("--min", "0,0,0"), ("max",))
    rc("box-nothing", box, (), ("min",))
    rc("box-both-forms", box, ("--min", "0,0,0", "--max", "1,1,1", "--centre", "0,0,0", "--size", "1,1,1"), ("centre",))
    rc("box-min-two-numbers", box, ("--min", "1,2", "--max", "3,3,3"), ("min",))
    rc("box-min-nan", box, ("--min", "nan,0,0", "--max", "3,3,3"), ("min",))
    rc("box-size-negative", box, ("--centre", "0,0,0", "--size", "-1,1,1"), ("size",))
    rc("box-rotation-1000", box, ("--centre", "0,0,0", "--size", "1,1,1", "--rotation", "0,0,1000"), ("rotation",))
    rc("box-rotation-with-corners", box, ("--min", "0,0,0", "--max", "1,1,1", "--rotation", "0,0,10"), ("rotation",))
    rc("box-keeps-nothing", box, ("--min", "20,20,20", "--max", "30,30,30"), ("c.ply",))
    rc("box-keep-middle", box, ("--min", "0,0,0", "--max", "1,1,1", "--keep", "middle"), ("keep",))
    plane = "crop.plane"
    rc("plane-zero-normal", plane, ("--point", "0,0,0", "--normal", "0,0,0"), ("normal",))
    rc("plane-no-point", plane, ("--normal", "0,0,1"), ("point",))
    rc("plane-keeps-nothing", plane, ("--point", "0,0,50", "--normal", "0,0,1"), ("c.ply",))
    lasso = "crop.lasso"
    rc("lasso-two-vertices", lasso, ("--polygon", "0,0,1,1", "--mvp", ORTHO), ("polygon",))
    rc("lasso-odd-count", lasso, ("--polygon", "0,0,1,0,0", "--mvp", ORTHO), ("polygon",))
    rc("lasso-polygon-inf", lasso, ("--polygon", "0,0,inf,0,0,1", "--mvp", ORTHO), ("polygon",))
    rc("lasso-mvp-15", lasso, ("--polygon", SQUARE, "--mvp", ORTHO.rsplit(",", 1)[0]), ("mvp",))
    rc("lasso-mvp-no-w", lasso, ("--polygon", SQUARE, "--mvp", ",".join(["0"] * 16)), ("mvp",))
    rc("lasso-no-mvp", lasso, ("--polygon", SQUARE), ("mvp",))
    seg = "segment.components"
    rc("segment-eps-0", seg, ("--eps", "0"), ("eps",))
    rc("segment-eps-nan", seg, ("--eps", "nan"), ("eps",))
    rc("segment-min-points-0", seg, ("--min-points", "0"), ("min_points",))
    rc("segment-component-0", seg, ("--keep", "component", "--component", "0"), ("component",))
    rc("segment-component-9", seg, ("--eps", "5", "--keep", "component", "--component", "9"), ("component",))
    rc("segment-all-noise", seg, ("--eps", "1e-6", "--min-points", "2"), ("c.ply",))
    return out
