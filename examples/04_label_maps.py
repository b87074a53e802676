"""Label maps of a bark photo and a new label map of any size (:mod:`barkgen.labels`,
:mod:`barkgen.shapes`; laitoch2018 §3.5-3.6, wang2003 §3.2).

* colour regions: k-means of the denoised CIELAB colours (:func:`barkgen.labels.color_regions`),
  here with the extra edge label (``edges=True``, laitoch2018 §3.5.6);
* texton regions: filter-bank textons merged into k labels with no user step
  (:func:`barkgen.labels.texton_regions`);
* a preview of the photo tinted by label (:func:`barkgen.labels.label_preview`);
* a new, tileable 192x192 label map with the exemplar's shapes and label areas
  (:func:`barkgen.shapes.synthesize_label_map`, engine strategy), with its pyramid levels.

Run::

    python examples/04_label_maps.py OUTDIR

Writes ``OUTDIR/labels_color.png``, ``labels_color_edges.png``, ``labels_texton.png``,
``preview.png``, ``labels_out.png`` and ``labels_out_level_N.png`` for each pyramid level.
"""

import sys
from pathlib import Path

import numpy as np

import barkgen
import barkgen.labels
import barkgen.shapes


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    photo = barkgen.read_image(barkgen.sample_exemplar_path())[:128, :128]

    labels = barkgen.labels.color_regions(photo, 3, seed=0)
    with_edges = barkgen.labels.color_regions(photo, 3, edges=True, seed=0)
    textons = barkgen.labels.texton_regions(photo, 3, n_textons=12, seed=0)
    barkgen.write_png(out_dir / "labels_color.png", labels)
    barkgen.write_png(out_dir / "labels_color_edges.png", with_edges)
    barkgen.write_png(out_dir / "labels_texton.png", textons)
    barkgen.write_png(out_dir / "preview.png", barkgen.labels.label_preview(photo, labels))

    result = barkgen.shapes.synthesize_label_map(
        labels, canvas=barkgen.Canvas((192, 192), tile=True), budget=barkgen.Budget(seed=4)
    )
    barkgen.write_png(out_dir / "labels_out.png", result.label_map)
    for level, level_map in enumerate(result.levels):
        barkgen.write_png(out_dir / f"labels_out_level_{level}.png", level_map)
    for value in np.unique(labels):
        print(
            f"label {value}: {np.mean(labels == value):.0%} of the photo, "
            f"{np.mean(result.label_map == value):.0%} of the new map"
        )


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "examples_out/04_label_maps"))
