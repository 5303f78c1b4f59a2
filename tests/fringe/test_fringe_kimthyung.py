"""Real fringe captures of a sphere with a camera + projector calibration
(github.com/kimthyung/3D_Reconstruction_with_Fringe_pattern; no licence to copy, read
from ../shared and skipped where absent).

What the captures are (found from the images, see docs/fringe.md): 3-step phase
shifting of a 114 px period (shifts 0, 120, 240 deg), a 4-bit (horizontal) or 3-bit
(vertical) Gray code of 114 px stripes projected least significant bit first, and a dark
frame. The TI LightCrafter 4500 shows 912 x 1140 patterns on a diamond mirror array with
half-height rows, and the calibration counts square pixels: calibration_scale [1, 0.5].
No nominal diameter exists; the test checks that the reconstruction is a sphere
(plausible radius, form small against it) and that two ways of isolating it agree.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from camcmm.api import get_algorithm
from camcmm_plugins.fringe.decode import decode


def sequence(direction, bits):
    return {
        "projector": {"width": 912, "height": 1140, "calibration_scale": [1, 0.5]},
        "frames": [
            {"type": "phase", "direction": direction, "steps": 3, "period": 114},
            {"type": "gray", "direction": direction, "period": 114, "bits": bits, "bit_order": "lsb_first"},
            "black",
        ],
    }


def frames(root, folder, n):
    return [cv2.imread(str(root / folder / f"{i:02d}.png"), cv2.IMREAD_GRAYSCALE) for i in range(n)]


@pytest.fixture
def root(shared_data):
    return shared_data / "fringe_sphere_kimthyung"


def test_both_fringe_directions_decode(root):
    for folder, n, direction, bits in (("hori_test", 8, "horizontal", 4), ("verti_test", 7, "vertical", 3)):
        dec = decode(sequence(direction, bits), frames(root, folder, n))
        assert 0.45 < dec.valid_fraction < 0.65  # the lit wall, sphere and stand
        x = dec.coords[direction]
        m = dec.mask
        assert np.nanmin(x) > -1 and np.nanmax(x) < (1140 if direction == "horizontal" else 912)
        # the Gray code and the phase agree: the code only has to be corrected on
        # narrow strips along its boundaries
        assert dec.orders["corrected"] < 0.05 * m.sum()
        assert dec.orders["dropped"] < 0.01 * m.sum()
        # projector rows grow down the image, columns to the right
        grad = np.nanmedian(np.diff(x, axis=0 if direction == "horizontal" else 1))
        assert grad > 0.2


@pytest.mark.slow
def test_sphere_reconstructs_as_a_sphere(root):
    res = get_algorithm("fringe.reconstruct")(
        sequence=sequence("horizontal", 4),
        images=frames(root, "hori_test", 8),
        calibration=root / "CalibrationDataDistortion",
    )
    cloud = res["cloud"]
    assert res["n_points"] > 1_000_000 and res["method"] == "camera-projector"
    # 1. the sphere's image, cropped by pixel (a disc inside its outline), least squares
    #    with the VDI/VDE 2634 outlier rule
    x, y = cloud.fields["x_px"], cloud.fields["y_px"]
    crop = get_algorithm("fit.sphere")(cloud=cloud.subset((x - 968) ** 2 + (y - 560) ** 2 < 250**2), outliers="vdi2634")
    r, form = crop["radius"], crop["form"]
    # measured: r = 50.12 mm, rms 1.09 mm, range 4.72 mm (a ripple of three cycles per
    # fringe: the captures' strongly non-linear projector response, uncorrected)
    assert 45 < r < 56
    assert form["rms"] / r < 0.03 and form["range"] / r < 0.12
    assert 300 < crop["center"][2] < 380  # the calibration board was at 290-330 mm
    # 2. segment.sphere on the whole cloud (wall, stand, table), seeded with that radius,
    #    finds the same sphere (measured: r = 50.70 mm, rms 1.04 mm on 300 000 points)
    seg = get_algorithm("segment.sphere")(cloud=cloud, nominal_radius=round(r))
    assert len(seg["indices"]) > 150_000
    fit = get_algorithm("fit.sphere")(cloud=seg["cloud"], outliers="vdi2634")
    assert abs(fit["radius"] - r) < 1.0 and fit["form"]["rms"] / fit["radius"] < 0.03
    assert np.linalg.norm(np.subtract(crop["center"], fit["center"])) < 1.5
