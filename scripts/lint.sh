#!/usr/bin/env bash
# The house's static checks, as .ci/run makes them before the tests: ruff (lint and format) and
# mypy (pyproject.toml's [tool.ruff] and [tool.mypy]). Sets up .venv with the dev extra first.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/_venv.sh dev
"$VENV/bin/ruff" check .
"$VENV/bin/ruff" format --check .
"$VENV/bin/mypy"
