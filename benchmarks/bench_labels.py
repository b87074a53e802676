#!/usr/bin/env python3
"""Label-map benchmark (issue 4): every photo of ``../shared/data/bark`` at full size, k = 2 and
3, colour regions and texton channels; prints a table of label coverage, smallest region,
half-split classifier accuracy (labels follow appearance) and time, plus the speed on a 1024x1024
photo (medians over ``--runs``), and writes a contact sheet of the k = 3 colour-region previews.

    .venv/bin/python benchmarks/bench_labels.py [--sheet previews.png] [--runs 3] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from barkgen.io import read_image, write_png  # noqa: E402
from barkgen.labels import (  # noqa: E402
    color_regions,
    contact_sheet,
    label_preview,
    texton_channels,
    texton_regions,  # noqa: E402
)
from barkgen.labels.regions import default_min_region  # noqa: E402
from barkgen.testing import half_split_accuracy, label_fractions, smallest_region  # noqa: E402

METHODS = {"color": color_regions, "texton": texton_regions}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sheet", default=None, help="write the contact sheet of previews here")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    bark = SHARED / "data" / "bark"
    if not bark.is_dir():
        print(f"needs the team's shared folder at {SHARED} (set BARKGEN_SHARED)", file=sys.stderr)
        return 2
    rows, previews, names = [], [], []
    print("| photo | size | method | k | label coverage | smallest region (min) | half-split accuracy | time |")
    print("|---|---|---|---|---|---|---|---|")
    for path in sorted(p for p in bark.iterdir() if p.suffix.lower() in (".jpg", ".png")):
        img = read_image(path)
        for method, fn in METHODS.items():
            for k in (2, 3):
                t = time.perf_counter()
                lm = fn(img, k, seed=0)
                dt = time.perf_counter() - t
                same = bool((fn(img, k, seed=0) == lm).all())
                row = {
                    "photo": path.stem,
                    "method": method,
                    "k": k,
                    "time": dt,
                    "coverage": [float(f) for f in label_fractions(lm)],
                    "smallest": smallest_region(lm),
                    "min_region": default_min_region(lm.shape),
                    "accuracy": half_split_accuracy(img, lm),
                    "same_seed_same_map": same,
                }
                rows.append(row)
                print(
                    f"| {path.stem} | {img.shape[1]}x{img.shape[0]} | {method} | {k} | "
                    f"{' / '.join(f'{f:.2f}' for f in row['coverage'])} | {row['smallest']} "
                    f"({row['min_region']}) | {row['accuracy']:.3f} | {dt:.2f} s |",
                    flush=True,
                )
                if method == "color" and k == 3:
                    previews.append(label_preview(img, lm))
                    names.append(path.stem)
    print()
    print("| criterion | colour | texton |")
    print("|---|---|---|")
    for name, test in (
        ("every label >= 5 %", lambda r: min(r["coverage"]) >= 0.05),
        ("no region under the minimum", lambda r: r["smallest"] >= r["min_region"]),
        ("same seed, same map", lambda r: r["same_seed_same_map"]),
        ("k = 2 half-split accuracy >= 0.9", lambda r: r["k"] != 2 or r["accuracy"] >= 0.9),
    ):
        cells = []
        for method in METHODS:
            sel = [r for r in rows if r["method"] == method]
            if name.startswith("k = 2"):
                sel = [r for r in sel if r["k"] == 2]
            cells.append(f"{sum(test(r) for r in sel)}/{len(sel)}")
        print(f"| {name} | {' | '.join(cells)} |")

    # speed on a 1024x1024 photo
    from barkgen.io import read_centre_crop

    img = read_centre_crop(bark / "pine_plated_01.jpg", 1024)
    times = {"colour regions, k = 3": [], "texton channels, 36 filters, K = 25": []}
    for _ in range(a.runs):
        t = time.perf_counter()
        color_regions(img, 3, seed=0)
        times["colour regions, k = 3"].append(time.perf_counter() - t)
        t = time.perf_counter()
        texton_channels(img, 25, seed=0)
        times["texton channels, 36 filters, K = 25"].append(time.perf_counter() - t)
    print()
    print(f"| 1024x1024 photo, median of {a.runs} | time |")
    print("|---|---|")
    for name, ts in times.items():
        print(f"| {name} | {statistics.median(ts):.2f} s |")
    if a.sheet:
        write_png(a.sheet, contact_sheet(previews, names, columns=2, tile_size=480))
    if a.json:
        Path(a.json).write_text(
            json.dumps({"rows": rows, "speed": {k: statistics.median(v) for k, v in times.items()}}, indent=1)
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
