#!/usr/bin/env bash
# Set up and start the dashboard on http://127.0.0.1:8000 with the built-in demo survey loaded.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
exec .venv/bin/ldv-survey serve --demo --host "${HOST:-127.0.0.1}" --port "${PORT:-8000}"
