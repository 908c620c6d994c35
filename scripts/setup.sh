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
