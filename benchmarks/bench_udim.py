"""Benchmark of UDIM output (issue 69): ``barkgen generate --udim COLSxROWS --tile`` from the
bundled sample, then every pair of neighbouring tiles of every map joined side by side (and,
the set tiling, the last tile against the first, round the trunk), measured on the joined image.

    .venv/bin/python benchmarks/bench_udim.py [--tile-size 4096] [--grid 4x1] [--seed 0]
                                              [--from FOLDER] [--render PNG] [--quick] [--json F]

Per map and pair: the mean step across the tiles' border over the pair's median step across a
column boundary (as :func:`barkgen.evaluate.grid_step_ratio` measures steps) and the longest
straight line on the border (:func:`barkgen.evaluate.line_mask`, the boundaries within 2 px of
it), each beside the same figures at the middle of either tile, where the canvas was not cut:
what the bark itself gives at any one column. From the reference map: the longest straight seam
along each tile border (a run of rows whose pixels either side copy no neighbouring photo
pixels), its rank among all the output's column boundaries and their 99th percentile. The run's seconds and peak resident memory are its own
process's. ``--from``: measure a set already made (nothing is run). ``--render``: the set's
Blender set-up renders its first tile border (``--focus 1,0.5``; Debian ``blender``).
``--quick``: 2x1 tiles of 512 px.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

#: px either side of a tile border whose line counts as the border's
BORDER_REACH = 2


def make_set(folder: Path, tile: int, grid: str, seed: int) -> dict:
    """``generate --udim`` into ``folder`` in a process of its own: its seconds and peak MiB."""
    command = [sys.executable, "-m", "barkgen", "generate", "--size", f"{tile}x{tile}", "--udim", grid]
    command += ["--tile", "--seed", str(seed), "-q", "-o", str(folder)]
    t0 = time.perf_counter()
    process = subprocess.Popen(command)
    _, status, usage = os.wait4(process.pid, 0)
    if status:
        raise SystemExit(f"generate failed ({status})")
    return {"seconds": round(time.perf_counter() - t0, 1), "peak_mib": round(usage.ru_maxrss / 1024)}


def column_steps(image: np.ndarray) -> np.ndarray:
    """The mean step across each boundary between neighbouring columns (CIELAB for a colour
    image, as :func:`barkgen.evaluate.grid_step_ratio` measures it; the unit range otherwise)."""
    from barkgen.evaluate import as_lab
    from barkgen.evaluate.patches import as_unit_image

    img = as_unit_image(image)
    img = as_lab(image).astype(np.float64) if img.shape[2] == 3 else img.astype(np.float64)
    return np.sqrt(np.sum(np.diff(img, axis=1) ** 2, axis=2)).mean(axis=0)


def longest_runs(mask: np.ndarray) -> np.ndarray:
    """Each column's longest run of True down a 2-D mask."""
    on = mask.astype(np.int32)
    count = np.cumsum(on, axis=0)
    last_break = np.maximum.accumulate(np.where(on == 0, count, 0), axis=0)
    return (count - last_break).max(axis=0)


def column_seams(references: np.ndarray, exemplar: tuple[int, int], wraps: tuple[bool, bool]) -> np.ndarray:
    """For each boundary between output columns (the last against the first), the longest
    straight seam along it: the longest run of rows whose two pixels either side copy no
    neighbouring photo pixels (``exemplar``: the photo's ``(h, w)``, ``wraps``: its axes that
    wrap)."""
    right = np.roll(references, -1, axis=1)
    dy, dx = right[..., 0] - references[..., 0], right[..., 1] - references[..., 1]
    if wraps[0]:
        dy %= exemplar[0]
    if wraps[1]:
        dx %= exemplar[1]
    return longest_runs((dy != 0) | (dx != 1))


def column_lines(image: np.ndarray) -> np.ndarray:
    """For each boundary between neighbouring columns, the longest straight vertical line
    within :data:`BORDER_REACH` px of it (:func:`barkgen.evaluate.line_mask`), px."""
    from scipy.ndimage import maximum_filter1d

    from barkgen.evaluate import line_mask

    across_cols, _ = line_mask(image)
    return maximum_filter1d(longest_runs(across_cols), 2 * BORDER_REACH + 1, mode="nearest")


def pair_figures(left: np.ndarray, right: np.ndarray) -> dict:
    """Two tiles joined side by side (``left``'s right edge against ``right``'s left): the step
    across their border (over the pair's median step across a column boundary) and the longest
    line on it, each with its rank among every column boundary of the pair (the share of
    columns below it: a border no different from the bark's other columns ranks anywhere), and
    the pair's median and 99th-percentile line."""
    joined = np.concatenate((left, right), axis=1)
    border = left.shape[1] - 1
    steps, lines = column_steps(joined), column_lines(joined)
    return {
        "step": round(float(steps[border] / np.median(steps)), 3),
        "step_rank": round(float((steps < steps[border]).mean()), 3),
        "border_line": int(lines[border]),
        "line_rank": round(float((lines < lines[border]).mean()), 3),
        "line_p50": int(np.percentile(lines, 50)),
        "line_p99": int(np.percentile(lines, 99)),
    }


def measure(folder: Path) -> list[dict]:
    """Every map's neighbouring tiles of the set in ``folder``, pair by pair."""
    from barkgen.io import read_image, read_reference

    (record,) = [p for p in glob.glob(str(folder / "*.json")) if "udim" in json.loads(Path(p).read_text())]
    meta = json.loads(Path(record).read_text())
    stem, udim = Path(record).stem, meta["udim"]
    references, exemplar = read_reference(folder / "reference.png")
    report = json.loads((folder / "report.json").read_text())
    width, wraps = udim["tile_width_px"], tuple(report["exemplar_wrap"])
    rows = []
    seams = column_seams(references, exemplar, wraps)
    for number in range(1, udim["columns"] + 1):  # the straight seams along each tile border
        border = number * width - 1
        rows.append(
            {
                "map": "reference",
                "pair": f"{1000 + number}|{1001 + number % udim['columns']}",
                "seam": int(seams[border]),
                "seam_rank": round(float((seams < seams[border]).mean()), 3),
                "seam_p99": int(np.percentile(seams, 99)),
            }
        )
    maps = sorted({Path(p).name.split(".")[0][len(stem) + 1 :] for p in glob.glob(str(folder / f"{stem}_*.1001.png"))})
    for name in maps:
        tiles = {n: read_image(folder / f"{stem}_{name}.{n}.png") for n in udim["tiles"]}
        for row in range(udim["rows"]):
            numbers = [1001 + 10 * row + c for c in range(udim["columns"])]
            pairs = list(zip(numbers, numbers[1:]))
            if meta.get("tileable"):
                pairs.append((numbers[-1], numbers[0]))  # round the trunk
            for a, b in pairs:
                rows.append({"map": name, "pair": f"{a}|{b}", **pair_figures(tiles[a], tiles[b])})
    return rows


def render(folder: Path, png: Path) -> None:
    """The set's Blender set-up, rendered at its first tile border."""
    blender = shutil.which("blender")
    if blender is None:
        raise SystemExit("--render needs Blender (Debian package blender)")
    (script,) = glob.glob(str(folder / "*_blender.py"))
    options = ["--render", str(png), "--resolution", "768", "--samples", "32", "--focus", "1,0.5"]
    subprocess.run(
        [blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", script, "--", *options],
        check=True,
        capture_output=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tile-size", type=int, default=4096)
    parser.add_argument("--grid", default="4x1")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--from", dest="source", type=Path, help="a set made already")
    parser.add_argument("--render", type=Path, help="render its first tile border here (PNG)")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if args.quick:
        args.tile_size, args.grid = 512, "2x1"
    with tempfile.TemporaryDirectory(prefix="bench-udim-") as scratch:
        folder, run = args.source, {}
        if folder is None:
            folder = Path(scratch) / "set"
            run = make_set(folder, args.tile_size, args.grid, args.seed)
        rows = measure(folder)
        if args.render:
            render(folder, args.render)
    print(f"UDIM {args.grid} of the bundled sample, tileable, seed {args.seed}", end="")
    print(f": {run['seconds']} s, peak {run['peak_mib']} MiB" if run else f" (from {folder})")
    seams, rows = [r for r in rows if r["map"] == "reference"], [r for r in rows if r["map"] != "reference"]
    print(f"{'tile border':>18} {'seam':>6} {'rank':>6} {'p99':>5}   (the longest straight seam along it, px)")
    for r in seams:
        print(f"{r['pair']:>18} {r['seam']:>6} {r['seam_rank']:>6.2f} {r['seam_p99']:>5}")
    print(f"{'map':>18} {'pair':>10} {'step':>6} {'rank':>6} {'line':>5} {'rank':>6} {'p50':>4} {'p99':>4}")
    for r in rows:
        print(
            f"{r['map']:>18} {r['pair']:>10} {r['step']:>6.3f} {r['step_rank']:>6.2f} "
            f"{r['border_line']:>5} {r['line_rank']:>6.2f} {r['line_p50']:>4} {r['line_p99']:>4}"
        )
    print(
        f"largest step at a tile border {max(r['step'] for r in rows)}, longest line {max(r['border_line'] for r in rows)} px "
        f"(the pairs' 99th-percentile column: {max(r['line_p99'] for r in rows)} px); "
        f"mean rank of the borders among the columns: steps {np.mean([r['step_rank'] for r in rows]):.2f}, "
        f"lines {np.mean([r['line_rank'] for r in rows]):.2f}"
    )
    if args.json:
        args.json.write_text(json.dumps({"run": run, "seams": seams, "pairs": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
