"""VDI/VDE 2634 part 2 and part 3 acceptance tests (standard plugins ``vdi2634-2`` and
``vdi2634-3``) and the ``camcmm verify`` command. Kept light: the manifest is read
without importing anything here. Protocol: docs/standards.md."""
