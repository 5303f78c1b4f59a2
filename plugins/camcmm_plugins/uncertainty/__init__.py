"""Measurement uncertainty: GUM budgets, ISO 15530-3 with a calibrated workpiece, and a
Monte Carlo simulation of a stereo camera system (thesis ch. 2.6, 3.2-3.3, 4.4).

Light on purpose: the host reads ``plugin.yaml`` without importing code. Modules, one
topic each: :mod:`.gum` (budgets, Welch-Satterthwaite, coverage factors),
:mod:`.iso15530` (eq. 4.1), :mod:`.stereo_model` (projection, distortion and its
inverse, eqs. 3.1-3.14, perturbation of the second camera, eqs. 3.15-3.21),
:mod:`.triangulation` (batched linear and optimal triangulation), :mod:`.montecarlo`
(sampling per table 3.1, accumulation, convergence, sweeps, volume maps),
:mod:`.distributed` (the same chunks on a Dask cluster), :mod:`.plugin` (entry points)
and :mod:`.cli` (``camcmm uncertainty``).
"""
