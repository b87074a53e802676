"""A tileable texture with an extra map synthesized along (``tile=True``, ``extra=``).

Any map aligned with the exemplar (height, normals, roughness, ...) can go along: it takes part
in the matching and comes back through the same references, re-integrated in the gradient
domain so it has no cliffs where copied pieces meet. Here the extra map is a height field
estimated from the photo itself (:func:`barkgen.material.estimate_height`). With ``tile=True``
the output wraps seamlessly left/right and top/bottom; ``texture_2x2.png`` shows it tiled.

Run::

    python examples/02_tile_and_extras.py OUTDIR

Writes ``OUTDIR/texture.png``, ``OUTDIR/texture_height.png`` (both 128x128, tileable) and
``OUTDIR/texture_2x2.png``.
"""

import sys
from pathlib import Path

import numpy as np

import barkgen
import barkgen.material


def to_grey16(height: np.ndarray) -> np.ndarray:
    """A height field as a 16-bit grey image, lowest = 0, highest = 65535."""
    span = max(float(height.max() - height.min()), 1e-6)
    return np.round((height - height.min()) / span * 65535).astype(np.uint16)


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    exemplar = barkgen.read_image(barkgen.sample_exemplar_path())[:128, :128]
    height = barkgen.material.estimate_height(exemplar / 255.0)  # (128, 128) float32, pixels

    result = barkgen.synthesize(exemplar, 128, tile=True, seed=2, extra={"height": height})

    barkgen.write_png(out_dir / "texture.png", result.image)
    barkgen.write_png(out_dir / "texture_height.png", to_grey16(result.extras["height"][:, :, 0]))
    barkgen.write_png(out_dir / "texture_2x2.png", np.tile(result.image, (2, 2, 1)))
    print(f"tileable texture and its height map in {out_dir}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "examples_out/02_tile_and_extras"))
