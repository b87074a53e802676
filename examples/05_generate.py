"""The one-click pipeline, photo -> new bark, for several seeds of one photo
(:func:`barkgen.pipeline.analyze_photo`, :func:`barkgen.generate`; laitoch2018 Figure 1.2).

``analyze_photo`` does the per-photo work once (the photo's label map and the k-coherence
analyses of both solvers); ``generate`` then makes the output label map and the texture that
follows it for each seed, and gives the same bytes as a ``generate`` without the shared
analysis. ``encode_generate`` encodes the files of one run exactly as ``barkgen generate``
writes them and ``barkgen.io.write_folder_atomic`` writes them as one step.

Run::

    python examples/05_generate.py OUTDIR

Writes ``OUTDIR/seed_5/`` and ``OUTDIR/seed_6/``, each with ``texture.png`` (128x128, tileable),
``labels_in.png``, ``labels_out.png``, ``reference.png``, ``preview.png`` and ``report.json``.
"""

import dataclasses
import sys
from pathlib import Path

import barkgen
import barkgen.io
import barkgen.pipeline


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    photo = barkgen.read_image(barkgen.sample_exemplar_path())[:128, :128]
    options = barkgen.GenerateOptions(size=(128, 128), k=3, tile=True)

    analysis = barkgen.pipeline.analyze_photo(photo, options)  # once per photo
    print(f"photo analysed in {analysis.seconds:.1f} s")
    for seed in (5, 6):
        seed_options = dataclasses.replace(options, seed=seed)
        result = barkgen.generate(photo, seed_options, analysis=analysis)
        files = barkgen.pipeline.encode_generate(photo, result, source="sample_bark.jpg (crop)")
        barkgen.io.write_folder_atomic(out_dir / f"seed_{seed}", files)
        print(f"seed {seed}: {sorted(files)} ({result.report['timings_s']['total']:.1f} s)")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "examples_out/05_generate"))
