#!/usr/bin/env python3
"""A painted stroke kept through ``--resume``, under each output-label-map strategy.

    .venv/bin/python benchmarks/bench_resume.py [--photos NAME ...] [--seeds 3 4] [--size 256] [--json F]

For each photo (256 px, 3 colour labels) and strategy (``joint``, generate's default; ``engine``;
``layered``): a tileable label map of ``--size``, then a horizontal stroke 4 px wide across the
middle two thirds of its level 3, painted with the darkest label and again with the lightest, and
the synthesis resumed from that level (laitoch2018 §1: the artist steers the large-scale layout).
``kept`` is the share of the stroke's pixels (at full size) that hold its label in the final
map, worst and mean over seeds and labels (target: at least 90 % under every strategy);
``held`` the share of the whole map equal to the edited level brought to full size (the rest is
the solver's own boundary detail).
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

from barkgen.io import read_centre_crop  # noqa: E402
from barkgen.labels import color_regions  # noqa: E402
from barkgen.shapes import Budget, Canvas, synthesize_label_map  # noqa: E402
from barkgen.shapes.engine import upsample_codes  # noqa: E402

PHOTOS = ("fir_scaly_01", "oak_furrowed_moss_01", "pine_plated_01", "willow_furrowed_01")
STRATEGIES = ("joint", "engine", "layered")
LEVEL = 3


def photo_256(name: str) -> np.ndarray:
    """The photo's centre crop, its short side at 256 px (as the tests read it)."""
    return read_centre_crop(next((SHARED / "data" / "bark").glob(name + ".*")), 256)


def measure(photo: np.ndarray, strategy: str, seeds: list[int], size: int) -> dict:
    labels = color_regions(photo, 3, seed=0)
    values = np.unique(labels)
    given = photo if strategy == "joint" else None
    kept, held = [], []
    start = time.perf_counter()
    for seed in seeds:
        base = synthesize_label_map(
            labels, canvas=Canvas((size, size), tile=True), strategy=strategy, photo=given, budget=Budget(seed=seed)
        )
        edited = base.levels[LEVEL].copy()
        h, w = edited.shape
        stroke = np.zeros_like(edited, bool)
        stroke[h // 2 - 2 : h // 2 + 2, w // 6 : 5 * w // 6] = True
        big = np.kron(stroke, np.ones((2**LEVEL, 2**LEVEL), bool))
        for value in (values[0], values[-1]):
            painted = edited.copy()
            painted[stroke] = value
            out = synthesize_label_map(
                labels,
                canvas=Canvas((size, size), tile=True),
                strategy=strategy,
                resume=(LEVEL, painted),
                photo=given,
                budget=Budget(seed=seed),
            ).label_map
            wanted = values[
                upsample_codes(np.searchsorted(values, painted), Canvas((size, size), tile=True), values.size)
            ]
            kept.append(float(np.mean(out[big] == value)))
            held.append(float(np.mean(out == wanted)))
    return {
        "kept_min": min(kept),
        "kept_mean": statistics.mean(kept),
        "held_mean": statistics.mean(held),
        "seconds": time.perf_counter() - start,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--photos", nargs="*", default=list(PHOTOS))
    parser.add_argument("--seeds", type=int, nargs="*", default=[3, 4])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if not (SHARED / "data" / "bark").is_dir():
        raise SystemExit(f"needs the team's bark photos in {SHARED}/data/bark (set BARKGEN_SHARED)")
    rows = []
    print(f"{'photo':24} {'strategy':8} {'kept worst':>10} {'kept mean':>9} {'held':>5} {'seconds':>7}")
    for name in args.photos:
        photo = photo_256(name)
        for strategy in STRATEGIES:
            row = {"photo": name, "strategy": strategy, **measure(photo, strategy, args.seeds, args.size)}
            rows.append(row)
            print(
                f"{name:24} {strategy:8} {row['kept_min']:10.1%} {row['kept_mean']:9.1%} "
                f"{row['held_mean']:5.2f} {row['seconds']:7.1f}",
                flush=True,
            )
    print("kept: the stroke's pixels holding its label (target >= 90 % under every strategy)")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
