#!/usr/bin/env bash
# Set up (first time only), lint, and run the whole test suite, the browser tests included.
# Extra arguments go to pytest (e.g. -k fit, -m "not slow" for the quick run).
set -uo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh || exit 1
export VTK_DEFAULT_OPENGL_WINDOW=${VTK_DEFAULT_OPENGL_WINDOW:-vtkEGLRenderWindow}
# Lint before the tests: a failure here stops the run (the style rules are in pyproject.toml).
.venv/bin/ruff check app plugins tests examples benchmarks || exit 1
# Types of the core (the [tool.mypy] section of pyproject.toml says which files).
.venv/bin/python -m mypy || exit 1
.venv/bin/ruff format --check app plugins tests examples benchmarks || exit 1
# Both cores (pytest-xdist): the browser tests share one worker (their xdist_group), the
# headless tests are spread over the others. CAMCMM_TEST_WORKERS=0 runs in this process.
workers=${CAMCMM_TEST_WORKERS:-auto}
if [ "$workers" = 0 ]; then
  .venv/bin/python -m pytest -p no:dash "$@"
else
  .venv/bin/python -m pytest -p no:dash -n "$workers" --dist loadgroup "$@"
fi
rc=$?
if [ "$rc" = 5 ]; then
  # pytest's 5 means "no tests were collected": for a suite that must test something,
  # that is a failure, not a pass.
  echo "scripts/test.sh: pytest collected no tests (exit 5) - treating as failure" >&2
  exit 1
fi
exit "$rc"
