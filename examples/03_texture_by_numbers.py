"""Texture-by-numbers: paint where the fissures go, get bark that follows the painting
(:func:`barkgen.texture_by_numbers`, laitoch2018 §3.1-3.4).

The exemplar's label map ``A`` comes from :func:`barkgen.labels.color_regions` (2 labels: dark
fissures and light plates); the wanted label map ``B`` is drawn here with numpy (a light field
crossed by two dark wavy fissures); the output ``B'`` has ``B``'s size and its labels.

Run::

    python examples/03_texture_by_numbers.py OUTDIR

Writes ``OUTDIR/exemplar_labels.png``, ``OUTDIR/target_labels.png`` and ``OUTDIR/texture.png``
(160x128).
"""

import sys
from pathlib import Path

import numpy as np

import barkgen
import barkgen.labels


def wavy_fissures(shape: tuple[int, int], dark: int, light: int) -> np.ndarray:
    """A label map of ``shape``: two dark vertical wavy bands on a light field."""
    y, x = np.mgrid[: shape[0], : shape[1]]
    target = np.full(shape, light, np.uint8)
    for centre in (0.3 * shape[1], 0.7 * shape[1]):
        target[np.abs(x - centre - 6 * np.sin(y / 9.0)) < 5] = dark
    return target


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    exemplar = barkgen.read_image(barkgen.sample_exemplar_path())[:128, :128]
    labels = barkgen.labels.color_regions(exemplar, 2, seed=0)  # grey values 0 and 255
    dark, light = np.unique(labels)
    target = wavy_fissures((160, 128), dark, light)

    result = barkgen.texture_by_numbers(exemplar, labels, target, budget=barkgen.Budget(seed=3))

    barkgen.write_png(out_dir / "exemplar_labels.png", labels)
    barkgen.write_png(out_dir / "target_labels.png", target)
    barkgen.write_png(out_dir / "texture.png", result.image)
    print(f"texture following target_labels.png in {out_dir}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "examples_out/03_texture_by_numbers"))
