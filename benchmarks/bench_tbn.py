#!/usr/bin/env python3
"""Texture-by-numbers benchmark: label fidelity, sharpness, coherence and speed, in one run.

    .venv/bin/python benchmarks/bench_tbn.py [--photos a,b] [--sizes 512,1024] [--runs 5]
                                              [--json out.json] [--skip-quality] [--skip-speed]

Quality (issue 3's acceptance set, :mod:`barkgen.testing`): for every photo of
``../shared/data/bark``, a 256x256 centre crop, its 2- and 3-label maps (NL-means, k-means on
CIELAB, 3x3 mode filter; laitoch2018 §3.5) and target label maps made of the crop's own label map
cut into 64-px blocks, shuffled, flipped and assembled to each size. Scored with the team's
``texeval`` (``--labels-in A --labels-out B``) against the unguided synthesis of the same size in
the same run: label_fidelity_ratio (>= 0.9), label_fidelity_balanced (>= 0.85), sharpness_ratio
(0.9-1.1; beside it the same references copied exactly, `blend="none"`), coherence / unguided coherence (<= 1.25); and the same photo with random
initialisation (at the first size) for the smart-vs-random comparison. The known answer (the
exemplar's own pixels arranged like the target's blocks) is scored alongside: it shows what the
metrics allow on each case.

Speed: 256x256 pine exemplar, 1024x1024 target label map: texture_by_numbers against synthesize of
the same size, in process, interleaved, medians over ``--runs``; ratio (target <= 2).
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

from barkgen.io import read_centre_crop  # noqa: E402
from barkgen.synth import Budget, synthesize, texture_by_numbers  # noqa: E402
from barkgen.testing import kmeans_label_map, shuffled_blocks  # noqa: E402

PHOTO_SUFFIXES = {".jpg", ".jpeg", ".png"}


def photos() -> list[Path]:
    return sorted(p for p in (SHARED / "data" / "bark").iterdir() if p.suffix.lower() in PHOTO_SUFFIXES)


def quality(names: list[str] | None, sizes: list[int]) -> list[dict]:
    sys.path.insert(0, str(SHARED / "eval"))
    import texeval

    rows = []
    for path in photos():
        if names and path.stem not in names:
            continue
        ex = read_centre_crop(path, 256)
        for n_labels in (2, 3):
            a = kmeans_label_map(ex, n_labels)
            ev = texeval.TexEval(ex, labels_in=a)
            for i, size in enumerate(sizes):
                b = shuffled_blocks(a, size, seed=1)
                # the known answer: the exemplar's own blocks in the target's arrangement (the
                # same generator draws, so the same shuffle and flips)
                smart = texture_by_numbers(ex, a, b, budget=Budget(seed=0))
                runs = {
                    "answer": shuffled_blocks(ex, size, seed=1),
                    "unguided": synthesize(ex, size, seed=0).image,
                    "smart": smart.image,
                    # the same references, the colour copied exactly (``blend="none"``)
                    "unblended": ex[smart.references[..., 0], smart.references[..., 1]],
                }
                if i == 0:
                    runs["random"] = texture_by_numbers(ex, a, b, budget=Budget(seed=0), init="random").image
                m = {k: ev.evaluate(img, labels_out=b) for k, img in runs.items()}
                row = {"photo": path.stem, "labels": n_labels, "size": size}
                for k, r in m.items():
                    row[k] = {
                        key: r[key]
                        for key in (
                            "coherence",
                            "completeness",
                            "sharpness_ratio",
                            "label_fidelity",
                            "label_fidelity_train",
                            "label_fidelity_ratio",
                            "label_fidelity_balanced",
                            "largest_copy",
                        )
                    }
                rows.append(row)
                s, u = row["smart"], row["unguided"]
                print(
                    f"  {path.stem:28s} {n_labels} labels {size:5d}: fidelity {s['label_fidelity_ratio']:.3f}"
                    f" balanced {s['label_fidelity_balanced']:.3f} sharp {s['sharpness_ratio']:.3f}"
                    f" (unblended {row['unblended']['sharpness_ratio']:.3f})"
                    f" coherence {s['coherence']:.2f} / unguided {u['coherence']:.2f}"
                    f" = {s['coherence'] / u['coherence']:.2f}x",
                    file=sys.stderr,
                    flush=True,
                )
    return rows


def speed(runs: int) -> dict:
    ex = read_centre_crop(SHARED / "data" / "bark" / "pine_plated_01.jpg", 256)
    a = kmeans_label_map(ex, 3)
    b = shuffled_blocks(a, 1024, seed=1)
    texture_by_numbers(ex, a, shuffled_blocks(a, 128, seed=1))  # compile / load the numba cache
    synthesize(ex, 128)
    tbn, plain = [], []
    for i in range(runs):
        t = time.perf_counter()
        synthesize(ex, 1024, seed=i)
        plain.append(time.perf_counter() - t)
        t = time.perf_counter()
        texture_by_numbers(ex, a, b, budget=Budget(seed=i))
        tbn.append(time.perf_counter() - t)
    return {"tbn": statistics.median(tbn), "unguided": statistics.median(plain), "runs": runs}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photos", default=None, help="comma-separated photo names (default: all)")
    ap.add_argument("--sizes", default="512,1024")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--json", default=None, help="also write all figures to this file")
    ap.add_argument("--skip-quality", action="store_true")
    ap.add_argument("--skip-speed", action="store_true")
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    if not (SHARED / "data" / "bark").is_dir():
        print(f"needs the team's shared folder at {SHARED} (set BARKGEN_SHARED)", file=sys.stderr)
        return 2
    names = a.photos.split(",") if a.photos else None
    sizes = [int(s) for s in a.sizes.split(",")]
    out: dict = {}
    if not a.skip_quality:
        out["quality"] = rows = quality(names, sizes)
        print(
            "| photo | labels | size | fidelity ratio | balanced | sharpness (unblended) | coherence (x unguided)"
            " | random init: fidelity / coherence | known answer: fidelity / balanced / coherence / sharpness |"
        )
        print("|---|---|---|---|---|---|---|---|---|")
        for r in rows:
            s, u = r["smart"], r["unguided"]
            rnd = r.get("random")
            rtxt = f"{rnd['label_fidelity_ratio']:.3f} / {rnd['coherence']:.2f}" if rnd else ""
            k = r["answer"]
            ktxt = (
                f"{k['label_fidelity_ratio']:.3f} / {k['label_fidelity_balanced']:.3f} / "
                f"{k['coherence']:.2f} ({k['coherence'] / u['coherence']:.2f}x) / {k['sharpness_ratio']:.3f}"
            )
            print(
                f"| {r['photo']} | {r['labels']} | {r['size']} | {s['label_fidelity_ratio']:.3f} | "
                f"{s['label_fidelity_balanced']:.3f} | {s['sharpness_ratio']:.3f}"
                f" ({r['unblended']['sharpness_ratio']:.3f}) | "
                f"{s['coherence']:.2f} ({s['coherence'] / u['coherence']:.2f}x) | {rtxt} | {ktxt} |"
            )
        n = len(rows)
        passed = {
            "fidelity ratio >= 0.9": sum(r["smart"]["label_fidelity_ratio"] >= 0.9 for r in rows),
            "balanced >= 0.85": sum(r["smart"]["label_fidelity_balanced"] >= 0.85 for r in rows),
            "sharpness 0.9-1.1": sum(0.9 <= r["smart"]["sharpness_ratio"] <= 1.1 for r in rows),
            "coherence <= 1.25x unguided": sum(
                r["smart"]["coherence"] <= 1.25 * r["unguided"]["coherence"] for r in rows
            ),
        }
        with_random = [r for r in rows if "random" in r]
        wins_coh = sum(r["smart"]["coherence"] < r["random"]["coherence"] for r in with_random)
        wins_fid = sum(r["smart"]["label_fidelity"] > r["random"]["label_fidelity"] for r in with_random)
        print()
        print("| criterion | cases passed |")
        print("|---|---|")
        for k, v in passed.items():
            print(f"| {k} | {v}/{n} |")
        print(f"| smart beats random on coherence | {wins_coh}/{len(with_random)} |")
        print(f"| smart beats random on label fidelity | {wins_fid}/{len(with_random)} |")
        for who in ("smart", "answer"):
            ratios = [r[who]["coherence"] / r["unguided"]["coherence"] for r in rows]
            print(
                f"| median coherence / unguided, {'barkgen' if who == 'smart' else 'known answer'}"
                f" | {statistics.median(ratios):.2f}x |"
            )
        for key, name in (("label_fidelity_ratio", "fidelity ratio"), ("label_fidelity_balanced", "balanced")):
            ok = sum(r["smart"][key] >= r["answer"][key] - 0.02 for r in rows)
            print(f"| {name} within 0.02 of the known answer (or above) | {ok}/{n} |")
    if not a.skip_speed:
        sp = out["speed"] = speed(a.runs)
        print()
        print("| speed (256 exemplar -> 1024 target, in process) | median |")
        print("|---|---|")
        print(f"| synthesize (unguided), {sp['runs']} runs | {sp['unguided']:.2f} s |")
        print(f"| texture_by_numbers, {sp['runs']} runs | {sp['tbn']:.2f} s |")
        print(f"| ratio | {sp['tbn'] / sp['unguided']:.2f}x |")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
