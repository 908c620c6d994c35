#!/usr/bin/env bash
# The frontend's formatter: the prettier pinned in package-lock.json, installed into node_modules
# with npm ci (Debian's nodejs/npm when npm is missing). Idempotent and offline once installed.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v npm >/dev/null; then
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq nodejs npm >/dev/null
fi
stamp=node_modules/.ldvsurvey-installed
sum=$(sha256sum package-lock.json | cut -c1-16)
if [ ! -x node_modules/.bin/prettier ] || [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$sum" ]; then
  npm ci --no-audit --no-fund --loglevel=error
  echo "$sum" > "$stamp"
fi
