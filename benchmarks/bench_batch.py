"""Benchmark of batch generation on Dask (``barkgen.batch``): throughput of 1 and 2 workers and
the scheduling overhead per task, on the same batch in the same run.

    .venv/bin/python benchmarks/bench_batch.py [--size 512] [--variants 8] [--repeats 3] [--json F]

The batch: 2 exemplars (fir, pine; 512 px centre crops of the shared photos) x ``--variants``
seeds at ``--size``², tileable, k = 3, as ``barkgen batch`` runs it (photo analysed once per
exemplar, shared with the workers). Each configuration runs ``--repeats`` times into a fresh
folder on a fresh LocalCluster. The cluster's start (worker processes importing barkgen,
:mod:`barkgen.batch.preload`) is shown apart and not counted: a cluster serves many batches.
The photos' analyses are counted.

- ``1 worker x 1 thread`` and ``2 workers x 1 thread``: the scaling the issue asks for (each
  worker one core), and ``1 worker x 2 threads``: one worker using both cores by itself;
- variants per minute (median), and their ratio to 1 worker x 1 thread;
- scheduling overhead per task from Dask's task stream: on each worker, the idle gaps between
  one task's end and the next one's start while tasks were waiting, plus the time spent
  fetching inputs (the shared analysis, the photo), divided by the number of variant tasks;
  its share of a variant's median compute time.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from barkgen.io import read_centre_crop  # noqa: E402

PHOTOS = {"fir": "fir_scaly_01", "pine": "pine_plated_01"}
CONFIGS = (("1 worker x 1 thread", 1, 1), ("1 worker x 2 threads", 1, 2), ("2 workers x 1 thread", 2, 1))


def make_spec(folder: Path, size: int, variants: int) -> Path:
    from barkgen.io import write_png

    entries = []
    for name, stem in PHOTOS.items():
        path = folder / f"{name}.png"
        write_png(path, read_centre_crop(next((SHARED / "data" / "bark").glob(stem + ".*")), 512))
        entries.append({"name": name, "path": path.name, "count": variants, "seed_base": 0})
    spec = folder / "spec.yaml"
    spec.write_text(json.dumps({"size": f"{size}x{size}", "tile": True, "k": 3, "exemplars": entries}))
    return spec


def overhead(records: list[dict]) -> tuple[float, float, int]:
    """(idle gaps + input transfers) in seconds over the variant tasks, median variant compute
    seconds, and the number of variant tasks, from Dask's task-stream records."""
    by_worker: dict[str, list[tuple[float, float, str]]] = {}
    transfer = 0.0
    compute = []
    for rec in records:
        for ss in rec["startstops"]:
            if ss["action"] == "compute":
                by_worker.setdefault(rec["worker"], []).append((ss["start"], ss["stop"], rec["key"]))
                if "variant" in str(rec["key"]):
                    compute.append(ss["stop"] - ss["start"])
            elif ss["action"] == "transfer":
                transfer += ss["stop"] - ss["start"]
    gaps = 0.0
    for tasks in by_worker.values():
        tasks.sort()
        for (_, end, _), (start, _, key) in zip(tasks, tasks[1:]):
            gaps += max(0.0, start - end)
    return (gaps + transfer), statistics.median(compute), len(compute)


def run_once(spec, out: Path, workers: int, threads: int) -> dict:
    from distributed import Client, get_task_stream

    from barkgen.batch import load_spec, local_cluster, run_batch

    t0 = time.perf_counter()
    cluster = local_cluster(workers, threads)  # workers start with barkgen imported (preload)
    try:
        with Client(cluster) as client:
            client.wait_for_workers(workers)
            start = time.perf_counter() - t0
            with get_task_stream(client) as stream:
                t0 = time.perf_counter()
                report = run_batch(load_spec(spec, threads=threads), out, client=client, threads=threads)
                wall = time.perf_counter() - t0
            records = stream.data
    finally:
        cluster.close()
    assert report.made == report.total and not report.failed, report
    over, median_compute, n = overhead(records)
    return {
        "start": start,
        "wall": wall,
        "per_minute": report.made / wall * 60,
        "overhead_per_task": over / n,
        "median_compute": median_compute,
        "analysis": statistics.mean(report.analysis_seconds.values()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--variants", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    results: dict[str, list[dict]] = {name: [] for name, _, _ in CONFIGS}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        spec = make_spec(folder, args.size, args.variants)
        for repeat in range(args.repeats):  # interleaved, so drift hits every configuration alike
            for name, workers, threads in CONFIGS:
                out = folder / f"out-{workers}-{threads}-{repeat}"
                results[name].append(run_once(spec, out, workers, threads))
                r = results[name][-1]
                print(
                    f"  run {repeat + 1}: {name}: {r['wall']:.1f} s, {r['per_minute']:.1f} variants/min",
                    file=sys.stderr,
                )
    base = statistics.median(r["per_minute"] for r in results[CONFIGS[0][0]])
    n = 2 * args.variants
    print(
        f"\nbatch: 2 exemplars x {args.variants} variants = {n} at {args.size}x{args.size}, tileable, "
        f"k = 3; medians of {args.repeats} runs"
    )
    print(
        f"{'configuration':24s} {'start s':>7s} {'wall s':>7s} {'var/min':>8s} {'x 1w1t':>7s} {'analysis s':>10s} "
        f"{'variant s':>9s} {'overhead/task s':>15s} {'overhead %':>10s}"
    )
    summary = {}
    for name, _, _ in CONFIGS:
        rs = results[name]
        med = {key: statistics.median(r[key] for r in rs) for key in rs[0]}
        share = 100 * med["overhead_per_task"] / med["median_compute"]
        summary[name] = {**med, "speedup": med["per_minute"] / base, "overhead_percent": share}
        print(
            f"{name:24s} {med['start']:7.1f} {med['wall']:7.1f} {med['per_minute']:8.1f} {med['per_minute'] / base:7.2f} "
            f"{med['analysis']:10.1f} {med['median_compute']:9.2f} {med['overhead_per_task']:15.3f} "
            f"{share:10.1f}"
        )
    two = summary["2 workers x 1 thread"]
    print(
        f"\n2 workers / 1 worker: {two['speedup']:.2f}x (target >= 1.6); against 1 worker using both "
        f"cores: {two['per_minute'] / summary['1 worker x 2 threads']['per_minute']:.2f}x"
    )
    print(
        f"scheduling overhead per task, 2 workers: {two['overhead_percent']:.1f} % of a variant's "
        "compute (target <= 5 %)"
    )
    if args.json:
        args.json.write_text(
            json.dumps({"size": args.size, "variants": args.variants, "results": results, "summary": summary}, indent=2)
        )


if __name__ == "__main__":
    main()
