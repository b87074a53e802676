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

    .venv/bin/python benchmarks/bench_web.py --browser [--runs 3] [--tile] [--material] [--json F]

``--browser`` (issue 71): what a user sees, in Debian's Chromium (Playwright, 1366x768) on
``barkgen serve`` started on loopback with a fresh library and a fresh analysis cache each run:
(a) the bundled sample (1024²) uploaded -> its label map shown on the photo's page; (b) Generate
clicked with the page's defaults (1024x1024; tileable and material off unless ``--tile`` /
``--material``) -> the result's texture shown; (c) another seed (the result's "New seed…" page,
Generate) -> shown. ``--pick S``: the user's pause between the page opened and the upload
(the server's job process starts meanwhile); ``--think S``: between the label map shown and
Generate (the server makes the default settings' analysis meanwhile). Each run also splits (b) and (c) into the job's wait, its run in the worker
(as the server records them) and the rest (the page, the transfer). Medians of ``--runs``.
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


#: the web app's targets (issue 71): upload -> labels, click -> set, another seed -> set (s)
BROWSER_TARGETS_S = {"upload": 3.0, "generate": 5.0, "another_seed": 2.0}
SAMPLE = REPO / "src" / "barkgen" / "data" / "sample_bark.jpg"


def _shown(page, testid: str, timeout_ms: int = 600_000) -> None:
    """Wait until the page's image ``testid`` has a loaded picture (and no loading overlay)."""
    page.wait_for_function(
        f"() => {{ const img = document.querySelector('[data-testid={testid}]');"
        " const busy = document.querySelector('[data-testid=labels-loading]');"
        " return img && img.getAttribute('src') && img.complete && img.naturalWidth > 0"
        " && !(busy && !busy.hidden && img.classList.contains('is-loading')); }",
        timeout=timeout_ms,
        polling=20,
    )


def _generate_and_show(page) -> float:
    """Click Generate on an exemplar page, wait for the result's texture: seconds."""
    t = time.perf_counter()
    page.get_by_test_id("generate").click()
    page.wait_for_url("**/results/*", timeout=600_000)
    _shown(page, "result-texture")
    return time.perf_counter() - t


def browser_run(browser, photo: Path, tile: bool, material: bool, think_s: float = 0.0, pick_s: float = 0.0) -> dict:
    """One run on a new server, library and analysis cache: the three figures in seconds and the
    server's record of the two jobs."""
    from bench_relief_editor import _serve

    with tempfile.TemporaryDirectory() as folder:
        os.environ["BARKGEN_CACHE_DIR"] = str(Path(folder) / "cache")  # the served process' own
        process, server = _serve(Path(folder) / "lib")
        page = browser.new_page(viewport={"width": 1366, "height": 768})
        try:
            page.goto(server)
            time.sleep(pick_s)  # the user picks the file
            page.get_by_test_id("upload-file").set_input_files(str(photo))
            t = time.perf_counter()
            page.get_by_test_id("upload-submit").click()
            page.wait_for_url("**/exemplars/*")
            _shown(page, "labels-in")
            upload_s = time.perf_counter() - t
            page.get_by_test_id("param-tile").set_checked(tile)
            page.get_by_test_id("param-material").set_checked(material)
            size = page.get_by_test_id("param-size").input_value()
            time.sleep(think_s)  # the user looks at the label map and the settings
            generate_s = _generate_and_show(page)
            page.get_by_test_id("another-seed").click()
            page.wait_for_url("**/exemplars/*")
            _shown(page, "labels-in")
            page.get_by_test_id("param-seed").fill("77")
            another_s = _generate_and_show(page)
            jobs = page.request.get(f"{server}api/jobs").json()
        finally:
            page.close()
            process.terminate()
            process.wait(timeout=30)
            log = (Path(folder) / "serve.log").read_text()
    generated = sorted((j for j in jobs if j["kind"] == "generate"), key=lambda j: j["number"])
    split = [
        {"wait_s": j["started"] - j["created"], "run_s": j["finished"] - j["started"], "state": j["state"]}
        for j in generated
    ]
    labels = [j["finished"] - j["created"] for j in jobs if j["kind"] == "labels"]
    return {
        "upload_s": upload_s,
        "generate_s": generate_s,
        "another_seed_s": another_s,
        "size": size,
        "label_job_s": labels,
        "jobs": split,
        "compiles_logged": log.count("ompil"),
    }


def browser_main(args) -> None:
    from playwright.sync_api import sync_playwright

    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_relief_editor import CHROMIUM, CHROMIUM_ARGS

    if not CHROMIUM.exists():
        sys.exit(f"needs Debian's chromium at {CHROMIUM} (scripts/test.sh installs it)")
    runs = []
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            for i in range(args.runs):
                run = browser_run(browser, SAMPLE, args.tile, args.material, args.think, args.pick)
                runs.append(run)
                jobs = " | ".join(f"wait {j['wait_s']:.2f} run {j['run_s']:.2f}" for j in run["jobs"])
                print(
                    f"run {i + 1}: upload->labels {run['upload_s']:.2f} s, click->set {run['generate_s']:.2f} s, "
                    f"another seed {run['another_seed_s']:.2f} s  (jobs: {jobs}; label job "
                    f"{', '.join(f'{s:.2f}' for s in run['label_job_s']) or '-'})",
                    flush=True,
                )
        finally:
            browser.close()

    def med(key: str) -> float:
        return statistics.median(r[key] for r in runs)

    def job_med(index: int, key: str) -> float:
        return statistics.median(r["jobs"][index][key] for r in runs)

    size = runs[0]["size"]
    print(
        f"\nweb app in Chromium: sample 1024², {size}, tile {'on' if args.tile else 'off'}, "
        f"material {'on' if args.material else 'off'}, {args.pick:g} s to pick the photo, "
        f"{args.think:g} s between the label map and Generate; "
        f"medians of {len(runs)} runs"
    )
    rows = [
        ("upload -> label map shown", med("upload_s"), BROWSER_TARGETS_S["upload"], None),
        ("click Generate -> set shown", med("generate_s"), BROWSER_TARGETS_S["generate"], 0),
        ("another seed -> set shown", med("another_seed_s"), BROWSER_TARGETS_S["another_seed"], 1),
    ]
    print(f"{'':30} {'median s':>8} {'target':>7}  {'job wait':>8} {'job run':>8} {'page+rest':>9}")
    for name, value, target, job in rows:
        split = ""
        if job is not None:
            wait, run = job_med(job, "wait_s"), job_med(job, "run_s")
            split = f"{wait:8.2f} {run:8.2f} {value - wait - run:9.2f}"
        print(f"{name:30} {value:8.2f} {target:7.1f}  {split}")
    if args.json:
        args.json.write_text(json.dumps({"runs": runs, "args": vars(args) | {"json": str(args.json)}}, indent=2))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--browser", action="store_true", help="the three figures a user sees, in Chromium")
    parser.add_argument("--runs", type=int, default=3, help="--browser: runs (medians)")
    parser.add_argument("--tile", action="store_true", help="--browser: tileable sets")
    parser.add_argument(
        "--pick", type=float, default=0.0, help="--browser: seconds between the page opened and the upload"
    )
    parser.add_argument(
        "--think", type=float, default=0.0, help="--browser: seconds between the label map shown and Generate"
    )
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--material", action="store_true", help="material sets too")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if args.browser:
        browser_main(args)
        return
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
