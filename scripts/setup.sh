#!/usr/bin/env bash
# Set up everything ldv-survey needs on a fresh Debian machine with Python >= 3.11:
# a virtual environment in .venv with the package and its test tools, and (with
# --browser) Debian's chromium and docker-compose for the tests. Idempotent and quick when done.
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON:-python3}
want_browser=0
for a in "$@"; do [ "$a" = "--browser" ] && want_browser=1; done

if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
stamp=.venv/.ldvsurvey-installed
sum=$(cat pyproject.toml | sha256sum | cut -c1-16)
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$sum" ]; then
  .venv/bin/python -m pip install --quiet --upgrade pip
  .venv/bin/python -m pip install --quiet -e ".[test]"
  echo "$sum" > "$stamp"
fi

# the test tools from Debian: Chromium for the browser tests, docker-compose to validate the compose file
if [ "$want_browser" = 1 ] && { [ ! -x /usr/bin/chromium ] || ! command -v docker-compose >/dev/null; }; then
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium docker-compose >/dev/null
fi

# compile the numerical core once into numba's on-disk cache (in .venv unless LDVSURVEY_NUMBA_CACHE_DIR),
# so the first job is as fast as the tenth; quick when this code was already warmed
if .venv/bin/python -c "import sys; from ldvsurvey.pipelines.warmup import is_warm; sys.exit(0 if is_warm() else 1)"; then
  :
else
  echo "compiling the numerical core (once per installation, about 2 minutes)..."
  .venv/bin/ldv-survey warmup >/dev/null || echo "warning: ldv-survey warmup failed; the first job of each pipeline will compile" >&2
fi
