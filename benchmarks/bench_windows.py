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
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

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


def material_case(size: int, mode: str, seed: int, folder: str) -> dict:
    """One ``barkgen generate --tile --material`` in this process: seconds, peak memory and
    the output's quality (:func:`output_quality`)."""
    from barkgen.cli import main as barkgen
    from barkgen.data import sample_exemplar_path

    t0 = time.perf_counter()
    args = ["generate", str(sample_exemplar_path()), "-o", folder, "--size", f"{size}x{size}", "--tile", "--material"]
    try:
        barkgen([*args, "--windowed", mode, "--seed", str(seed), "--no-cache", "-q"])
    except SystemExit as exc:
        if exc.code:
            raise
    seconds = round(time.perf_counter() - t0, 2)
    peak = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    return {"seconds": seconds, "peak_mib": peak, **output_quality(folder)}


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
    args = parser.parse_args()
    if args.case:
        print(json.dumps(run_case(*args.case[:2], args.seed, args.case[2])))
        return
    if args.material_case:
        size, mode, folder = args.material_case
        print(json.dumps(material_case(int(size), mode, args.seed, folder)))
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
