#!/usr/bin/env bash
# Set up barkgen with its test dependencies in its own virtualenv (.venv) and run the test suite.
# Extra arguments go to pytest (e.g. -k cli, -x).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${BARKGEN_VENV:-.venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -e ".[dev]"
exec "$VENV/bin/python" -m pytest "$@"
