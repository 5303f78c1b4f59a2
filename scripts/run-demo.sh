#!/usr/bin/env bash
# Set up (first time only), create the demo project and open the app on it.
# Extra arguments go to `camcmm serve` (e.g. --port 8090).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export VTK_DEFAULT_OPENGL_WINDOW=${VTK_DEFAULT_OPENGL_WINDOW:-vtkEGLRenderWindow}
.venv/bin/camcmm demo demo
exec .venv/bin/camcmm serve --project demo "$@"
