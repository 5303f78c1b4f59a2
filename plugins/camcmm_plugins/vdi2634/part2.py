"""VDI/VDE 2634 part 2: acceptance test of optical 3D measuring systems based on area
scanning (e.g. stereo fringe projection; thesis ch. 2.7.1 and ch. 5).

* Probing error form P_F and size P_S: a calibrated sphere in at least 10 positions.
* Sphere-spacing error SD: a ball bar in at least 7 orientations.
* Flatness measurement error F: a flat in at least 6 orientations.

All fits least squares with at most 3 of every 1000 points removed (outlier rule
``vdi2634``) unless the plan says otherwise. See :mod:`.standard` for the protocol.
"""

from __future__ import annotations

from camcmm.api import InputError

from .standard import Standard, TestSpec


class Part2(Standard):
    id = "vdi2634-2"
    part = 2
    title = "VDI/VDE 2634 part 2"
    specs = (
        TestSpec("sphere", "Sphere positions", ("PF", "PS"), 10),
        TestSpec("ball_bar", "Ball bar orientations", ("SD",), 7),
        TestSpec("flat", "Flat orientations", ("F",), 6),
    )

    def check_plan(self, plan) -> None:
        super().check_plan(plan)
        scaled = {t: m for t, m in plan.scaling.items() if m != "none"}
        if scaled:  # an area-scanning system measures in mm; scaling is part 3's adaptation
            test = next(iter(scaled))
            raise InputError(
                f"{plan.source}: scaling.{test} is {scaled[test]!r}; part 2 systems measure in mm "
                "(scaling is for vdi2634-3)"
            )


#: The manifest entry: ``camcmm_plugins.vdi2634.part2:PART2``.
PART2 = Part2()
