"""devices plugins (skeleton; filled in by its issue)."""
