#!/usr/bin/env bash
# Set up (first time only), create the demo project and open the app on it.
# Extra arguments go to `camcmm serve` (e.g. --port 8090).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export VTK_DEFAULT_OPENGL_WINDOW=${VTK_DEFAULT_OPENGL_WINDOW:-vtkEGLRenderWindow}
# the demo's own "open it with: camcmm serve …" hint is for a shell user; here it is already opening
.venv/bin/camcmm demo demo | grep -v '^open it with:'
exec .venv/bin/camcmm serve --project demo "$@"
