#!/usr/bin/env python3
"""Speed and memory benchmark of ``barkgen synth`` against G'MIC, in one run.

    .venv/bin/python benchmarks/bench_synth.py [--runs 5] [--peer-runs 3] [--skip-4k] [--skip-peers]

Cases (whole commands, start-up included, wall clock; medians over runs, interleaved so machine
drift hits every tool alike):

1. 256x256 exemplar -> 1024x1024 tileable: barkgen vs G'MIC ``syntexturize_matchpatch`` + seamless
   frame (``../shared/eval/peers/gmic.sh --tile``); ratio barkgen / G'MIC.
2. 256x256 -> 4096x4096 tileable: wall time and peak memory (max RSS of the process).
3. Thread scaling (mazzolini2012 §6.3): 256 -> 2048 tileable with ``--threads 1`` and ``--threads 2``:
   speed-up and parallel efficiency, for the whole command and for the solver alone (in process).
4. Numba compilation: the first run with an empty cache (``NUMBA_CACHE_DIR`` pointed at a fresh
   folder) against a warm run.

The exemplar is the centre crop of ``../shared/data/bark/pine_plated_01.jpg`` (as compare.py makes
it); with no shared folder, the bundled sample is used and the peer is skipped.
"""

from __future__ import annotations

import argparse
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


def timed(cmd: list[str], env: dict | None = None) -> tuple[float, float]:
    """Run ``cmd``; return (wall seconds, peak RSS in MiB) of that process tree's main process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    dt = time.perf_counter() - t0
    err = proc.stderr.read().decode() if proc.stderr else ""
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}): {err[-500:]}")
    return dt, usage.ru_maxrss / 1024.0


def make_exemplar(dst: Path) -> Path:
    src = SHARED / "data" / "bark" / "pine_plated_01.jpg"
    from PIL import Image

    if not src.exists():
        sys.path.insert(0, str(REPO / "src"))
        from barkgen.data import sample_exemplar_path

        src = sample_exemplar_path()
    im = Image.open(src).convert("RGB")
    w, h = im.size
    s = 256 / min(w, h)
    im = im.resize((max(256, round(w * s)), max(256, round(h * s))), Image.LANCZOS)
    w, h = im.size
    im.crop(((w - 256) // 2, (h - 256) // 2, (w - 256) // 2 + 256, (h - 256) // 2 + 256)).save(dst)
    return dst


def synth_cmd(ex: Path, out: Path, size: int, *extra: str) -> list[str]:
    return BARKGEN + ["synth", str(ex), "-o", str(out), "--size", f"{size}x{size}", "--tile", "-q", *extra]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--peer-runs", type=int, default=3)
    ap.add_argument("--skip-4k", action="store_true")
    ap.add_argument("--skip-peers", action="store_true")
    a = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="barkgen-bench-"))
    ex = make_exemplar(work / "ex256.png")
    gmic = SHARED / "eval" / "peers" / "gmic.sh"
    have_gmic = (
        not a.skip_peers
        and gmic.exists()
        and subprocess.run(["python3", "-c", "import gmic"], capture_output=True).returncode == 0
    )
    rows: list[tuple[str, str]] = []

    # warm-up: compile/load the numba cache once
    timed(synth_cmd(ex, work / "warm.png", 256))

    # 1. 256 -> 1024 tileable, interleaved with G'MIC
    ours, theirs = [], []
    for i in range(max(a.runs, a.peer_runs if have_gmic else 0)):
        if i < a.runs:
            ours.append(timed(synth_cmd(ex, work / "b1024.png", 1024, "--seed", str(i)))[0])
        if have_gmic and i < a.peer_runs:
            theirs.append(
                timed(
                    ["bash", str(gmic), str(ex), str(work / "g1024.png"), "1024", "1024", "--tile", "--seed", str(i)]
                )[0]
            )
    med = statistics.median(ours)
    rows.append(("256->1024 tileable, barkgen synth (median of %d)" % len(ours), f"{med:.2f} s"))
    if theirs:
        gm = statistics.median(theirs)
        rows.append(("256->1024 tileable, G'MIC matchpatch (median of %d)" % len(theirs), f"{gm:.2f} s"))
        rows.append(("ratio barkgen / G'MIC", f"{med / gm:.3f}x"))

    # 2. 4096 x 4096
    if not a.skip_4k:
        t, rss = timed(synth_cmd(ex, work / "b4096.png", 4096))
        rows.append(("256->4096 tileable, wall", f"{t:.1f} s"))
        rows.append(("256->4096 tileable, peak RSS", f"{rss / 1024:.2f} GiB"))

    # 3. threads
    t1s, t2s = [], []
    for i in range(3):
        t1s.append(timed(synth_cmd(ex, work / "t1.png", 2048, "--threads", "1"))[0])
        t2s.append(timed(synth_cmd(ex, work / "t2.png", 2048, "--threads", "2"))[0])
    t1, t2 = statistics.median(t1s), statistics.median(t2s)
    rows.append(("256->2048 tileable, 1 thread (median of 3)", f"{t1:.2f} s"))
    rows.append(("256->2048 tileable, 2 threads (median of 3)", f"{t2:.2f} s"))
    rows.append(("speed-up 1->2 threads / efficiency", f"{t1 / t2:.2f}x / {t1 / t2 / 2:.0%}"))
    same = (work / "t1.png").read_bytes() == (work / "t2.png").read_bytes()
    rows.append(("1-thread and 2-thread outputs byte-identical", "yes" if same else "NO"))

    # 3b. the same, in process: the solver alone (start-up, I/O and analysis excluded)
    code = (
        "import sys, time, statistics; sys.path.insert(0, %r)\n"
        "from barkgen.io import read_image\n"
        "from barkgen.synth import synthesize, SynthesisConfig\n"
        "ex = read_image(%r); synthesize(ex, 128, tile=True)\n"
        "res = {1: [], 2: []}\n"
        "for _ in range(3):\n"
        "    for n in (1, 2):\n"
        "        r = synthesize(ex, 2048, tile=True, config=SynthesisConfig(threads=n))\n"
        "        res[n].append(r.timings['synthesis'])\n"
        "print(statistics.median(res[1]), statistics.median(res[2]))\n"
    ) % (str(REPO / "src"), str(ex))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    s1, s2 = (float(v) for v in out.stdout.split())
    rows.append(("solver only (in process), 2048, 1 / 2 threads", f"{s1:.2f} s / {s2:.2f} s"))
    rows.append(("solver speed-up 1->2 threads / efficiency", f"{s1 / s2:.2f}x / {s1 / s2 / 2:.0%}"))

    # 4. numba cache: cold vs warm
    cache = Path(tempfile.mkdtemp(prefix="barkgen-numba-"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    cold = timed(synth_cmd(ex, work / "c.png", 1024), env=env)[0]
    warm = timed(synth_cmd(ex, work / "c.png", 1024), env=env)[0]
    rows.append(("first run ever (empty numba cache), 256->1024", f"{cold:.2f} s"))
    rows.append(("second run (cache filled), 256->1024", f"{warm:.2f} s"))
    shutil.rmtree(cache, ignore_errors=True)

    print(f"barkgen benchmark, {os.cpu_count()} cores, exemplar {ex.name}")
    print("| case | value |")
    print("|---|---|")
    for k, v in rows:
        print(f"| {k} | {v} |")
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
