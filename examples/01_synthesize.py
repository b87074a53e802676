"""Synthesize new bark from the bundled sample photo with :func:`barkgen.synthesize`.

The exemplar is a 128 px crop of the bundled pine bark (``barkgen.sample_exemplar_path()``);
the output is a new, larger texture of the same bark, resolved pixel for pixel from the photo
(no blur) through its reference map (which photo pixel each output pixel copies), with the
colour steps where copied pieces meet blended away in the gradient domain (``blend="gradient"``,
the default; ``blend="none"`` keeps the exact copy).

Run::

    python examples/01_synthesize.py OUTDIR

Writes ``OUTDIR/exemplar.png``, ``OUTDIR/synthesized.png`` (160x224) and ``OUTDIR/reference.png``.
"""

import sys
from pathlib import Path

import barkgen
import barkgen.io


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    photo = barkgen.read_image(barkgen.sample_exemplar_path())  # (1024, 1024, 3) uint8
    exemplar = photo[:128, :128]

    result = barkgen.synthesize(exemplar, (160, 224), seed=1)  # size is (height, width)

    barkgen.write_png(out_dir / "exemplar.png", exemplar)
    barkgen.write_png(out_dir / "synthesized.png", result.image)
    barkgen.io.write_reference(out_dir / "reference.png", result.references, result.exemplar_shape)
    print(f"{result.image.shape[1]}x{result.image.shape[0]} texture in {out_dir}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "examples_out/01_synthesize"))
