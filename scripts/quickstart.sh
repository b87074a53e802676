#!/usr/bin/env bash
# Set up barkgen in its own virtualenv (.venv) and run the main job on the bundled sample photo:
# a 1024x1024 tileable bark texture, its reference map and a 2x2 tiling preview, in out/.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${BARKGEN_VENV:-.venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
log=$(mktemp)
if ! "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -e . >"$log" 2>&1; then
  cat "$log" >&2; rm -f "$log"; echo "barkgen: installing dependencies failed" >&2; exit 1
fi
rm -f "$log"
mkdir -p out
"$VENV/bin/barkgen" synth -o out/bark_1024_tile.png --size 1024x1024 --tile --seed 0 \
  --save-reference out/bark_1024_tile_reference.png "$@"
"$VENV/bin/python" - <<'PY'
import numpy as np
from barkgen.io import read_image, write_png
img = read_image("out/bark_1024_tile.png")
write_png("out/bark_1024_tile_2x2_preview.png", np.tile(img, (2, 2, 1))[::2, ::2])
PY
echo "outputs in $(pwd)/out: bark_1024_tile.png (texture), bark_1024_tile_reference.png, bark_1024_tile_2x2_preview.png"
