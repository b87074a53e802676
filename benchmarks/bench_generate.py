#!/usr/bin/env python3
"""Output label maps and the one-click pipeline: label-map fidelity of both strategies, final
texture quality against plain synthesis, and speed, in one run.

    .venv/bin/python benchmarks/bench_generate.py [--photos a,b] [--ks 2,3,4,5] [--crop 512]
        [--size 1024] [--seeds 0,1,2] [--strategy joint] [--runs 3] [--sheets DIR]
        [--json out.json] [--skip-labelmaps] [--skip-textures] [--skip-speed]

Label maps (laitoch2018 §3.6, §4.3-4.4): for every photo of ``../shared/data/bark`` (centre
crop, short side ``--crop``) and k = 2..5, the colour-region label map (``barkgen.labels``) is
synthesized at its own size by the three strategies (joint with the crop as its photo). Per case: the largest per-label area difference
in percentage points (target <= 3) and the shape dissimilarity of eq. 3.9 averaged over labels,
divided by the dissimilarity between the exemplar's left and right halves (target <= 1.5).

Textures: ``barkgen.pipeline.generate`` (defaults: k = 3, colour labels, ``--strategy`` label
maps, joint by default) on every full photo at ``--size``, scored with the team's ``texeval``
(``--labels-in labels_in --labels-out labels_out``) against plain ``synthesize`` of the same
photo, size and seed in the same run: label fidelity / ceiling (>= 0.85), balanced (>= 0.8), and
coherence, completeness and sharpness no worse than 1.25x plain synthesis. One seed's ratio is
noisy (oak's coherence ratio was 1.2x, 2.2x and 1.4x for seeds 0, 1, 2: plain synthesis itself
varies by 40 %), so every figure is the median over ``--seeds`` of each method, and the ratio
is median over median. ``--sheets DIR`` writes the first seed's contact sheets.

Speed: the bundled sample's 256x256 centre crop to 1024x1024, ``generate`` against plain
``synthesize`` in process, interleaved, medians over ``--runs`` (target <= 20 s).

Stages (``--profile``; with ``--skip-labelmaps --skip-textures --skip-speed`` alone): the
quickstart's run (tileable, material set) on the bundled sample and ``--profile-photos`` of the
shared photos, each a centre crop of 512 and 1024 px to an output of its size: every step of
the analysis (``report.json``'s ``analysis_*``: the light out and the label map, the two
solvers' analyses, the material set on its thread) and of another seed given the analysis
(labels out, texture, material), in a fresh interpreter per case, medians over ``--runs``
seeds. ``--profile-base SRC`` runs every case with another checkout's ``src`` too, interleaved
(``git worktree add /tmp/base COMMIT``), and prints the ratio of each step.
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

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from barkgen.io import (  # noqa: E402
    read_centre_crop,  # noqa: E402
    read_image,
    write_png,
)
from barkgen.labels import color_regions  # noqa: E402
from barkgen.pipeline import GenerateOptions, generate, preview_sheet  # noqa: E402
from barkgen.shapes import Budget, label_dissimilarity, synthesize_label_map  # noqa: E402
from barkgen.synth import synthesize  # noqa: E402

PHOTO_SUFFIXES = {".jpg", ".jpeg", ".png"}
#: the label-map strategies compared: barkgen's engines (labels alone; labels and the photo's
#: colours) and the layered method of the thesis
STRATEGIES = ("engine", "joint", "layered")


def photos(names: list[str] | None) -> list[Path]:
    found = sorted(p for p in (SHARED / "data" / "bark").iterdir() if p.suffix.lower() in PHOTO_SUFFIXES)
    return [p for p in found if not names or p.stem in names]


def mean_dissimilarity(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean(list(label_dissimilarity(a, b, max_samples=8000).values())))


def labelmaps(paths: list[Path], ks: list[int], crop: int) -> list[dict]:
    rows = []
    for path in paths:
        ex = read_centre_crop(path, crop)
        for k in ks:
            labels = color_regions(ex, k, seed=0)
            values = np.unique(labels)
            w = labels.shape[1] // 2
            halves = mean_dissimilarity(labels[:, :w], labels[:, w:])
            row = {"photo": path.stem, "k": int(values.size), "halves": halves}
            for strategy in STRATEGIES:
                t = time.perf_counter()
                out = synthesize_label_map(
                    labels,
                    labels.shape,
                    strategy=strategy,
                    photo=ex if strategy == "joint" else None,
                    budget=Budget(seed=0),
                ).label_map
                elapsed = time.perf_counter() - t
                areas = [abs(np.mean(out == v) - np.mean(labels == v)) * 100 for v in values]
                d = mean_dissimilarity(labels, out)
                row[strategy] = {"area_pp": max(areas), "dissimilarity": d, "ratio": d / halves, "seconds": elapsed}
            rows.append(row)
            print(
                f"  {path.stem:28s} k={k}: "
                + " | ".join(f"{name} {row[name]['area_pp']:.1f} pp {row[name]['ratio']:.2f}x" for name in STRATEGIES),
                file=sys.stderr,
                flush=True,
            )
    return rows


def textures(paths: list[Path], size: int, seeds: list[int], strategy: str, sheets: Path | None) -> list[dict]:
    sys.path.insert(0, str(SHARED / "eval"))
    import texeval

    keys = (
        "coherence",
        "completeness",
        "sharpness_ratio",
        "label_fidelity",
        "label_fidelity_train",
        "label_fidelity_ratio",
        "label_fidelity_balanced",
    )
    rows = []
    for path in paths:
        photo = read_image(path)
        ours, base, seconds, ev = [], [], [], None
        for seed in seeds:
            t = time.perf_counter()
            result = generate(photo, GenerateOptions(size=(size, size), seed=seed, strategy=strategy))
            seconds.append(time.perf_counter() - t)
            plain = synthesize(photo, (size, size), seed=seed).image
            ev = ev or texeval.TexEval(photo, labels_in=result.labels_in)
            ours.append(ev.evaluate(result.texture, labels_out=result.labels_out))
            base.append(ev.evaluate(plain))
            if sheets is not None and seed == seeds[0]:
                write_png(sheets / f"{path.stem}.png", preview_sheet(photo, result, tile_size=256))
        row = {
            "photo": path.stem,
            "seconds": statistics.median(seconds),
            "seeds": seeds,
            "generate": {k: statistics.median(m[k] for m in ours) for k in keys},
            "plain": {k: statistics.median(m[k] for m in base) for k in keys if base[0][k] is not None},
            "per_seed": [
                {"generate": {k: g[k] for k in keys}, "plain": {k: p[k] for k in keys if p[k] is not None}}
                for g, p in zip(ours, base)
            ],
        }
        rows.append(row)
        g, p = row["generate"], row["plain"]
        print(
            f"  {path.stem:28s} fidelity {g['label_fidelity_ratio']:.3f} balanced "
            f"{g['label_fidelity_balanced']:.3f} coherence {g['coherence'] / p['coherence']:.2f}x "
            f"completeness {g['completeness'] / p['completeness']:.2f}x sharpness "
            f"{g['sharpness_ratio']:.3f} (plain {p['sharpness_ratio']:.3f}) {row['seconds']:.1f} s; "
            "per seed coherence "
            + ", ".join(f"{r['generate']['coherence']:.2f}/{r['plain']['coherence']:.2f}" for r in row["per_seed"]),
            file=sys.stderr,
            flush=True,
        )
    return rows


def speed(runs: int) -> dict:
    from barkgen.data import sample_exemplar_path

    ex = read_centre_crop(sample_exemplar_path(), 256)
    options = GenerateOptions(size=(1024, 1024))
    generate(ex, GenerateOptions(size=(128, 128)))  # compile / load the numba cache
    gen, plain = [], []
    for i in range(runs):
        t = time.perf_counter()
        synthesize(ex, 1024, seed=i)
        plain.append(time.perf_counter() - t)
        t = time.perf_counter()
        generate(ex, GenerateOptions(size=options.size, seed=i))
        gen.append(time.perf_counter() - t)
    return {"generate": statistics.median(gen), "synthesize": statistics.median(plain), "runs": runs}


#: one case of ``--profile``, in a fresh interpreter: the analysis' steps, then another seed's
#: stages given it (medians over the seeds after a first, which loads the kernels)
PROFILE_CASE = """
import json, statistics, sys
from barkgen.io import read_centre_crop
from barkgen.pipeline import GenerateOptions, analyze_photo, generate
path, size, runs = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
photo = read_centre_crop(path, size)
options = GenerateOptions(size=(size, size), tile=True, material=True)
analysis = analyze_photo(photo, options)
steps = {f"analysis_{k}": v for k, v in getattr(analysis, "steps", {}).items()}
steps["analysis"] = analysis.seconds
seeds = []
for seed in range(runs + 1):
    timings = generate(photo, GenerateOptions(size=(size, size), tile=True, material=True, seed=seed + 1), analysis=analysis).report["timings_s"]
    seeds.append({k: v for k, v in timings.items() if not k.startswith("analysis")})
per_seed = {f"seed_{k}": statistics.median(s[k] for s in seeds[1:]) for k in seeds[1] if k != "total"}
per_seed["seed"] = statistics.median(s["total"] for s in seeds[1:]) - analysis.seconds
print(json.dumps({**steps, **per_seed}))
"""


def profile_case(src: Path, photo: Path, size: int, runs: int) -> dict:
    import subprocess

    env = {**os.environ, "PYTHONPATH": str(src)}
    out = subprocess.run(
        [sys.executable, "-c", PROFILE_CASE, str(photo), str(size), str(runs)],
        check=True,
        capture_output=True,
        text=True,
        env=env,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def profile(photos: list[Path], sizes: list[int], runs: int, base: Path | None) -> list[dict]:
    """Every step's seconds per case (and the base checkout's, interleaved), printed as a table."""
    rows = []
    for photo in photos:
        for size in sizes:
            row = {"photo": photo.stem, "size": size, "now": profile_case(REPO / "src", photo, size, runs)}
            if base is not None:
                row["base"] = profile_case(base, photo, size, runs)
            rows.append(row)
            print(f"  profiled {photo.stem} at {size}", file=sys.stderr, flush=True)
    steps = [k for k in rows[0]["now"] if k != "analysis_material"]  # (the wait after the solvers': ~0)
    print("| photo | size | " + " | ".join(steps) + " |")
    print("|---|---|" + "---|" * len(steps))
    for row in rows:
        cells = []
        for step in steps:
            now = row["now"].get(step)
            then = row.get("base", {}).get(step)
            cell = "" if now is None else f"{now:.2f}"
            if now is not None and then:
                cell += f" ({now / then:.2f}x)"
            cells.append(cell)
        print(f"| {row['photo']} | {row['size']} | " + " | ".join(cells) + " |")
    return rows


def _worse(g: dict, p: dict, key: str) -> float:
    """How many times worse than plain synthesis (sharpness: distance from 1)."""
    if key == "sharpness_ratio":
        return max(abs(1 - g[key]), 1e-3) / max(abs(1 - p[key]), 1e-3) if abs(1 - g[key]) > 0.05 else 1.0
    return g[key] / p[key]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photos", default=None, help="comma-separated photo names (default: all)")
    ap.add_argument("--ks", default="2,3,4,5")
    ap.add_argument("--crop", type=int, default=512)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--seeds", default="0,1,2", help="texture seeds (figures are medians over them)")
    ap.add_argument("--strategy", default="joint", help="generate's label-map strategy for the textures")
    ap.add_argument("--sheets", type=Path, default=None, help="write each run's contact sheet here")
    ap.add_argument("--json", default=None, help="also write all figures to this file")
    ap.add_argument("--profile", action="store_true", help="every step's seconds on four photos at 512 and 1024 px")
    ap.add_argument(
        "--profile-photos",
        default="oak_furrowed_moss_01,pine_plated_01,willow_furrowed_01",
        help="the shared photos profiled beside the bundled sample",
    )
    ap.add_argument("--profile-base", type=Path, default=None, help="another checkout's src, profiled alongside")
    ap.add_argument("--skip-labelmaps", action="store_true")
    ap.add_argument("--skip-textures", action="store_true")
    ap.add_argument("--skip-speed", action="store_true")
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    if not (SHARED / "data" / "bark").is_dir():
        print(f"needs the team's shared folder at {SHARED} (set BARKGEN_SHARED)", file=sys.stderr)
        return 2
    paths = photos(a.photos.split(",") if a.photos else None)
    out: dict = {}
    if not a.skip_labelmaps:
        rows = out["labelmaps"] = labelmaps(paths, [int(k) for k in a.ks.split(",")], a.crop)
        names = STRATEGIES
        print("| photo | k | " + " | ".join(f"{n}: area diff (pp) / dissimilarity ratio" for n in names) + " |")
        print("|---|---|" + "---|" * len(names))
        for r in rows:
            print(
                f"| {r['photo']} | {r['k']} | "
                + " | ".join(f"{r[n]['area_pp']:.1f} / {r[n]['ratio']:.2f}" for n in names)
                + " |"
            )
        print()
        print("| criterion | " + " | ".join(names) + " |")
        print("|---|" + "---|" * len(names))
        n_rows = len(rows)
        for label, test in (
            ("areas within 3 pp", lambda s: s["area_pp"] <= 3.0),
            ("dissimilarity <= 1.5x halves", lambda s: s["ratio"] <= 1.5),
            ("both", lambda s: s["area_pp"] <= 3.0 and s["ratio"] <= 1.5),
        ):
            print(f"| {label} | " + " | ".join(f"{sum(test(r[n]) for r in rows)}/{n_rows}" for n in names) + " |")
        for key, label in (
            ("area_pp", "median area diff (pp)"),
            ("ratio", "median dissimilarity ratio"),
            ("seconds", "median seconds per map"),
        ):
            print(
                f"| {label} | " + " | ".join(f"{statistics.median(r[n][key] for r in rows):.2f}" for n in names) + " |"
            )
    if not a.skip_textures:
        if a.sheets is not None:
            a.sheets.mkdir(parents=True, exist_ok=True)
        seeds = [int(v) for v in a.seeds.split(",")]
        rows = out["textures"] = textures(paths, a.size, seeds, a.strategy, a.sheets)
        print()
        print(f"{a.strategy} strategy, medians over seeds {a.seeds}")
        print(
            f"| photo ({a.size}x{a.size}) | fidelity / ceiling | balanced | coherence (x plain) |"
            " completeness (x plain) | sharpness (plain) | generate s |"
        )
        print("|---|---|---|---|---|---|---|")
        for r in rows:
            g, p = r["generate"], r["plain"]
            print(
                f"| {r['photo']} | {g['label_fidelity_ratio']:.3f} | {g['label_fidelity_balanced']:.3f} | "
                f"{g['coherence']:.2f} ({g['coherence'] / p['coherence']:.2f}x) | "
                f"{g['completeness']:.2f} ({g['completeness'] / p['completeness']:.2f}x) | "
                f"{g['sharpness_ratio']:.3f} ({p['sharpness_ratio']:.3f}) | {r['seconds']:.1f} |"
            )
        n = len(rows)
        print()
        print("| criterion | photos passed |")
        print("|---|---|")
        crit = {
            "fidelity >= 0.85 x ceiling": lambda g, p: g["label_fidelity_ratio"] >= 0.85,
            "balanced >= 0.8": lambda g, p: g["label_fidelity_balanced"] >= 0.8,
            "coherence <= 1.25x plain": lambda g, p: _worse(g, p, "coherence") <= 1.25,
            "completeness <= 1.25x plain": lambda g, p: _worse(g, p, "completeness") <= 1.25,
            "sharpness no worse than 1.25x plain": lambda g, p: _worse(g, p, "sharpness_ratio") <= 1.25,
        }
        for name, test in crit.items():
            print(f"| {name} | {sum(test(r['generate'], r['plain']) for r in rows)}/{n} |")
    if not a.skip_speed:
        sp = out["speed"] = speed(a.runs)
        print()
        print("| speed (256 sample crop -> 1024x1024, in process) | median |")
        print("|---|---|")
        print(f"| synthesize (plain), {sp['runs']} runs | {sp['synthesize']:.2f} s |")
        print(f"| generate (labels + label map + texture-by-numbers), {sp['runs']} runs | {sp['generate']:.2f} s |")
        print(f"| ratio | {sp['generate'] / sp['synthesize']:.2f}x |")
    if a.profile:
        from barkgen.data import sample_exemplar_path

        shared = [_photo_path(name) for name in a.profile_photos.split(",") if name]
        print()
        out["profile"] = profile([Path(sample_exemplar_path()), *shared], [512, 1024], a.runs, a.profile_base)
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))
    return 0


def _photo_path(name: str) -> Path:
    """A shared photo by its name (any suffix)."""
    for suffix in sorted(PHOTO_SUFFIXES):
        path = SHARED / "data" / "bark" / f"{name}{suffix}"
        if path.exists():
            return path
    raise SystemExit(f"no photo {name} in {SHARED / 'data' / 'bark'}")


if __name__ == "__main__":
    sys.exit(main())
