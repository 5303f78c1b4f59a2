#!/usr/bin/env bash
# One-time (and idempotent) set-up: the virtual environment at .venv with camcmm and
# its test tools, and Debian's Chromium for the browser test. Re-running is cheap.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null 2>&1 || PY=python3

if [ ! -x .venv/bin/python ]; then
  echo "camcmm setup: creating .venv with $($PY --version)"
  "$PY" -m venv .venv
fi
stamp=.venv/.camcmm-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ setup.py -nt "$stamp" ]; then
  echo "camcmm setup: installing camcmm and its dependencies into .venv"
  .venv/bin/python -m pip install --quiet --upgrade pip
  .venv/bin/python -m pip install --quiet -e ".[test]"
  touch "$stamp"
fi

# The browser test drives Debian's Chromium through Playwright (never `playwright
# install`, which downloads a browser build of its own).
if ! command -v chromium >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ]; then SUDO=""; elif command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else SUDO="none"; fi
  if [ "$SUDO" != none ] && command -v apt-get >/dev/null 2>&1; then
    echo "camcmm setup: installing Debian's chromium for the browser test"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium chromium-driver >/dev/null
  else
    echo "camcmm setup: chromium not found and cannot be installed here; the browser test will be skipped" >&2
  fi
fi
