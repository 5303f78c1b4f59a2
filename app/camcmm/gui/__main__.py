"""``python -m camcmm.gui PROJECT [--host H] [--port N]``: serve the GUI."""

import sys

if "--session-child" in sys.argv:  # watch the launcher from the start: no orphan while trame loads
    from .launcher.child import watch_parent

    watch_parent()

from .app import main  # noqa: E402

sys.exit(main())
