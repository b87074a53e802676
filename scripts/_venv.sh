# Sourced by the scripts: make the project's virtualenv ($BARKGEN_VENV, default .venv) and install
# barkgen into it, editable, with the extras named in $1 (e.g. "dev", "docs"); on failure, the
# installer's log and one line, exit 1.
VENV=${BARKGEN_VENV:-.venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
log=$(mktemp)
if ! "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -e ".[$1]" >"$log" 2>&1; then
  cat "$log" >&2; rm -f "$log"; echo "barkgen: installing dependencies failed" >&2; exit 1
fi
rm -f "$log"
