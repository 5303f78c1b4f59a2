"""The words the Uncertainty page says about its starting points.

Both tabs start from the same system: the stereo camera pair of thesis ch. 3.3.1 with
the uncertainties of its table 3.2. The budget starts from the contributions the
thesis tabulates; the Monte Carlo starts from the parameter uncertainties the thesis
tabulates and computes the contributions itself — so the two can differ, and the page
says why (tests/test_uncertainty_distributions.py ties both defaults to the thesis and
checks the numbers quoted here).
"""

from __future__ import annotations

THESIS = "thesis ch. 3.3.1, table 3.2"

BUDGET_SOURCE = (
    "Starting budget: the x column of thesis table 3.2 (ch. 3.3.1) — the contributions the "
    "thesis tabulates for its stereo pair (feature location 3.1, focal length 1.7, rotation 9.1, "
    "translation 1.5, radial distortion 2.1 µm), each entered as a standard uncertainty u. "
    "The Monte Carlo tab starts from the same system and computes these contributions itself."
)

MC_SOURCE = (
    "Starting system: the stereo pair of thesis ch. 3.3.1 (two 4024 × 3036 px cameras, 1.85 µm "
    "pixels, f = 16.74 / 16.66 mm, baseline 199.35 mm, 38.64° between the axes) with the parameter "
    "uncertainties of table 3.2 (0.1 px; 0.82, 0.84 px; 1.84, 1.52, 0.71 × 10⁻⁴ rad; 13, 8, 27 µm; "
    "k1, k2 0.001, 0.0362) — the system of the GUM budget tab. The budget quotes the contributions the "
    "thesis tabulates; this study computes them over a 60 × 40 × 40 mm grid around the convergence point. "
    "Feature location and focal length agree with the table (x: about 3.4 and 1.7 µm against 3.1 and 1.7 µm); "
    "rotation comes out at 3.7–3.8 µm in x against the table's 9.1 µm, and radial distortion well below "
    "its 2.1 µm. The thesis does not state the volume it simulated, and these contributions grow with it "
    "(80 × 60 × 60 mm gives rotation about 5.0, 4.7, 8.8 µm in x, y, z; the table: 9.1, 4.7, 9.1 µm), so no "
    "volume reproduces the whole table. The combined u_c(x), about 5.4 µm here, is near the 5.9 µm the "
    "thesis's discussion (ch. 3.4.1) quotes rather than its table's 10.1 µm."
)
