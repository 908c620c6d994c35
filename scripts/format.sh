#!/usr/bin/env bash
# Fix what the linters can fix, over the whole tree: ruff's lint fixes and formatting (Python, settings
# in pyproject.toml) and prettier (frontend/, settings in .prettierrc). What stays is printed by the
# checks at the end; scripts/test.sh runs the same checks and fails on any.
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x .venv/bin/ruff ] || ./scripts/setup.sh --test
./scripts/node-tools.sh

.venv/bin/ruff check --fix --quiet . || true  # what it cannot fix is listed by the check below
.venv/bin/ruff format .
node_modules/.bin/prettier --write --log-level warn frontend

echo "== left to fix by hand:"
.venv/bin/ruff check . && node_modules/.bin/prettier --check --log-level warn frontend
