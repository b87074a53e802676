"""Bi-layer textures without bounds (:mod:`barkgen.bilayer`, guingo2017).

A photo is analysed once into a structure layer ``P`` plus spatially varying Gaussian noise
(``I = P + sum_k M_k N_k``); the model then synthesizes any window of an unbounded plane on the
fly. Pixels depend only on their coordinates, the seed and the options, so two windows that
overlap agree exactly there. A deformed synthesis rotates and zooms the structure while the
fine grain keeps the photo's scale. The model is saved and read back with
:func:`barkgen.io.write_bilayer_model` / :func:`barkgen.io.read_bilayer_model`.

Run::

    python examples/07_bilayer.py OUTDIR

Writes ``OUTDIR/model.npz``, ``analysis.png`` (exemplar, P, N, masks, spectra),
``window_0_0.png`` and ``window_64_0.png`` (128x128 each, overlapping by 64 px),
``deformed.png`` (128x128) and ``structure.png`` / ``noise.png`` (the layers of window 0, 0).
"""

import sys
from pathlib import Path

import numpy as np

import barkgen
import barkgen.bilayer
import barkgen.io


def to_uint8(image: np.ndarray) -> np.ndarray:
    return np.round(np.clip(image, 0.0, 1.0) * 255).astype(np.uint8)


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    photo = barkgen.read_image(barkgen.sample_exemplar_path())[:128, :128]

    model = barkgen.bilayer.analyze(photo, barkgen.bilayer.AnalysisOptions(k=2, tloc=4))
    barkgen.io.write_bilayer_model(out_dir / "model.npz", model)
    model = barkgen.io.read_bilayer_model(out_dir / "model.npz")

    left = model.window(0, 0, 128, 128, seed=8, layers=True)
    right = model.window(64, 0, 128, 128, seed=8)  # continues ``left`` to the right
    assert np.array_equal(left["texture"][:, 64:], right[:, :64])
    deformation = barkgen.bilayer.Deformation(rotate=15.0, scale=(1.0, 1.5), keep_vertical=True)
    deformed = model.window(0, 0, 128, 128, seed=8, options=barkgen.bilayer.SynthesisOptions(deformation=deformation))

    sheet = barkgen.bilayer.analysis_preview(model, left["texture"])
    barkgen.write_png(out_dir / "analysis.png", sheet)
    barkgen.write_png(out_dir / "window_0_0.png", to_uint8(left["texture"]))
    barkgen.write_png(out_dir / "window_64_0.png", to_uint8(right))
    barkgen.write_png(out_dir / "deformed.png", to_uint8(deformed))
    barkgen.write_png(out_dir / "structure.png", to_uint8(left["structure"]))
    barkgen.write_png(out_dir / "noise.png", to_uint8(left["noise"] + 0.5))
    print(f"bi-layer model with {model.k} noises and four images in {out_dir}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "examples_out/07_bilayer"))
