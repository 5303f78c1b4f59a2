"""calibration plugins (skeleton; filled in by its issue)."""
