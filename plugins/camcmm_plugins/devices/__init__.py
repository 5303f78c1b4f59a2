"""Devices and acquisition sequences: cameras, projectors, stages, interferometer — real
and simulated (thesis ch. 3.2.3, 4.2, 4.5, 5). See docs/devices.md.

Light on purpose: the host reads ``plugin.yaml`` without importing code. Modules, one
topic each: :mod:`.base` (Device, DeviceStatus, Events, DeviceError, DeviceMonitor),
:mod:`.camera` (Camera, OpenCVCamera), :mod:`.genicam` (harvesters, optional),
:mod:`.stage` (Stage, SimulatedStage), :mod:`.zaber` (Zaber ASCII protocol and stages),
:mod:`.interferometer` (serial line protocol, CSV import, simulated),
:mod:`.projector` (PatternProjector model for the browser page, SpeckleProjector),
:mod:`.simulated` (rendering cameras, the simulator-backed Zaber stage),
:mod:`.simulator` (the Zaber-ASCII stage + interferometer simulator process, stdlib only),
:mod:`.sequence` (the pause/resume engine) and :mod:`.acquisition` (turntable, fringe,
scale run), :mod:`.cli` (``camcmm devices``).
"""
