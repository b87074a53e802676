#!/usr/bin/env bash
# Set up barkgen with its test dependencies in its own virtualenv (.venv) and run the test suite.
# Extra arguments go to pytest (e.g. -k cli, -x).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/_venv.sh dev
# the web app's three.js (npm registry, integrity-checked)
"$VENV/bin/python" -m barkgen.web.assets || true
# the Khronos glTF validator (npm registry) for the glb tests, run offline in node
if command -v npm >/dev/null && [ ! -d .cache/node/node_modules/gltf-validator ]; then
  npm install --prefix .cache/node --no-audit --no-fund --silent gltf-validator@2.0.0-dev.3.10 >/dev/null 2>&1 \
    || echo "barkgen: warning: gltf-validator did not install; the glb validation tests will skip" >&2
fi
# Debian's Chromium (the browser tests; Playwright drives it, no browser download) and Blender
# (the Blender preset's test: Node Wrangler wires the set)
missing=""
[ -x /usr/bin/chromium ] || missing="$missing chromium"
[ -x /usr/bin/blender ] || missing="$missing blender"
if [ -n "$missing" ] && command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
  echo "barkgen: installing Debian's$missing for the tests" >&2
  # shellcheck disable=SC2086
  { apt-get install -y -q $missing || { apt-get update -q && apt-get install -y -q $missing; }; } \
    >/tmp/barkgen-apt.log 2>&1 || echo "barkgen: warning:$missing did not install (see /tmp/barkgen-apt.log)" >&2
fi
exec "$VENV/bin/python" -m pytest "$@"
