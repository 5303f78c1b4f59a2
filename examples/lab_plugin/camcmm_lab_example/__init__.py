"""Example lab plugin for camcmm. Keep this file light: the host reads plugin.yaml
without running the plugin's code."""
