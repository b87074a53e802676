#!/usr/bin/env python3
"""The main job's speed: the quickstart's ``generate`` (1024x1024 tileable material set from the
bundled 1024x1024 photo), whole commands timed from outside, G'MIC as the yardstick.

    .venv/bin/python benchmarks/bench_quickstart.py [--runs 5] [--peer-runs 5] [--skip-peer]
        [--skip-seeds] [--skip-first-run] [--skip-busy] [--skip-4k] [--json out.json]
        [--record benchmarks/recorded/quickstart.json]

Rows (wall seconds are medians; every run is a fresh process, start-up and file writing
included; the runs of each row interleaved with G'MIC's, so a machine that slows down slows
both):

* **quickstart, new photo**: ``barkgen generate -o DIR --size 1024x1024 --tile --seed 0
  --material`` with the numba cache filled and an empty analysis cache (a new
  ``BARKGEN_CACHE_DIR`` each run: the photo's analysis is made, and written), beside G'MIC's
  256->1024 tiled synthesis (``../shared/eval/peers/gmic.sh --tile``, the team's yardstick);
  ratio of the medians (targets: <= 4 s and <= 0.35x). Each stage's own seconds
  (``report.json``) are listed beside the figures recorded for an earlier main
  (``benchmarks/recorded/quickstart.json``; ``--record`` writes this run's there), so a stage
  that grows shows.
* **another seed**: the same command with seeds 1, 2, ... of the same photo, the analysis
  cache filled by one run before (target <= 2 s); and **in-process**, the Python API's
  :func:`~barkgen.pipeline.generate` given the photo's analysis, as the web app's worker and
  batch run it (target <= 1 s).
* **first run**: the same command with an empty numba cache (``NUMBA_CACHE_DIR`` a new
  folder), and ``barkgen warm-up`` followed by it, as the quickstart's set-up runs them.
* **busy machine**: the new-photo command while another CPU-bound process runs (a
  single-threaded spinner, and a second ``generate`` of another photo in a loop: two batch
  workers, or the web app's worker beside a desktop), against its quiet median (target
  <= 2x).
* **4096x4096** tileable with material from the same photo (new photo): wall, peak RSS and
  time per pixel against the 1024 run (targets: <= 30 s, <= 3 GB).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
BARKGEN = [sys.executable, "-m", "barkgen"]
SPINNER = [sys.executable, "-c", "while True: pass"]


def timed(cmd: list[str], env: dict | None = None) -> tuple[float, float]:
    """Wall seconds and peak RSS (GiB) of one run of ``cmd`` (its output thrown away)."""
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env={**os.environ, **(env or {})})
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    if status != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({status}): {err.strip()[-500:]}")
    return wall, usage.ru_maxrss / 2**20


def quickstart(out: Path, size: int = 1024, seed: int = 0) -> list[str]:
    return BARKGEN + [
        "generate",
        "-o",
        str(out),
        "--size",
        f"{size}x{size}",
        "--tile",
        "--seed",
        str(seed),
        "--material",
        "--name",
        "bark",
        "-q",
    ]


def new_photo(work: Path) -> dict:
    """The environment of a run whose photo was never analysed: an empty analysis cache (the
    run makes the analysis and writes it there, as a new photo's first run does)."""
    shutil.rmtree(work / "analysis-cache", ignore_errors=True)
    return {"BARKGEN_CACHE_DIR": str(work / "analysis-cache")}


#: the Python API's another seed, in a fresh interpreter: the photo's analysis once, then
#: ``generate`` given it, per seed (the first seed after the analysis is not counted: it loads
#: what the first call of each kernel loads)
IN_PROCESS = """
import json, sys, time
from barkgen.data import sample_exemplar_path
from barkgen.io import read_image
from barkgen.pipeline import GenerateOptions, analyze_photo, generate
photo = read_image(sample_exemplar_path())
options = GenerateOptions(size=(1024, 1024), tile=True, material=True)
analysis = analyze_photo(photo, options)
seconds = []
for seed in range(int(sys.argv[1]) + 1):
    t = time.perf_counter()
    generate(photo, GenerateOptions(size=(1024, 1024), tile=True, material=True, seed=seed + 1), analysis=analysis)
    seconds.append(time.perf_counter() - t)
print(json.dumps(seconds[1:]))
"""


def in_process_seeds(runs: int) -> list[float]:
    out = subprocess.run(
        [sys.executable, "-c", IN_PROCESS, str(runs)], check=True, capture_output=True, text=True
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


RECORDED = REPO / "benchmarks" / "recorded" / "quickstart.json"


def recorded_rows(stages: dict, quiet: float, record: dict | None) -> list[tuple[str, str]]:
    """Each stage's median now, beside the recorded main's."""
    if not record:
        return [(f"  stage {name} (median)", f"{value:.2f} s") for name, value in stages.items()]
    label = f"{record['commit']}, {record['measured']}"
    rows = [
        (
            f"  recorded: whole command ({label})",
            f"{record['quickstart_s']:.2f} s, now {quiet / record['quickstart_s']:.2f}x",
        )
    ]
    for name, value in stages.items():
        before = record["stages"].get(name)
        then = f" (recorded {before:.2f} s: {value / before:.2f}x)" if before else ""
        rows.append((f"  stage {name} (median)", f"{value:.2f} s{then}"))
    return rows


def make_peer_exemplar(dst: Path) -> Path:
    """The yardstick's input: the sample's 256x256 centre crop (as ``bench_synth``)."""
    sys.path.insert(0, str(REPO / "src"))
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_centre_crop, write_png

    write_png(dst, read_centre_crop(sample_exemplar_path(), 256))
    return dst


def stage_seconds(folder: Path) -> dict:
    return json.loads((folder / "report.json").read_text())["timings_s"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--peer-runs", type=int, default=5)
    ap.add_argument("--skip-peer", action="store_true")
    ap.add_argument("--skip-seeds", action="store_true")
    ap.add_argument("--skip-first-run", action="store_true")
    ap.add_argument("--skip-busy", action="store_true")
    ap.add_argument("--skip-4k", action="store_true")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--record", type=Path, default=None, help="write this run's whole-command and stage medians here")
    ap.add_argument("--commit", default=None, help="the commit measured (for --record; default: git's HEAD)")
    a = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="barkgen-bench-"))
    rows: list[tuple[str, str]] = []
    figures: dict = {}
    gmic = SHARED / "eval" / "peers" / "gmic.sh"
    have_peer = not a.skip_peer and shutil.which("gmic") is not None and gmic.exists()
    record = json.loads(RECORDED.read_text()) if RECORDED.exists() else None
    try:
        timed(quickstart(work / "warm"), env=new_photo(work))  # fills the numba cache if it is not already
        seed_cache = {"BARKGEN_CACHE_DIR": str(work / "seed-cache")}
        if not a.skip_seeds:
            timed(quickstart(work / "s0"), env=seed_cache)  # the photo's analysis, cached
        ex = make_peer_exemplar(work / "ex256.png") if have_peer else None
        ours, seeds, theirs, stages = [], [], [], []
        for i in range(max(a.runs, a.peer_runs if have_peer else 0)):
            if i < a.runs:
                ours.append(timed(quickstart(work / "q"), env=new_photo(work))[0])
                stages.append(stage_seconds(work / "q"))
                if not a.skip_seeds:
                    seeds.append(timed(quickstart(work / "s", seed=i + 1), env=seed_cache)[0])
            if have_peer and i < a.peer_runs:
                theirs.append(
                    timed(
                        ["bash", str(gmic), str(ex), str(work / "g.png"), "1024", "1024", "--tile", "--seed", str(i)]
                    )[0]
                )
        quiet = statistics.median(ours)
        stage_medians = {name: statistics.median(s[name] for s in stages) for name in stages[0]}
        figures.update(quickstart_s=ours, stages=stage_medians)
        rows.append((f"quickstart generate, new photo (median of {len(ours)})", f"{quiet:.2f} s"))
        rows += recorded_rows(stage_medians, quiet, record)
        peer = statistics.median(theirs) if theirs else None
        if peer:
            figures["gmic_s"] = theirs
            rows.append((f"G'MIC 256->1024 tiled (median of {len(theirs)})", f"{peer:.2f} s"))
            rows.append(("ratio barkgen / G'MIC", f"{quiet / peer:.2f}x"))
        if seeds:
            api = in_process_seeds(a.runs)
            figures.update(another_seed_s=seeds, another_seed_in_process_s=api)
            med = statistics.median(seeds)
            rows.append((f"another seed, whole command (median of {len(seeds)})", f"{med:.2f} s"))
            if peer:
                rows.append(("  ratio to G'MIC", f"{med / peer:.2f}x"))
            rows.append((f"another seed, in-process (median of {len(api)})", f"{statistics.median(api):.2f} s"))
        if a.record:
            commit = (
                a.commit
                or subprocess.run(
                    ["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True, text=True
                ).stdout.strip()
            )
            a.record.parent.mkdir(parents=True, exist_ok=True)
            a.record.write_text(
                json.dumps(
                    {
                        "commit": commit,
                        "measured": time.strftime("%Y-%m-%d"),
                        "machine": f"{os.cpu_count()} cores",
                        "quickstart_s": round(quiet, 3),
                        "stages": {k: round(v, 3) for k, v in stage_medians.items()},
                        "gmic_s": round(peer, 3) if peer else None,
                    },
                    indent=1,
                )
                + "\n"
            )

        if not a.skip_first_run:
            cache = work / "numba-cache"
            cold = timed(quickstart(work / "cold"), env={"NUMBA_CACHE_DIR": str(cache / "a"), **new_photo(work)})[0]
            t_warmup = timed(BARKGEN + ["warm-up", "--quiet"], env={"NUMBA_CACHE_DIR": str(cache / "b")})[0]
            after = timed(quickstart(work / "after"), env={"NUMBA_CACHE_DIR": str(cache / "b"), **new_photo(work)})[0]
            figures.update(first_run_empty_cache_s=cold, warm_up_s=t_warmup, first_run_after_setup_s=after)
            rows.append(("first run, empty numba cache", f"{cold:.1f} s"))
            rows.append(("set-up's warm-up, then the first run", f"{t_warmup:.1f} s + {after:.1f} s"))

        if not a.skip_busy:
            rows += busy_rows(work, quiet, figures)

        if not a.skip_4k:
            wall, rss = timed(quickstart(work / "k4", size=4096), env=new_photo(work))
            per_pixel = (wall / 4096**2) / (quiet / 1024**2)
            figures.update(
                k4_s=wall, k4_peak_gib=rss, k4_per_pixel_ratio=per_pixel, k4_stages=stage_seconds(work / "k4")
            )
            rows.append(("4096x4096 tiled with material, wall", f"{wall:.1f} s"))
            rows.append(("4096x4096, peak RSS", f"{rss:.2f} GiB"))
            rows.append(("4096x4096 time per pixel / 1024x1024's", f"{per_pixel:.2f}x"))
            for name, value in figures["k4_stages"].items():
                rows.append((f"  stage {name}", f"{value:.1f} s"))
    finally:
        shutil.rmtree(work, ignore_errors=True)

    width = max(len(r[0]) for r in rows)
    print(f"| {'case'.ljust(width)} | figure |")
    print(f"|{'-' * (width + 2)}|--------|")
    for name, value in rows:
        print(f"| {name.ljust(width)} | {value} |")
    if a.json:
        a.json.write_text(json.dumps(figures, indent=1))
    return 0


def busy_rows(work: Path, quiet: float, figures: dict) -> list[tuple[str, str]]:
    """The new-photo command beside a spinner, and beside another generate in a loop."""
    rows = []
    for label, hog in (("a single-threaded spinner", SPINNER), ("another generate in a loop", None)):
        stop = work / "stop"
        stop.unlink(missing_ok=True)
        if hog is None:
            loop = f"while [ ! -e {stop} ]; do BARKGEN_NO_CACHE=1 {' '.join(quickstart(work / 'hog', seed=7))}; done"
            proc = subprocess.Popen(
                ["bash", "-c", loop], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
            )
        else:
            proc = subprocess.Popen(hog, start_new_session=True)
        time.sleep(2.0)
        try:
            busy = [timed(quickstart(work / "b"), env=new_photo(work))[0] for i in range(3)]
        finally:
            stop.touch()
            os.killpg(proc.pid, 15)
            proc.wait()
        med = statistics.median(busy)
        figures[f"busy_{'spinner' if hog else 'generate'}_s"] = busy
        rows.append((f"beside {label} (median of 3)", f"{med:.2f} s = {med / quiet:.2f}x quiet"))
    return rows


if __name__ == "__main__":
    raise SystemExit(main())
