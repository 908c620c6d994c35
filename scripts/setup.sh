#!/usr/bin/env bash
# Set up everything ldv-survey needs on a fresh Debian machine with Python >= 3.11:
# a virtual environment in .venv with the package (with --test also its test tools), and (with
# --browser) Debian's chromium and docker-compose for the tests. Idempotent and quick when done.
# With --no-warmup the numerical core is not compiled here: `ldv-survey serve` compiles it in the
# background while it listens (scripts/run.sh), and the first jobs wait for it.
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON:-python3}
want_browser=0
want_warmup=1
want_test=0
for a in "$@"; do
  [ "$a" = "--browser" ] && want_browser=1
  [ "$a" = "--no-warmup" ] && want_warmup=0
  [ "$a" = "--test" ] && want_test=1
done
t0=$SECONDS
say() { echo "[setup $((SECONDS - t0)) s] $*"; }

if [ ! -x .venv/bin/python ]; then
  say "creating the virtual environment .venv"
  "$PY" -m venv .venv
fi
stamp=.venv/.ldvsurvey-installed
sum=$(cat pyproject.toml | sha256sum | cut -c1-16)
have=$(cat "$stamp" 2>/dev/null || true)
# the dashboard needs the package alone; the tests need its test tools too (".[test]"): an
# installation with the test tools serves both, one without them is completed when the tests ask
if [ "$want_test" = 1 ]; then target=".[test]" need="$sum:test"; else target="." need="$sum:run"; fi
if [ "$have" != "$sum:test" ] && [ "$have" != "$need" ]; then
  say "installing the Python packages into .venv (about a minute on a fresh clone)"
  # one line per package as pip gets to it (not the progress bars), so a first start is never silent
  pip_progress() { { grep --line-buffered -E '^(Collecting|Installing collected|Successfully installed)' || true; } |
    cut -c1-160 | sed -u 's/^/  /'; }
  .venv/bin/python -m pip install --progress-bar off --upgrade pip | pip_progress
  .venv/bin/python -m pip install --progress-bar off -e "$target" | pip_progress
  echo "$need" > "$stamp"
  say "Python packages installed"
fi

# the test tools from Debian: Chromium for the browser tests, docker-compose to validate the compose file
if [ "$want_browser" = 1 ] && { [ ! -x /usr/bin/chromium ] || ! command -v docker-compose >/dev/null; }; then
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium docker-compose >/dev/null
fi

# compile the numerical core once into numba's on-disk cache (in .venv unless LDVSURVEY_NUMBA_CACHE_DIR),
# so the first job is as fast as the tenth; quick when this code was already warmed
if [ "$want_warmup" = 0 ] ||
  .venv/bin/python -c "import sys; from ldvsurvey.pipelines.warmup import is_warm; sys.exit(0 if is_warm() else 1)"; then
  :
else
  say "compiling the numerical core (once per installation, about 2 minutes)..."
  .venv/bin/ldv-survey warmup >/dev/null || echo "warning: ldv-survey warmup failed; the first job of each pipeline will compile" >&2
fi
