#!/usr/bin/env bash
# The house's static checks, as .ci/run makes them before the tests: ruff (lint and format) and
# mypy (pyproject.toml's [tool.ruff] and [tool.mypy]). Sets up .venv with the dev extra first.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${BARKGEN_VENV:-.venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
log=$(mktemp)
if ! "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -e ".[dev]" >"$log" 2>&1; then
  cat "$log" >&2; rm -f "$log"; echo "barkgen: installing dependencies failed" >&2; exit 1
fi
rm -f "$log"
"$VENV/bin/ruff" check .
"$VENV/bin/ruff" format --check .
"$VENV/bin/mypy"
