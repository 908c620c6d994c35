#!/usr/bin/env bash
# Set up and start the dashboard on http://127.0.0.1:8000 with the built-in demo survey loaded.
# On a fresh clone the server listens as soon as the packages are installed; the numerical core
# compiles in the background meanwhile (about 2 minutes on 2 cores, printed as it goes) and the
# first jobs wait for it, their page saying so.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh --no-warmup
echo "[run] starting the dashboard on http://${HOST:-127.0.0.1}:${PORT:-8000}/ (the demo survey is simulated on the first start)"
exec .venv/bin/ldv-survey serve --demo --host "${HOST:-127.0.0.1}" --port "${PORT:-8000}"
