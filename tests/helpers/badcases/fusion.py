"""Bad inputs of what issue 30 added to the fusion: ``camcmm fuse sample`` into a file, and a
cloud without colours fused with ``--grey intensity`` (its image is its relief, which no
intensity shows: refused naming the cloud and what to set, before any matching)."""

from __future__ import annotations

from helpers.badcases.heightmaps import x3p
from helpers.badinputs import Case, _sphere, ply_binary


def cases() -> list[Case]:
    bare = ply_binary(_sphere(300))  # xyz only: no colours
    return [
        Case("fuse-sample-into-a-file", ("fuse", "sample", "f.txt"), {"f.txt": b"not a folder"}, ("f.txt",), 30.0),
        Case(
            "fuse-grey-intensity-colourless-cloud",
            ("fuse", "csi", "--cloud", "c.ply", "--csi", "m.x3p", "--grey", "intensity"),
            {"c.ply": bare, "m.x3p": x3p()},
            ("c.ply",),
            30.0,
        ),
    ]
