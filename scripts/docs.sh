#!/usr/bin/env bash
# Build the documentation site (MkDocs Material, mkdocs.yml) with --strict: a broken link, a
# missing page or a docstring that does not render fails the build. Installs the docs extra into
# the project's virtualenv (.venv, as scripts/test.sh makes it). Output in site/ (or $1).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/_venv.sh docs
# the CLI reference is generated from the Typer app; tests/test_docs_site.py checks it is current
export NO_MKDOCS_2_WARNING=1
exec "$VENV/bin/python" -m mkdocs build --strict --site-dir "${1:-site}"
