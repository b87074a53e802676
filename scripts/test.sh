#!/usr/bin/env bash
# Set up barkgen with its test dependencies in its own virtualenv (.venv) and run the test suite.
# Extra arguments go to pytest (e.g. -k cli, -x).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${BARKGEN_VENV:-.venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
log=$(mktemp)
if ! "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -e ".[dev]" >"$log" 2>&1; then
  cat "$log" >&2; rm -f "$log"; echo "barkgen: installing dependencies failed" >&2; exit 1
fi
rm -f "$log"
exec "$VENV/bin/python" -m pytest "$@"
