#!/usr/bin/env bash
# Set up, check lint and formatting (ruff, prettier; scripts/format.sh fixes what it can), and run
# every test. Extra arguments go to pytest (and skip the lint and formatting checks).
# Under CI (CI=true) or with LDVSURVEY_TEST_SCALEOUT=1 the scale-out tests run against PostgreSQL and
# Redis on loopback (started here if installed but stopped) and the database-facing tests run a second
# time on PostgreSQL; an unreachable engine is then a failure, not a skip.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh --test --browser
./scripts/node-tools.sh

if [ $# -eq 0 ]; then
  echo "== lint and formatting (scripts/format.sh fixes what can be fixed)"
  .venv/bin/ruff check .
  .venv/bin/ruff format --check .
  node_modules/.bin/prettier --check --log-level warn frontend
fi

if [ "${CI:-}" = "true" ]; then export LDVSURVEY_TEST_SCALEOUT=1; fi
if [ "${LDVSURVEY_TEST_SCALEOUT:-}" = "1" ]; then
  if ! pg_isready -h 127.0.0.1 -q 2>/dev/null && command -v pg_ctlcluster >/dev/null; then
    pg_ctlcluster --skip-systemctl-redirect "$(ls /etc/postgresql | head -1)" main start || true
  fi
  if ! redis-cli -h 127.0.0.1 ping >/dev/null 2>&1 && command -v redis-server >/dev/null; then
    redis-server --daemonize yes --bind 127.0.0.1 --port 6379 --save "" --appendonly no || true
  fi
fi

.venv/bin/python -m pytest -q "$@"
if [ "${LDVSURVEY_TEST_SCALEOUT:-}" = "1" ] && [ $# -eq 0 ]; then
  echo "== the database-facing tests again, on PostgreSQL"
  LDVSURVEY_TEST_DATABASE_URL="${LDVSURVEY_TEST_PG_URL:-postgresql+psycopg://root@127.0.0.1:5432/test}" \
    .venv/bin/python -m pytest -q -p no:cacheprovider tests/api
fi
