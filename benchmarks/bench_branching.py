"""Benchmark of branching structures (issue 8, sibbing2010): extraction, the statistical
model's growth and the fragment-based rendering, on the four crack images of
``../shared/data/branching`` and three fissured barks.

    .venv/bin/python benchmarks/bench_branching.py [--size 1024] [--seeds 3] [--render]
                                                   [--render-repeats 3] [--images STEM ...]
                                                   [--sheets DIR] [--json F]

Per image, in one process: extraction time; growth of ``--size``² structures (median time
over ``--seeds`` seeds, after a warm-up); the paper's Fig. 7 evaluation as numbers — L1
distance (0 = equal, 2 = disjoint) of the angle and thickness histograms (B = 16, source's
range) for the model and for a no-model baseline (a random walk with Gaussian turns of the
source's spread and the source's mean thickness, the same total length); crossings not
recorded as a merge; junctions (furcations + merges) and free ends (branch ends connected to
nothing, away from the border) per megapixel, source vs grown.
With ``--render``: the render of the first seed's structure at ``--size``² (median time of
``--render-repeats`` renders), the core engine's plain synthesis of the same image at the
same size (timed in the same process: how fast the machine was), coherence and sharpness
(:mod:`barkgen.evaluate`) of the render against the plain synthesis, and crack continuity: mean luminance
along the grown skeleton in the render over mean luminance along the source skeleton in the
image.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(REPO / "src"))

IMAGES = [
    SHARED / "data" / "branching" / n
    for n in ("cracked_earth_01.jpg", "dried_mud_01.jpg", "dried_mud_02.jpg", "mud_crackle_gray_01.png")
]
IMAGES += [
    SHARED / "data" / "bark" / n
    for n in ("fissured_gray_01.png", "vertical_fractures_01.png", "oak_furrowed_moss_01.jpg")
]


def random_walk_baseline(source, size: tuple[int, int], seed: int):
    """No model: walks from random points with Gaussian turns of the source's turning-angle
    spread, at the source's step and mean thickness, until the grown length is the source's
    length per pixel times the output area."""
    from barkgen.branching import Branch, Structure
    from barkgen.branching.stats import structure_values

    rng = np.random.default_rng(seed)
    angles, thickness = structure_values(source)
    w, h = size
    target = source.total_length() / (source.width * source.height) * w * h
    mean_len = source.total_length() / len(source.branches)
    n_steps = max(int(mean_len / source.step), 2)
    branches, grown = [], 0.0
    while grown < target:
        th = rng.uniform(-np.pi, np.pi)
        turns = rng.normal(0.0, angles.std(), n_steps)
        heading = th + np.cumsum(turns)
        xy = rng.uniform([0, 0], [w - 1, h - 1]) + source.step * np.cumsum(
            np.column_stack([np.cos(heading), np.sin(heading)]), axis=0
        )
        xy = np.vstack([xy[:1] - source.step * np.array([np.cos(th), np.sin(th)]), xy])
        branches.append(Branch(np.column_stack([xy, np.full(len(xy), thickness.mean())])))
        grown += branches[-1].length()
    return Structure(source.step, (w, h), branches)


def skeleton_luminance(image: np.ndarray, structure) -> float:
    """Mean CIELAB L along the 1-pixel skeleton of ``structure`` in ``image``."""
    import cv2

    from barkgen.color import rgb_to_lab

    rgb = image if image.ndim == 3 and image.shape[2] == 3 else np.repeat(image.reshape(*image.shape[:2], 1), 3, 2)
    lum = rgb_to_lab(rgb.astype(np.float32) / 255.0)[..., 0]
    mask = np.zeros(image.shape[:2], np.uint8)
    for b in structure.branches:
        cv2.polylines(mask, [np.round(b.xy).astype(np.int32)], False, 1, 1)
    return float(lum[mask > 0].mean())


def run_image(
    path: Path, size: int, seeds: list[int], render: bool, sheets: Path | None, render_repeats: int = 3
) -> dict:
    from barkgen.branching.extract import extract_structure, overlay_structure
    from barkgen.branching.grow import grow_structure
    from barkgen.branching.model import fit_model
    from barkgen.branching.stats import compare_structures
    from barkgen.io import read_image, write_png

    image = read_image(path)
    t0 = time.perf_counter()
    source = extract_structure(image)
    t_extract = time.perf_counter() - t0
    model = fit_model(source)
    grow_structure(model, (128, 128), seed=99)  # warm-up (numba cache load)
    times, grown = [], []
    for s in seeds:
        t0 = time.perf_counter()
        grown.append(grow_structure(model, (size, size), seed=s))
        times.append(time.perf_counter() - t0)
    cmps = [compare_structures(source, g) for g in grown]
    walks = [compare_structures(source, random_walk_baseline(source, (size, size), s)) for s in seeds]
    row = {
        "image": path.stem,
        "size": f"{image.shape[1]}x{image.shape[0]}",
        "extract_s": t_extract,
        "branches": len(source.branches),
        "step": source.step,
        "grow_s": statistics.median(times),
        "angle_l1": statistics.median(c.angle_l1 for c in cmps),
        "thickness_l1": statistics.median(c.thickness_l1 for c in cmps),
        "heading_l1": statistics.median(c.heading_l1 for c in cmps),
        "walk_heading_l1": statistics.median(c.heading_l1 for c in walks),
        "walk_angle_l1": statistics.median(c.angle_l1 for c in walks),
        "walk_thickness_l1": statistics.median(c.thickness_l1 for c in walks),
        "crossings": max(c.target_intersections for c in cmps),
        "free_ends_src": cmps[0].source_free_end_density,
        "free_ends_out": statistics.median(c.target_free_end_density for c in cmps),
        "junctions_src": cmps[0].source_junction_density,
        "junctions_out": statistics.median(c.target_junction_density for c in cmps),
        "merges_src": sum(b.joins is not None for b in source.branches) / (source.width * source.height / 1e6),
        "merges_out": statistics.median(
            sum(b.joins is not None for b in g.branches) / (size * size / 1e6) for g in grown
        ),
    }
    row["junction_ratio"] = row["junctions_out"] / max(row["junctions_src"], 1e-9)
    if sheets is not None:
        sheets.mkdir(parents=True, exist_ok=True)
        write_png(sheets / f"{path.stem}_extracted.png", overlay_structure(image, source))
    if render:
        from barkgen.branching.render import render_branches
        from barkgen.synth import synthesize

        rgb = image if image.shape[2] == 3 else np.repeat(image, 3, axis=2)
        render_times = []
        for _ in range(render_repeats):  # the same render: the median of the times
            t0 = time.perf_counter()
            result = render_branches(image, source, grown[0], seed=seeds[0])
            render_times.append(time.perf_counter() - t0)
        row["render_s"] = statistics.median(render_times)
        t0 = time.perf_counter()
        plain = synthesize(image, (size, size), seed=seeds[0]).image
        row["plain_s"] = time.perf_counter() - t0  # the core engine, same size, same process
        out = result.image if result.image.shape[2] == 3 else np.repeat(result.image, 3, axis=2)
        plain3 = plain if plain.shape[2] == 3 else np.repeat(plain, 3, axis=2)
        from barkgen.evaluate import coherence, sharpness_ratio

        row["coherence"] = coherence(out, rgb)
        row["coherence_plain"] = coherence(plain3, rgb)
        row["coherence_ratio"] = row["coherence"] / row["coherence_plain"]
        row["sharpness_ratio"] = sharpness_ratio(out, rgb) / sharpness_ratio(plain3, rgb)
        row["crack_lum_ratio"] = skeleton_luminance(out, grown[0]) / skeleton_luminance(rgb, source)
        if sheets is not None:
            write_png(sheets / f"{path.stem}_render.png", out)
            write_png(sheets / f"{path.stem}_plain.png", plain3)
            write_png(sheets / f"{path.stem}_labels.png", result.labels)
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--render", action="store_true")
    parser.add_argument("--sheets", type=Path)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--render-repeats", type=int, default=3, help="renders timed per image (median)")
    parser.add_argument("--images", nargs="*", help="only these image stems")
    args = parser.parse_args()
    rows = []
    for path in IMAGES:
        if args.images and path.stem not in args.images:
            continue
        rows.append(run_image(path, args.size, list(range(args.seeds)), args.render, args.sheets, args.render_repeats))
        r = rows[-1]
        print(
            f"{r['image']:26s} extract {r['extract_s']:5.2f}s  grow {r['grow_s']:5.2f}s  "
            f"L1 angle {r['angle_l1']:.3f} (walk {r['walk_angle_l1']:.3f})  "
            f"L1 thickness {r['thickness_l1']:.3f} (walk {r['walk_thickness_l1']:.3f})  "
            f"crossings {r['crossings']}  junctions/Mpx {r['junctions_src']:.0f} -> {r['junctions_out']:.0f} "
            f"({r['junction_ratio']:.2f}x)  merges/Mpx {r['merges_src']:.0f} -> {r['merges_out']:.0f}  "
            f"free ends/Mpx {r['free_ends_src']:.0f} -> {r['free_ends_out']:.0f}"
            + (
                f"  render {r['render_s']:5.2f}s (plain synthesis {r['plain_s']:4.2f}s) coherence {r['coherence_ratio']:.2f}x sharpness "
                f"{r['sharpness_ratio']:.2f}x crack lum {r['crack_lum_ratio']:.2f}"
                if args.render
                else ""
            ),
            flush=True,
        )
    keys = [
        "grow_s",
        "angle_l1",
        "thickness_l1",
        "heading_l1",
        "walk_angle_l1",
        "walk_thickness_l1",
        "walk_heading_l1",
        "junction_ratio",
    ]
    if args.render:
        keys += ["render_s", "plain_s", "coherence_ratio", "sharpness_ratio", "crack_lum_ratio"]
    print("\n| image | " + " | ".join(keys) + " |")
    print("|---" * (len(keys) + 1) + "|")
    for r in rows:
        print(
            f"| {r['image']} | "
            + " | ".join(f"{r[k]:.3f}" if isinstance(r[k], float) else str(r[k]) for k in keys)
            + " |"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
