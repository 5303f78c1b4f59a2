#!/usr/bin/env bash
# Set up (first time only) and run the whole test suite, the browser test included.
# Extra arguments go to pytest (e.g. -k fit, -m "not browser").
set -uo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh || exit 1
export VTK_DEFAULT_OPENGL_WINDOW=${VTK_DEFAULT_OPENGL_WINDOW:-vtkEGLRenderWindow}
.venv/bin/python -m pytest -p no:dash "$@"
rc=$?
if [ "$rc" = 5 ]; then
  # pytest's 5 means "no tests were collected": for a suite that must test something,
  # that is a failure, not a pass.
  echo "scripts/test.sh: pytest collected no tests (exit 5) - treating as failure" >&2
  exit 1
fi
exit "$rc"
