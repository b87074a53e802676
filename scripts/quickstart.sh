#!/usr/bin/env bash
# Set up barkgen in its own virtualenv (.venv) and run the main job on the bundled sample photo:
# photo -> label map -> new label map -> 1024x1024 tileable bark, with its maps and a contact
# sheet, in out/ (and a 2x2 tiling preview to check the seams by eye).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/_venv.sh all
# three.js for `barkgen serve`'s 3D trunk (the editable install's build has fetched it; this checks,
# from the module's file: it needs only the standard library, and skips importing barkgen)
"$VENV/bin/python" src/barkgen/web/assets.py || true
# compile the numba kernels into their cache once, as part of the set-up (about 30 s), so that
# the first run is as fast as every later one
"$VENV/bin/barkgen" warm-up --quiet
"$VENV/bin/barkgen" generate -o out --size 1024x1024 --tile --seed 0 --material "$@"
# the preview and the 2x2 tiling in one Python start-up (barkgen preview out -o out/trunk_preview.png)
"$VENV/bin/python" - <<'PY'
import numpy as np
from barkgen.cli import main
from barkgen.io import read_image, write_png
try:
    main(["preview", "out", "-o", "out/trunk_preview.png"])
except SystemExit as exc:
    if exc.code:
        raise
img = read_image("out/texture.png")
write_png("out/texture_2x2_preview.png", np.tile(img, (2, 2, 1))[::2, ::2])
PY
echo "outputs in $(pwd)/out: texture.png, labels_in.png, labels_out.png, reference.png, report.json, preview.png, texture_2x2_preview.png, the material set sample_bark_seed0_1K_*.png + sample_bark_seed0_1K.json, trunk_preview.png"
