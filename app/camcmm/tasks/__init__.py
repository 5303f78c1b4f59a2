"""Headless tasks: what the pages (and the commands) run, without trame or VTK.

One module per task a page runs — compare with CAD, fusion, photogrammetry, calibration,
studies, the acceptance wizard. Each is plain functions or a plain class with a typed
request and outcome, ``run`` (the plugin found by the task it provides, through the host or
the worker), ``store(project)`` (the result row, its files and items, the page's record)
and ``restore(project)`` (the last run back, as the project keeps it); each declares the
outputs it reads of its provider as a :class:`camcmm.contracts.OutputContract`. A page holds
its task and only shows it: tests drive the task directly (tests/tasks/).

Nothing here imports :mod:`camcmm.gui`, trame or VTK (tests/core/test_layering.py checks).
"""
