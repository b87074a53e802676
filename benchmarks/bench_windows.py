"""Benchmark of the windowed fine levels (issue 69): tileable synthesis of the bundled sample,
solved whole and window by window (``SynthesisConfig(window=...)``), each in a process of its
own so its peak memory is its own.

    .venv/bin/python benchmarks/bench_windows.py [--sizes 2048 4096] [--window 1024] [--seed 0]
                                                 [--quick] [--json F]

Per size and mode: seconds of the synthesis, the process's peak resident memory, coherence
(:func:`barkgen.evaluate.coherence`, over the wrap) of the output's top-left 1024² crop against
the photo, the longest straight seam between copied pieces (:func:`barkgen.evaluate.longest_seam`),
the colour's step ratio across the pieces' borders (:func:`barkgen.evaluate.border_step_ratio`)
and across the window cores' borders over the steps elsewhere
(:func:`barkgen.evaluate.grid_step_ratio`: 1 = no trace of the windows).
``--quick``: 1024² with 256 px windows.

    .venv/bin/python benchmarks/bench_windows.py --material [--sizes 4096] [--quick]

``--material``: the whole ``barkgen generate --tile --material`` of each size instead, made whole
and window by window (``--windowed no`` / ``yes``: the finest levels, the colour blend and the
material set), each in a process of its own: seconds, peak resident memory, the coherence of the
texture's top-left 1024² and the longest straight seam of its reference map. ``--quick``: 1024².

    .venv/bin/python benchmarks/bench_windows.py --large [16384] [--base 4096] [--cache DIR] [--quick]

``--large``: issue 69's acceptance run. The set of each ``--large`` size made window by window,
beside the ``--base`` size made whole and window by window (the same-run time base: a run
linear in area takes ``(size / base)²`` times as long). Each run in a process of its own, then
measured from its files in another (:func:`large_quality`): the likeness of the texture's
top-left 2048² (coherence, completeness, sharpness and colour against the photo), every map's
longest straight line and the reference map's longest straight seam (both measured on
overlapping crops of :data:`CROP` px, so a large map is never held as floats whole), and the
colour's step ratio across the window cores' borders over the steps inside them. ``--cache DIR``
keeps each run's figures (``DIR/SIZE-MODE.json``) and skips a run whose figures are there.
``--quick``: 2048² beside 1024².
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import resource
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np


def run_case(size: int, window: int, seed: int, trace: int) -> dict:
    """One synthesis in this process: its figures (``trace``: the window side whose borders are
    measured, the same for the whole solve)."""
    from barkgen.data import sample_exemplar_path
    from barkgen.evaluate import border_step_ratio, coherence, grid_step_ratio, longest_seam
    from barkgen.io import read_image
    from barkgen.synth import SynthesisConfig, synthesize

    photo = read_image(sample_exemplar_path())
    t0 = time.perf_counter()
    result = synthesize(photo, size, tile=True, seed=seed, config=SynthesisConfig(window=window))
    seconds = time.perf_counter() - t0
    image = result.image
    crop = min(size, 1024)
    return {
        "size": size,
        "window": window,
        "seconds": round(seconds, 2),
        "peak_mib": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "coherence": coherence(image[:crop, :crop], photo, wrap=crop == size),
        "longest_seam": longest_seam(
            result.references,
            tile=True,
            exemplar_wrap=tuple(side if wraps else 0 for side, wraps in zip(photo.shape[:2], result.exemplar_wrap)),
        ),
        "step_ratio": border_step_ratio(image.astype(np.float32), result.references, tile=True),
        "window_border_step": grid_step_ratio(image, trace, tile=True),
    }


def material_case(size: int, mode: str, seed: int, folder: str, quality: bool = True) -> dict:
    """One ``barkgen generate --tile --material`` in this process: seconds, peak memory and
    the output's quality (:func:`output_quality`)."""
    from barkgen.cli import main as barkgen
    from barkgen.data import sample_exemplar_path

    t0 = time.perf_counter()
    # (beyond 8192² the output limit is raised, as a user does)
    limit = ["--max-pixels", str(size * size)] if size > 8192 else []
    args = [
        *limit,
        "generate",
        str(sample_exemplar_path()),
        "-o",
        folder,
        "--size",
        f"{size}x{size}",
        "--tile",
        "--material",
    ]
    try:
        barkgen([*args, "--windowed", mode, "--seed", str(seed), "--no-cache", "-q"])
    except SystemExit as exc:
        if exc.code:
            raise
    seconds = round(time.perf_counter() - t0, 2)
    peak = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    return {"seconds": seconds, "peak_mib": peak, **(output_quality(folder) if quality else {})}


def output_quality(folder: str) -> dict:
    """The run's texture's coherence (top-left 1024² against the photo) and its reference map's
    longest straight seam."""
    from pathlib import Path

    from barkgen.data import sample_exemplar_path
    from barkgen.evaluate import coherence, longest_seam
    from barkgen.io import read_image, read_reference

    photo = read_image(sample_exemplar_path())
    texture = read_image(Path(folder) / "texture.png")
    references, _ = read_reference(Path(folder) / "reference.png")
    wraps = json.loads((Path(folder) / "report.json").read_text())["exemplar_wrap"]
    crop = min(texture.shape[0], 1024)
    return {
        "coherence": coherence(texture[:crop, :crop], photo, wrap=crop == texture.shape[0]),
        "longest_seam": longest_seam(
            references, tile=True, exemplar_wrap=tuple(n if w else 0 for n, w in zip(photo.shape[:2], wraps))
        ),
    }


#: side of the crops a large map's lines and seams are measured on, and their overlap: a line or
#: seam across a crop's border is whole in the next crop up to ``CROP_OVERLAP`` px
CROP = 4096
CROP_OVERLAP = 512
#: the maps of a set whose lines are measured (``NAME_<map>.png``)
SET_MAPS = ("Color", "Displacement", "NormalGL", "AmbientOcclusion", "Roughness")


def _crops(shape: tuple[int, int]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Overlapping crops covering a tiling map, round its edges: ``(rows, cols)`` index arrays."""
    h, w = shape

    def starts(n: int) -> list[np.ndarray]:
        if n <= CROP:
            return [np.arange(n)]
        return [np.arange(s, s + CROP + CROP_OVERLAP) % n for s in range(0, n, CROP)]

    return [(rows, cols) for rows in starts(h) for cols in starts(w)]


def _longest_in_crops(image: np.ndarray, figure) -> int:
    """``figure(crop, tile)`` (px) at its largest over :func:`_crops` (the whole map, tiling,
    when it is one crop)."""
    crops = _crops(image.shape[:2])
    if len(crops) == 1:
        return int(figure(image, True))
    return max(int(figure(image[np.ix_(rows, cols)], False)) for rows, cols in crops)


#: the period of the grid a texture's piece borders favour (its coarse levels' references
#: up-sampled three times): every 8th boundary steps ~1.3x the others in a whole solve too
PHASE = 8


def window_step_ratio(image: np.ndarray, side: int) -> tuple[float, float]:
    """:func:`barkgen.evaluate.grid_step_ratio` of a tiling image, measured in bands of rows so a
    large image is never held in CIELAB floats whole: the mean step across the ``side`` px
    cells' borders over the mean step across the other boundaries; and over the other
    boundaries of the same place on the :data:`PHASE` px grid (the window borders measured
    against their own kind: 1 = no trace of the windows)."""
    from barkgen.evaluate import as_lab

    h, w = image.shape[:2]
    sums = [np.zeros(w), np.zeros(h)]  # per boundary: after column j / after row i
    for top in range(0, h, CROP):
        rows = np.arange(top, min(top + CROP, h) + 1) % h  # one row more: the step to the next band
        band = as_lab(image[rows]).astype(np.float64)
        nxt = np.roll(band[:-1], -1, axis=1)
        sums[0] += np.sqrt(np.sum((nxt - band[:-1]) ** 2, axis=2)).sum(axis=0)
        sums[1][rows[:-1]] += np.sqrt(np.sum((band[1:] - band[:-1]) ** 2, axis=2)).sum(axis=1)
    on, off, same = [], [], []
    for total, n, length in ((sums[0], w, h), (sums[1], h, w)):
        index = np.arange(n)
        border = index % side == side - 1
        on.append(total[border] / length)
        off.append(total[~border] / length)
        same.append(total[~border & (index % PHASE == (side - 1) % PHASE)] / length)
    grid = float(np.concatenate(on).mean())
    return grid / max(float(np.concatenate(off).mean()), 1e-12), grid / max(float(np.concatenate(same).mean()), 1e-12)


def large_quality(folder: str) -> dict:
    """The acceptance figures of a tileable run's files: likeness of the texture's top-left
    2048², every map's longest line, the longest seam and the colour's step ratio at the window
    cores' borders."""
    from pathlib import Path

    from barkgen.data import sample_exemplar_path
    from barkgen.evaluate import coherence, colour_distance, completeness, sharpness_ratio
    from barkgen.io import read_image
    from barkgen.pipeline.windowed import WINDOW

    photo = read_image(sample_exemplar_path())
    texture = _read_large(Path(folder) / "texture.png")
    crop = texture[:2048, :2048]
    whole = crop.shape[0] == texture.shape[0]
    figures: dict = {
        "coherence": coherence(crop, photo, wrap=whole),
        "completeness": completeness(crop, photo, wrap=whole),
        "sharpness": sharpness_ratio(crop, photo),
        "colour": colour_distance(crop, photo),
    }
    figures["grid_step"], figures["window_step"] = window_step_ratio(texture, WINDOW)
    del texture, crop
    wraps = json.loads((Path(folder) / "report.json").read_text())["exemplar_wrap"]
    exemplar_wrap = tuple(n if w else 0 for n, w in zip(photo.shape[:2], wraps))
    # a map a process, two at a time (each reads its map and goes through its crops)
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as pool:
        seam = pool.submit(_reference_seam, str(Path(folder) / "reference.png"), exemplar_wrap)
        lines = {kind: pool.submit(_map_line, str(next(Path(folder).glob(f"*_{kind}.png")))) for kind in SET_MAPS}
        figures["lines"] = {kind: done.result() for kind, done in lines.items()}
        figures["longest_seam"] = seam.result()
    return figures


def _read_large(path) -> np.ndarray:
    """An image file as barkgen reads it, whatever its size (:func:`barkgen.io.read_image`: a PNG
    past Pillow's own 179-megapixel limit, such as a 16384² map, is decoded by OpenCV)."""
    from barkgen.io import read_image

    return read_image(path)


#: px of a crop's edges whose boundaries are not counted: there a boundary is compared with the
#: boundaries on one side only (:data:`barkgen.evaluate.lines.REACH`), and the crop's first and
#: last look like lines; the crops' overlap measures them in the next crop
EDGE = 8


def _map_line(path: str) -> int:
    """A map file's longest straight line (:func:`barkgen.evaluate.longest_line`), in crops."""
    from barkgen.evaluate import line_mask, longest_line
    from barkgen.evaluate.seams import longest_run

    def in_crop(crop: np.ndarray, tile: bool) -> int:
        if tile:  # (the whole map)
            return longest_line(crop, tile=True)
        across_cols, across_rows = line_mask(crop)
        return max(longest_run(across_cols[:, EDGE:-EDGE].T), longest_run(across_rows[EDGE:-EDGE]))

    return _longest_in_crops(_read_large(path), in_crop)


def _reference_seam(path: str, exemplar_wrap: tuple) -> int:
    """A reference map file's longest straight seam (:func:`barkgen.evaluate.longest_seam`), in
    crops (``reference.png`` read by :func:`barkgen.io.read_reference`)."""
    from barkgen.evaluate import longest_seam
    from barkgen.io import read_reference

    references, _ = read_reference(path)
    return _longest_in_crops(references, lambda c, t: longest_seam(c, tile=t, exemplar_wrap=exemplar_wrap))


def _output(cmd: list[str]) -> str:
    """The last line a command of this benchmark prints; its error's last lines if it fails."""
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"{' '.join(cmd[1:])} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return done.stdout.splitlines()[-1]


def large_table(sizes: list[int], base: int, seed: int, cache: str | None, keep: str | None = None) -> list[dict]:
    """The ``--large`` table: ``base`` whole and windowed, then each size windowed; every run
    and its measuring in processes of their own (figures kept in ``cache``)."""
    import tempfile
    from pathlib import Path

    print(f"barkgen generate --tile --material of the bundled sample, seed {seed}: large sets window by window")
    print(
        f"{'size':>6} {'run':>9} {'s':>7} {'x base':>6} {'peak MiB':>9} {'coh':>6} {'comp':>6} {'sharp':>6} "
        f"{'colour':>6} {'grid':>6} {'win step':>8} {'seam':>5} {'line':>5} {'(map)':<16}"
    )
    rows, base_seconds = [], {}
    for size, mode in [(base, "no"), (base, "yes")] + [(size, "yes") for size in sizes]:
        label = "whole" if mode == "no" else "windowed"
        kept = Path(cache, f"{size}-{label}.json") if cache else None
        if kept is not None and kept.exists():
            r = json.loads(kept.read_text())
        else:
            with tempfile.TemporaryDirectory() as folder:
                if keep:  # the run's files kept for a look (DIR/SIZE-RUN)
                    folder = str(Path(keep, f"{size}-{label}"))
                    Path(folder).mkdir(parents=True, exist_ok=True)
                cmd = [sys.executable, __file__, "--material-case", str(size), mode, folder, "--seed", str(seed)]
                ran = json.loads(_output([*cmd, "--no-quality"]))  # (measured below, from its files)
                measured = _output([sys.executable, __file__, "--measure", folder])
            r = {
                "size": size,
                "run": label,
                "seconds": ran["seconds"],
                "peak_mib": ran["peak_mib"],
                **json.loads(measured),
            }
            if kept is not None:
                kept.parent.mkdir(parents=True, exist_ok=True)
                kept.write_text(json.dumps(r, indent=1))
        rows.append(r)
        if size == base:
            base_seconds[label] = r["seconds"]
        # the time against the base's, run the same way and scaled by the area (1: linear)
        linear = r["seconds"] / (base_seconds[label] * (size / base) ** 2)
        line_map = max(r["lines"], key=r["lines"].get)
        print(
            f"{size:6d} {label:>9} {r['seconds']:7.1f} {linear:6.2f} {r['peak_mib']:9.0f} {r['coherence']:6.3f} "
            f"{r['completeness']:6.3f} {r['sharpness']:6.3f} {r['colour']:6.2f} {r['grid_step']:6.3f} {r['window_step']:8.3f} "
            f"{r['longest_seam']:5d} {r['lines'][line_map]:5d} {line_map:<16}",
            flush=True,
        )
    for r in rows[2:]:
        area = (r["size"] / base) ** 2
        print(
            f"{r['size']}² windowed: {r['seconds'] / base_seconds['whole']:.1f}x the {base}² whole run's time, "
            f"{r['seconds'] / base_seconds['windowed']:.1f}x its windowed run's (linear in area: {area:g}x)"
        )
    return rows


def material_table(sizes: list[int], seed: int) -> list[dict]:
    """The ``--material`` table: each size whole and windowed (measured before the run's folder
    goes), and their ratios."""
    import tempfile

    rows = []
    print(f"barkgen generate --tile --material of the bundled sample, seed {seed}: whole and in windows")
    print(f"{'size':>6} {'run':>9} {'s':>7} {'peak MiB':>9} {'coh':>6} {'seam':>5}")
    for size in sizes:
        got = {}
        for mode, label in (("no", "whole"), ("yes", "windowed")):
            with tempfile.TemporaryDirectory() as folder:
                cmd = [sys.executable, __file__, "--material-case", str(size), mode, folder, "--seed", str(seed)]
                done = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
            r = got[mode] = json.loads(done.strip().splitlines()[-1])
            rows.append({"size": size, "run": label, **r})
            line = f"{size:6d} {label:>9} {r['seconds']:7.1f} {r['peak_mib']:9.0f} {r['coherence']:6.3f}"
            print(f"{line} {r['longest_seam']:5d}", flush=True)
        yes, no = got["yes"], got["no"]
        ratios = (yes["seconds"] / no["seconds"], yes["peak_mib"] / no["peak_mib"], yes["coherence"] / no["coherence"])
        print(f"{'':6} {'ratio':>9} {ratios[0]:7.2f}x {ratios[1]:8.2f}x {ratios[2]:5.2f}x")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2048, 4096])
    parser.add_argument("--window", type=int, default=1024)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--json")
    parser.add_argument("--material", action="store_true", help="barkgen generate's set, whole and in windows")
    parser.add_argument("--case", nargs=3, type=int, help=argparse.SUPPRESS)  # size window trace: one run
    parser.add_argument("--material-case", nargs=3, help=argparse.SUPPRESS)  # size mode folder: one run
    parser.add_argument("--large", type=int, nargs="*", help="windowed sets of these sizes (16384) beside --base")
    parser.add_argument("--base", type=int, default=4096, help="the --large runs' base size")
    parser.add_argument("--cache", help="--large: a folder keeping each run's figures")
    parser.add_argument("--keep", help="--large: keep each run's files in this folder (DIR/SIZE-RUN)")
    parser.add_argument("--measure", help=argparse.SUPPRESS)  # folder: a large run's figures
    parser.add_argument("--no-quality", action="store_true", help=argparse.SUPPRESS)  # --material-case: time it only
    args = parser.parse_args()
    if args.measure:
        print(json.dumps(large_quality(args.measure)))
        return
    if args.large is not None:
        sizes, base = ([2048], 1024) if args.quick else (args.large or [16384], args.base)
        rows = large_table(sizes, base, args.seed, args.cache, args.keep)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(rows, f, indent=1)
        return
    if args.case:
        print(json.dumps(run_case(*args.case[:2], args.seed, args.case[2])))
        return
    if args.material_case:
        size, mode, folder = args.material_case
        print(json.dumps(material_case(int(size), mode, args.seed, folder, quality=not args.no_quality)))
        return
    if args.material:
        rows = material_table([1024] if args.quick else args.sizes, args.seed)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(rows, f, indent=1)
        return
    sizes, window = ([1024], 256) if args.quick else (args.sizes, args.window)
    rows = []
    print(f"tileable synthesis of the bundled sample, seed {args.seed}, windows of {window} px")
    print(f"{'size':>6} {'mode':>9} {'s':>7} {'peak MiB':>9} {'coh':>6} {'seam':>5} {'step':>6} {'win step':>8}")
    for size in sizes:
        for mode, w in (("whole", 0), ("windowed", window)):
            cmd = [sys.executable, __file__, "--case", str(size), str(w), str(window), "--seed", str(args.seed)]
            out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            rows.append({"mode": mode, **r})
            print(
                f"{size:6d} {mode:>9} {r['seconds']:7.1f} {r['peak_mib']:9.0f} {r['coherence']:6.3f} "
                f"{r['longest_seam']:5d} {r['step_ratio']:6.3f} {r['window_border_step']:8.3f}",
                flush=True,
            )
        whole, windowed = rows[-2], rows[-1]
        print(
            f"{'':6} {'ratio':>9} {windowed['seconds'] / whole['seconds']:7.2f}x "
            f"{windowed['peak_mib'] / whole['peak_mib']:8.2f}x {windowed['coherence'] / whole['coherence']:5.2f}x"
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
