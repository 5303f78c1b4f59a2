"""``python -m camcmm.gui PROJECT [--host H] [--port N]``: serve the GUI."""

import sys

from .app import main

sys.exit(main())
