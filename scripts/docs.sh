#!/usr/bin/env bash
# Build the documentation site (MkDocs Material, mkdocs.yml) with --strict: a broken link, a
# missing page or a docstring that does not render fails the build. Installs the docs extra into
# the project's virtualenv (.venv, as scripts/test.sh makes it). Output in site/ (or $1).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${BARKGEN_VENV:-.venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
log=$(mktemp)
if ! "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -e ".[docs]" >"$log" 2>&1; then
  cat "$log" >&2; rm -f "$log"; echo "barkgen: installing dependencies failed" >&2; exit 1
fi
rm -f "$log"
# the CLI reference is generated from the Typer app; tests/test_docs_site.py checks it is current
export NO_MKDOCS_2_WARNING=1
exec "$VENV/bin/python" -m mkdocs build --strict --site-dir "${1:-site}"
