"""GD&T on measured clouds: features, datums, ISO 1101 characteristics with their
uncertainty and ISO 14253-1 verdicts (``camcmm gdt evaluate``; docs/gdt.md)."""
