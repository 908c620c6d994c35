#!/usr/bin/env bash
# Set up and run every test. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh --browser
exec .venv/bin/python -m pytest -q "$@"
