"""Benchmark of the web app's jobs (``barkgen serve``): what a generate costs through the server
compared with the same calls made directly, and how responsive the server stays meanwhile.

    .venv/bin/python benchmarks/bench_web.py [--size 512] [--seeds 4] [--material] [--json F]

One photo (oak, the shared photo's 1024 px as uploaded), ``--seeds`` seeds at ``--size``²,
tileable, k = 3, in the same process and run:

- direct: :func:`barkgen.pipeline.analyze_photo` once, then per seed
  :func:`barkgen.pipeline.generate` with that analysis and the files encoded as the server
  stores them (:func:`barkgen.web.worker.encode_result`): the server's own work without the
  server;
- server: the app on a fresh library (FastAPI TestClient, a real worker process), the photo
  uploaded, one job per seed submitted at once; per job the time from its start (running) to
  done as the server records them (the worker's work, the file transfer and the library
  write), and the first job's submit-to-done time, which holds the worker process' start and the photo's analysis;
- responsiveness: the latency of ``GET /api/jobs/{id}`` and ``GET /api/exemplars`` polled
  every 0.25 s while the jobs run (median and 95th percentile).

Medians; ratio server / direct per seed after the first.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(REPO / "src"))

PHOTO = SHARED / "data" / "bark" / "oak_furrowed_moss_01.jpg"


def direct(photo_bytes: bytes, size: int, seeds: list[int], material: bool) -> dict:
    from barkgen.io import decode_image
    from barkgen.pipeline import GenerateOptions, analyze_photo, generate
    from barkgen.web.worker import JobSpec, encode_result

    photo = decode_image(photo_bytes)
    options = GenerateOptions(size=(size, size), k=3, tile=True, material=material, seed=seeds[0])
    t0 = time.perf_counter()
    analysis = analyze_photo(photo, options)
    analysis_s = time.perf_counter() - t0
    per_seed = []
    for seed in seeds:
        t = time.perf_counter()
        opts = GenerateOptions(size=(size, size), k=3, tile=True, material=material, seed=seed)
        result = generate(photo, opts, analysis=analysis)
        encode_result(
            photo, result, JobSpec(job_id="x", photo=b"", photo_hash="", source="oak", options={}, set_name="bench")
        )
        per_seed.append(time.perf_counter() - t)
    return {"analysis_s": analysis_s, "per_seed_s": per_seed}


def server(photo_bytes: bytes, size: int, seeds: list[int], material: bool) -> dict:
    from fastapi.testclient import TestClient

    from barkgen.library import Library
    from barkgen.web import create_app

    latencies: dict[str, list[float]] = {"job": [], "exemplars": []}
    with tempfile.TemporaryDirectory() as folder, TestClient(create_app(Library(Path(folder) / "lib"))) as client:
        exemplar_id = client.post("/api/exemplars", files={"file": ("oak.jpg", photo_bytes)}).json()["id"]
        client.get(f"/api/exemplars/{exemplar_id}/labels.png?k=3")  # the page shows it before Generate
        ids = [
            client.post(
                "/api/jobs",
                json={
                    "exemplar_id": exemplar_id,
                    "size": f"{size}x{size}",
                    "seed": seed,
                    "k": 3,
                    "tile": True,
                    "material": material,
                },
            ).json()["id"]
            for seed in seeds
        ]
        finished: dict[str, dict] = {}
        stop = threading.Event()

        def poll_other() -> None:
            while not stop.is_set():
                t = time.perf_counter()
                client.get("/api/exemplars")
                latencies["exemplars"].append(time.perf_counter() - t)
                time.sleep(0.25)

        other = threading.Thread(target=poll_other)
        other.start()
        while len(finished) < len(ids):
            for job_id in ids:
                if job_id in finished:
                    continue
                t = time.perf_counter()
                job = client.get(f"/api/jobs/{job_id}").json()
                latencies["job"].append(time.perf_counter() - t)
                if job["state"] in ("done", "failed", "cancelled"):
                    assert job["state"] == "done", job
                    finished[job_id] = job
            time.sleep(0.25)  # about what a page costs the server (its events are pushed)
        stop.set()
        other.join()
    return {
        "first_submit_to_done_s": finished[ids[0]]["finished"] - finished[ids[0]]["created"],
        "per_seed_s": [finished[j]["finished"] - finished[j]["started"] for j in ids],
        "latency_ms": {
            k: (statistics.median(v) * 1000, sorted(v)[int(0.95 * (len(v) - 1))] * 1000) for k, v in latencies.items()
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--material", action="store_true", help="material sets too")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if not PHOTO.is_file():
        sys.exit(f"needs the shared photo {PHOTO} (set BARKGEN_SHARED)")
    photo_bytes = PHOTO.read_bytes()
    seeds = list(range(args.seeds))
    direct(photo_bytes, 128, seeds[:1], args.material)  # compile / load the numba kernels first
    d = direct(photo_bytes, args.size, seeds, args.material)
    s = server(photo_bytes, args.size, seeds, args.material)
    d_med = statistics.median(d["per_seed_s"][1:] or d["per_seed_s"])
    s_med = statistics.median(s["per_seed_s"][1:] or s["per_seed_s"])
    rows = [
        ("photo analysis (direct)", f"{d['analysis_s']:.2f} s"),
        ("per seed, direct (median of seeds 2..n)", f"{d_med:.2f} s"),
        ("per seed, through the server (running -> done)", f"{s_med:.2f} s"),
        ("server / direct", f"{s_med / d_med:.2f}x ({(s_med - d_med) * 1000:+.0f} ms)"),
        ("first job, submit -> done (worker start + analysis)", f"{s['first_submit_to_done_s']:.2f} s"),
        ("GET /api/jobs/{id} while jobs run: median / p95", "{:.1f} / {:.1f} ms".format(*s["latency_ms"]["job"])),
        ("GET /api/exemplars while jobs run: median / p95", "{:.1f} / {:.1f} ms".format(*s["latency_ms"]["exemplars"])),
    ]
    title = f"web jobs: {args.size}x{args.size}, {args.seeds} seeds, material {'on' if args.material else 'off'}"
    width = max(len(r[0]) for r in rows)
    print(title)
    print("-" * (width + 16))
    for name, value in rows:
        print(f"{name.ljust(width)}  {value}")
    if args.json:
        args.json.write_text(
            json.dumps({"direct": d, "server": s, "args": vars(args) | {"json": str(args.json)}}, indent=2)
        )


if __name__ == "__main__":
    main()
