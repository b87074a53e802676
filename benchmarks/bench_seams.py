#!/usr/bin/env python3
"""Straight seams and map cliffs where copied pieces meet, in one run.

    .venv/bin/python benchmarks/bench_seams.py [--quick] [--cases synth,big,crops,generate,maps]

Uses ``../shared/eval/seams.py`` on the reference maps barkgen writes: the longest straight seam
(a run of neighbouring output pixels along one row or column whose references are not
neighbours) and, for the material sets, each map's step ratio (mean step across piece borders
over mean step inside pieces; a photo has 1.0). An exemplar that tiles is measured with
``--wrap-exemplar`` (a reference stepping from its last row to its first continues the piece),
the others without. Cases:

1. ``synth``: 1024x1024 tiled from the bundled sample, seeds 0-3;
2. ``big``: 2048x2048 untiled from the sample, seed 0;
3. ``crops``: 256x256 centre crops of the shared photos -> 1024x1024 tiled, seeds 0 and 1;
4. ``generate``: ``generate`` 1024x1024 tiled from the sample, seeds 0-3 (longest seam);
5. ``maps``: ``generate --tile --material`` 1024x1024: step ratio of the texture and of
   Displacement, NormalGL, AO and Roughness, on the sample (seeds 0-3) and four shared photos.

Prints one table per case with the worst case and the median.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(SHARED / "eval"))
sys.path.insert(0, str(REPO / "benchmarks"))

import seams  # noqa: E402  (../shared/eval/seams.py)
from barkgen.io import read_centre_crop  # noqa: E402

from barkgen.data import sample_exemplar_path  # noqa: E402
from barkgen.io import read_image, write_reference  # noqa: E402
from barkgen.synth import SynthesisConfig, exemplar_wraps, synthesize  # noqa: E402

PHOTOS = sorted((SHARED / "data" / "bark").glob("*_01.*"))
MAP_PHOTOS = ("birch_smooth_lenticels_01.jpg", "oak_furrowed_moss_01.jpg",
              "pine_plated_01.jpg", "willow_furrowed_01.jpg")


def longest_seam(references: np.ndarray, exemplar_shape, tile: bool, wraps) -> dict:
    """seams.py's measure of one reference map (written to a temporary PNG, as a user would)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "ref.png"
        write_reference(path, references, exemplar_shape)
        return seams.measure(path, tile=tile, wrap_exemplar=bool(any(wraps)))


def row(name: str, m: dict, seconds: float) -> tuple:
    return (name, m["longest"], f"{m['where'][0]} {m['where'][1]}", f"{m['seam_share']:.3f}",
            f"{seconds:.1f}")


def table(title: str, header: tuple, rows: list, value_col: int = 1) -> None:
    print(f"\n{title}")
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
    print("  ".join(str(h).ljust(w) for h, w in zip(header, widths)))
    for r in rows:
        print("  ".join(str(v).ljust(w) for v, w in zip(r, widths)))
    values = [float(r[value_col]) for r in rows]
    print(f"worst {max(values):g}  median {statistics.median(values):g}")


def synth_case(name: str, exemplar: np.ndarray, size: int, tile: bool, seed: int) -> tuple:
    wraps = exemplar_wraps(exemplar)
    t0 = time.perf_counter()
    res = synthesize(exemplar, size, tile=tile, seed=seed, config=SynthesisConfig())
    dt = time.perf_counter() - t0
    m = longest_seam(res.references, res.exemplar_shape, tile, res.exemplar_wrap)
    return row(name + (" (wraps)" if any(wraps) else ""), m, dt)


def generate_case(name: str, photo: np.ndarray, seed: int, material: bool, size: int = 1024):
    from barkgen.pipeline import GenerateOptions, generate

    t0 = time.perf_counter()
    res = generate(photo, GenerateOptions(size=(size, size), tile=True, seed=seed,
                                          material=material))
    return res, time.perf_counter() - t0


def step_ratios(res, tile: bool = True) -> dict:
    """Step ratio of the texture and each map of the material set across the seams."""
    y, x = res.references[..., 0].astype(np.int64), res.references[..., 1].astype(np.int64)
    ex = res.report["photo_size"][::-1]
    hs, vs = seams.seam_masks(y, x, tuple(ex), tile, any(res.report["exemplar_wrap"]))
    mat = res.material
    maps = {"texture": res.texture, "Displacement": mat.height, "NormalGL": mat.normals,
            "AO": mat.ao, "Roughness": mat.roughness}
    out = {}
    for key, img in maps.items():
        img = np.asarray(img)
        scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(img.dtype, 1.0)
        img = img.astype(np.float64) / scale
        out[key] = seams.step_ratio(img if img.ndim == 3 else img[..., None], hs, vs, tile)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="synth,big,crops,generate,maps")
    ap.add_argument("--quick", action="store_true", help="seed 0 only, four photos for crops")
    a = ap.parse_args()
    cases = set(a.cases.split(","))
    sample = read_image(sample_exemplar_path())
    seeds = [0] if a.quick else [0, 1, 2, 3]
    print(f"sample {sample.shape[1]}x{sample.shape[0]}, exemplar_wraps (y, x) = "
          f"{exemplar_wraps(sample)}")
    header = ("case", "longest px", "where", "seam share", "s")
    if "synth" in cases:
        rows = [synth_case(f"sample 1024 tiled seed {s}", sample, 1024, True, s) for s in seeds]
        table("synth 1024x1024 tiled from the sample", header, rows)
    if "big" in cases:
        rows = [synth_case("sample 2048 untiled seed 0", sample, 2048, False, 0)]
        table("synth 2048x2048 untiled from the sample", header, rows)
    if "crops" in cases:
        photos = PHOTOS[:4] if a.quick else PHOTOS
        rows = []
        for p in photos:
            crop = read_centre_crop(p, 256)
            for s in ([0] if a.quick else [0, 1]):
                rows.append(synth_case(f"{p.stem} seed {s}", crop, 1024, True, s))
        table("synth 256x256 crop -> 1024x1024 tiled", header, rows)
    if "generate" in cases or "maps" in cases:
        grows, mrows = [], []
        for s in seeds:
            res, dt = generate_case(f"sample seed {s}", sample, s, material="maps" in cases)
            m = longest_seam(res.references, sample.shape[:2], True, res.report["exemplar_wrap"])
            grows.append(row(f"sample seed {s}", m, dt))
            if "maps" in cases:
                r = step_ratios(res)
                mrows.append((f"sample seed {s}", *(f"{r[k]:.2f}" for k in r)))
        if "generate" in cases:
            table("generate 1024x1024 tiled from the sample", header, grows)
        if "maps" in cases:
            for name in MAP_PHOTOS[:1] if a.quick else MAP_PHOTOS:
                photo = read_image(SHARED / "data" / "bark" / name)
                res, _ = generate_case(name, photo, 0, material=True)
                r = step_ratios(res)
                mrows.append((Path(name).stem + " seed 0", *(f"{r[k]:.2f}" for k in r)))
            head = ("case", "texture", "Displacement", "NormalGL", "AO", "Roughness")
            print("\nstep ratio across seams, generate --tile --material 1024x1024 (photo = 1.0)")
            widths = [max(len(str(r[i])) for r in mrows + [head]) for i in range(len(head))]
            print("  ".join(str(h).ljust(w) for h, w in zip(head, widths)))
            for r in mrows:
                print("  ".join(str(v).ljust(w) for v, w in zip(r, widths)))
            for i, h in enumerate(head[1:], start=1):
                vals = [float(r[i]) for r in mrows]
                print(f"{h}: worst {max(vals):.2f}  median {statistics.median(vals):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
