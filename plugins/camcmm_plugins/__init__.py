"""Built-in camcmm plugins, each registered through the camcmm.plugins entry point."""
