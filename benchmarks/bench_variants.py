"""Benchmark of generate's cracks and bi-layer textures (issue 35), tileable, with material sets.

    .venv/bin/python benchmarks/bench_variants.py [--case cracks|bilayer|all] [--size 1024]
                                                  [--seed 0] [--quick] [--images STEM ...]
                                                  [--render] [--json F]

``--case cracks``: ``generate --structure cracks --tile --material`` on the four crack images of
``../shared/data/branching`` and two cracked barks. Per image: seconds; the tile border's step
ratio (:func:`barkgen.evaluate.wrap_step_ratio`, 1 = no seam when tiled); the grown network against the photo's (sibbing2010 Fig. 7 as
numbers: L1 of the turning-angle and thickness histograms, 0 = equal, 2 = disjoint; crossings
not recorded as a merge, counted on the torus; free ends per megapixel, grown over the photo's);
coherence (:func:`barkgen.evaluate.coherence`) over that of the core engine's plain tileable synthesis of the same photo, size
and seed in the same run (the ratio the branching issue measured at 3.2-12.8x for fragment
renders); the material's mean height in the cracks over outside (below 0: cracks are low); the
crack share: of the new network's pixels, those filled with crack pixels of the photo (its label
map's, through the reference map, :func:`barkgen.evaluate.label_share`) and how the copied
cracks run against the new network's (:func:`barkgen.evaluate.direction_agreement`: 1 parallel,
0 unrelated).
With ``--render``: the fragment render (sibbing2010 §5) of the same grown network, untiled (it
has no torus), and its coherence ratio beside.

``--case bilayer``: ``generate --model bilayer --tile --material`` on three barks. Per photo:
seconds, ``seam_ratio``, the coherence ratio against plain synthesis, and the largest step
ratio of the material set's maps (:func:`barkgen.evaluate.border_step_ratio`: mean step across
piece borders over inside pieces, as the seamless issue measures it).

``--quick``: 512² and two images per case.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(REPO / "src"))

CRACKS = [
    SHARED / "data" / "branching" / n
    for n in ("cracked_earth_01.jpg", "dried_mud_01.jpg", "dried_mud_02.jpg", "mud_crackle_gray_01.png")
] + [SHARED / "data" / "bark" / n for n in ("fissured_gray_01.png", "vertical_fractures_01.png")]
BILAYER = [
    SHARED / "data" / "bark" / n
    for n in ("lichen_covered_01.jpg", "birch_smooth_lenticels_01.jpg", "pine_plated_01.jpg")
]


def plain_coherence(photo: np.ndarray, size: int, seed: int) -> float:
    """The coherence of the core engine's plain tileable synthesis of ``photo``."""
    from barkgen.evaluate import coherence
    from barkgen.synth import synthesize

    return coherence(synthesize(photo, (size, size), tile=True, seed=seed).image, photo, wrap=True)


def material_steps(result, exemplar_shape) -> dict[str, float]:
    """The step ratio of the texture and each material map across the run's piece borders (the
    photo taken as wrapping along the axes it wraps along)."""
    from barkgen.evaluate import border_step_ratio

    wraps = result.report["exemplar_wrap"]
    periods = tuple(int(n) if w else 0 for n, w in zip(exemplar_shape, wraps))
    m = result.material
    maps = {"color": m.color, "height": m.height, "normals": m.normals, "ao": m.ao, "roughness": m.roughness}
    return {
        name: border_step_ratio(np.asarray(img, np.float64), result.references, tile=True, exemplar_wrap=periods)
        for name, img in maps.items()
    }


def run_cracks(path: Path, size: int, seed: int, render: bool) -> dict:
    from barkgen.branching import compare_structures, extract_structure, self_intersections
    from barkgen.evaluate import coherence, direction_agreement, label_share, wrap_step_ratio
    from barkgen.io import read_image
    from barkgen.pipeline import GenerateOptions, analyze_photo, generate

    photo = read_image(path)
    options = GenerateOptions(size=(size, size), structure="cracks", tile=True, seed=seed, material=True)
    t0 = time.perf_counter()
    analysis = analyze_photo(photo, options)
    result = generate(photo, options, analysis=analysis)
    seconds = time.perf_counter() - t0
    source = extract_structure(photo)
    cmp = compare_structures(source, result.cracks)
    plain = plain_coherence(photo, size, seed)
    crack = result.labels_out == 0
    height = result.material.height
    row = {
        "image": path.stem,
        "seconds": round(seconds, 1),
        "seam_ratio": wrap_step_ratio(result.texture),
        "angle_l1": cmp.angle_l1,
        "thickness_l1": cmp.thickness_l1,
        "crossings": self_intersections(result.cracks),
        "free_ends_ratio": cmp.target_free_end_density / max(cmp.source_free_end_density, 1e-9),
        "coherence_ratio": coherence(result.texture, photo, wrap=True) / plain,
        "crack_height": float((height[crack].mean() - height[~crack].mean()) / max(float(height.std()), 1e-9)),
        # the new network's pixels filled with crack pixels of the photo (its label map's)
        "crack_share": label_share(result.labels_in, result.labels_out, result.references, 0),
        # the copied cracks run the way the new network's do (1: parallel, 0: unrelated)
        "crack_direction": direction_agreement(result.labels_in, result.labels_out, result.references, 0, tile=True),
    }
    if render:
        from barkgen.branching import render_branches
        from barkgen.branching.structure import Structure

        flat = Structure(result.cracks.step, result.cracks.size, result.cracks.branches)  # no torus
        rendered = render_branches(photo, source, flat, seed=seed).image
        row["render_coherence_ratio"] = coherence(rendered, photo) / plain
    return row


def run_bilayer(path: Path, size: int, seed: int) -> dict:
    from barkgen.evaluate import coherence, wrap_step_ratio
    from barkgen.io import read_image
    from barkgen.pipeline import GenerateOptions, analyze_photo, generate

    photo = read_image(path)
    options = GenerateOptions(size=(size, size), model="bilayer", tile=True, seed=seed, material=True)
    t0 = time.perf_counter()
    analysis = analyze_photo(photo, options)
    result = generate(photo, options, analysis=analysis)
    seconds = time.perf_counter() - t0
    steps = material_steps(result, photo.shape[:2])
    worst = max(steps, key=lambda k: steps[k])
    return {
        "image": path.stem,
        "seconds": round(seconds, 1),
        "seam_ratio": wrap_step_ratio(result.texture),
        "coherence_ratio": coherence(result.texture, photo, wrap=True) / plain_coherence(photo, size, seed),
        "worst_step": steps[worst],
        "worst_map": worst,
        "noise_std": float(result.layers["noise"].std()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", choices=("cracks", "bilayer", "all"), default="all")
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="512² and two images per case")
    parser.add_argument("--images", nargs="*", help="only these stems")
    parser.add_argument("--render", action="store_true", help="also the fragment render of the grown network")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    size = 512 if args.quick else args.size
    rows: list[dict] = []

    def chosen(paths: list[Path]) -> list[Path]:
        paths = [p for p in paths if not args.images or p.stem in args.images]
        return paths[:2] if args.quick else paths

    if args.case in ("cracks", "all"):
        print(f"cracks, tiled, {size}x{size}, seed {args.seed}")
        print(
            f"{'image':28} {'s':>6} {'seam':>6} {'angle L1':>8} {'thick L1':>8} {'cross':>5} "
            f"{'free ends':>9} {'coh/plain':>9} {'crack h':>8} {'share':>6} {'dir':>5}"
            + ("  render coh/plain" if args.render else "")
        )
        for path in chosen(CRACKS):
            r = run_cracks(path, size, args.seed, args.render)
            rows.append({"case": "cracks", **r})
            print(
                f"{r['image']:28} {r['seconds']:6.1f} {r['seam_ratio']:6.3f} {r['angle_l1']:8.3f} "
                f"{r['thickness_l1']:8.3f} {r['crossings']:5d} {r['free_ends_ratio']:8.2f}x "
                f"{r['coherence_ratio']:8.2f}x {r['crack_height']:+8.2f} {100 * r['crack_share']:5.1f}% {r['crack_direction']:5.2f}"
                + (f"  {r['render_coherence_ratio']:.2f}x" if args.render else ""),
                flush=True,
            )
    if args.case in ("bilayer", "all"):
        print(f"bilayer, tiled, {size}x{size}, seed {args.seed}")
        print(f"{'image':28} {'s':>6} {'seam':>6} {'coh/plain':>9} {'worst step':>10} {'map':>9} {'noise std':>9}")
        for path in chosen(BILAYER):
            r = run_bilayer(path, size, args.seed)
            rows.append({"case": "bilayer", **r})
            print(
                f"{r['image']:28} {r['seconds']:6.1f} {r['seam_ratio']:6.3f} {r['coherence_ratio']:8.2f}x "
                f"{r['worst_step']:10.2f} {r['worst_map']:>9} {r['noise_std']:9.4f}",
                flush=True,
            )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
