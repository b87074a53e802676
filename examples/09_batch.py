"""A small forest of unique barks on Dask (:mod:`barkgen.batch`, ``barkgen batch``;
mazzolini2012 §3.1.1). Needs the ``[batch]`` extra (Dask, PyYAML); skipped with a message
without it.

The spec is the mapping a ``forest.yaml`` would hold (here written as ``spec.json``, which is
YAML too): one photo, three seeds, 96x96 tileable output. :func:`barkgen.batch.run_batch` starts
an embedded Dask LocalCluster (one worker process with one thread here, to keep it quick),
analyses the photo once, makes every variant on the workers and writes each folder atomically,
recording it in ``OUTDIR/forest/manifest.sqlite``; a second run finds nothing to do.

Run::

    python examples/09_batch.py OUTDIR

Writes ``OUTDIR/photos/pine.png``, ``OUTDIR/spec.json`` and ``OUTDIR/forest/pine/<seed>/`` for
seeds 10, 11 and 12, each with the files of ``barkgen generate`` (``texture.png``,
``labels_in.png``, ``labels_out.png``, ``reference.png``, ``preview.png``, ``report.json``),
plus ``OUTDIR/forest/manifest.sqlite``.
"""

import json
import sys
from pathlib import Path

SPEC = {
    "size": "96x96",
    "tile": True,
    "k": 3,
    "material": False,
    "exemplars": [{"name": "pine", "path": "photos/pine.png", "seeds": [10, 11, 12]}],
}


def main(out_dir: Path) -> None:
    try:
        import barkgen.batch
    except barkgen.errors.MissingExtraError as exc:
        print(f"skipped: {exc}")
        return
    (out_dir / "photos").mkdir(parents=True, exist_ok=True)
    photo = barkgen.read_image(barkgen.sample_exemplar_path())[:128, :128]
    barkgen.write_png(out_dir / "photos" / "pine.png", photo)
    (out_dir / "spec.json").write_text(json.dumps(SPEC, indent=2) + "\n")

    spec = barkgen.batch.load_spec(out_dir / "spec.json")
    report = barkgen.batch.run_batch(spec, out_dir / "forest", workers=1, threads=1, log=print)
    print(f"made {report.made} of {report.total} variants in {report.seconds:.1f} s, {len(report.failed)} failed")
    again = barkgen.batch.run_batch(spec, out_dir / "forest", workers=1, threads=1, log=print)
    assert again.made == 0 and again.skipped == again.total


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "examples_out/09_batch"))
