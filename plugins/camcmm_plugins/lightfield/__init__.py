"""Light-field depth as a scale for photogrammetry (thesis ch. 6.3, eqs. 6.2-6.5, table 6.3)."""
