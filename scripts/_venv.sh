# Sourced by the scripts: make the project's virtualenv ($BARKGEN_VENV, default .venv) and install
# barkgen into it, editable, with the extras named in $1 (e.g. "dev", "docs"); on failure, the
# installers' log and one line, exit 1.
# The installer is uv (`uv pip install`, from the same pyproject.toml; the install takes a third of
# pip's time: benchmarks/README.md, "The set-up"): the uv on PATH, else the venv's own, which pip
# installs into the venv first (its wheel only, never a build: a few seconds). pip installs
# everything itself when uv can't be had or fails, or with BARKGEN_INSTALLER=pip.
VENV=${BARKGEN_VENV:-.venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
log=$(mktemp)
uv_bin=""
if [ "${BARKGEN_INSTALLER:-uv}" != pip ]; then
  if command -v uv >/dev/null; then
    uv_bin=$(command -v uv)
  elif [ -x "$VENV/bin/uv" ] || "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary uv uv >"$log" 2>&1; then
    uv_bin=$VENV/bin/uv
  fi
fi
# --compile-bytecode: as pip does, so that no command compiles the dependencies' modules at start
if [ -n "$uv_bin" ] && "$uv_bin" pip install --quiet --compile-bytecode --python "$VENV/bin/python" -e ".[$1]" >>"$log" 2>&1; then
  :
elif ! "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -e ".[$1]" >>"$log" 2>&1; then
  cat "$log" >&2; rm -f "$log"; echo "barkgen: installing dependencies failed" >&2; exit 1
fi
rm -f "$log"
unset uv_bin
