"""Crack networks: extract, grow and render branching structures (:mod:`barkgen.branching`,
sibbing2010).

The source image is a crop of a dried-mud crack texture from the team's
``../shared/data/branching`` (``$BARKGEN_SHARED/data/branching``) when it is there; otherwise the bundled bark
sample, whose fissures are given as the darkest label of a 2-label colour map
(:func:`barkgen.labels.color_regions`, the ``labels=`` route of
:func:`barkgen.branching.extract_structure`). Then:

1. :func:`~barkgen.branching.extract_structure`: the crack network as polylines with thickness;
2. :func:`~barkgen.branching.fit_model` and :func:`~barkgen.branching.grow_structure`: its
   bending / furcation / merge statistics, and a new network of another size grown from them;
3. :func:`~barkgen.branching.render_branches`: an image whose cracks follow the new network,
   made of fragments of the source (the gaps filled by texture-by-numbers);
4. :func:`~barkgen.branching.compare_structures`: the two networks' histograms compared.

Run::

    python examples/08_branches.py OUTDIR

Writes ``OUTDIR/source.png``, ``source.json`` and ``grown.json`` (structure files as
``barkgen branches`` reads them), ``source_overlay.png``, ``rendered.png`` (160x128) and
``rendered_fissures.png``.
"""

import json
import os
import sys
from pathlib import Path

import numpy as np

import barkgen
import barkgen.branching
import barkgen.labels

DATA = Path(os.environ.get("BARKGEN_SHARED", Path(__file__).resolve().parents[2] / "shared")) / "data" / "branching"


def source_image() -> tuple[np.ndarray, np.ndarray | None, str]:
    """A 128 px crack image, its fissure label map (None: found in the image) and its origin."""
    mud = DATA / "mud_crackle_gray_01.png"
    if mud.is_file():
        return barkgen.read_image(mud)[:128, :128], None, mud.name
    bark = barkgen.read_image(barkgen.sample_exemplar_path())[:128, :128]
    return bark, barkgen.labels.color_regions(bark, 2, seed=0), "the bundled bark sample"


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    image, fissures, origin = source_image()

    source = barkgen.branching.extract_structure(image, fissures)
    model = barkgen.branching.fit_model(source)
    grown = barkgen.branching.grow_structure(model, (128, 160), seed=9)  # (width, height)
    rendered = barkgen.branching.render_branches(image, source, grown, seed=9)

    barkgen.write_png(out_dir / "source.png", image)
    (out_dir / "source.json").write_text(json.dumps(source.to_dict()))
    barkgen.write_png(out_dir / "source_overlay.png", barkgen.branching.overlay_structure(image, source))
    (out_dir / "grown.json").write_text(json.dumps(grown.to_dict()))
    barkgen.write_png(out_dir / "rendered.png", rendered.image)
    barkgen.write_png(out_dir / "rendered_fissures.png", rendered.labels)
    stats = barkgen.branching.compare_structures(source, grown)
    print(
        f"from {origin}: {len(source.branches)} source branches, {len(grown.branches)} grown; "
        f"L1 distances of the angle / thickness histograms {stats.angle_l1:.2f} / "
        f"{stats.thickness_l1:.2f} (0 = equal, 2 = disjoint)"
    )


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "examples_out/08_branches"))
