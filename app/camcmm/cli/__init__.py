"""The ``camcmm`` command line (see :mod:`camcmm.cli.main`)."""
