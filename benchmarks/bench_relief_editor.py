#!/usr/bin/env python3
"""The web app's relief editor, timed in a real browser (issue 33, part 3).

    .venv/bin/python benchmarks/bench_relief_editor.py [--sizes 512 1024] [--clicks 12] [--json F]

For each size: ``barkgen serve`` on a new library, Debian's Chromium (Playwright, software
WebGL: no GPU here), the bundled sample generated tileable with material maps, the relief editor
switched on, then ``--clicks`` single edits, each waited for. An edit's time runs from the pointer
event to the trunk drawn again with the new relief (what the artist waits for), split into the
server's answer (the edited height, float32), the trunk's new normal and displacement textures
and its frame, and the overlay drawn on the texture. The server alone is timed too: the same
one-edit step posted from Python (the edit list one longer than the last).
"""

from __future__ import annotations

import argparse
import json
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _serve(library: Path) -> tuple[subprocess.Popen, str]:
    port = _free_port()
    log = library.parent / "serve.log"
    process = subprocess.Popen(
        [sys.executable, "-m", "barkgen", "serve", "--port", str(port), "--library", str(library)],
        stdout=log.open("w"),
        stderr=subprocess.STDOUT,
    )
    deadline = time.monotonic() + 60
    while "barkgen is running at" not in (log.read_text() if log.exists() else ""):
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            raise SystemExit(f"barkgen serve did not start:\n{log.read_text()}")
        time.sleep(0.2)
    return process, f"http://127.0.0.1:{port}/"


def _result_page(page, server: str, size: int) -> str:
    page.goto(server)
    page.get_by_test_id("exemplar-card").first.click()
    page.wait_for_url("**/exemplars/*")
    page.get_by_test_id("param-size").select_option(f"{size}x{size}")
    page.get_by_test_id("param-tile").check()
    page.get_by_test_id("param-material").check()
    page.get_by_test_id("param-seed").fill("5")
    page.get_by_test_id("generate").click()
    page.wait_for_url("**/results/*", timeout=600_000)
    page.wait_for_selector("[data-testid=trunk-canvas][data-ready='1']", timeout=120_000)
    page.wait_for_selector("[data-testid=relief-canvas][data-ready='1']", state="attached", timeout=120_000)
    page.get_by_test_id("relief-toggle").check()
    return page.url.rstrip("/").split("/")[-1]


def measure(browser, server: str, size: int, clicks: int) -> dict:
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    result_id = _result_page(page, server, size)
    canvas = page.get_by_test_id("relief-canvas")
    canvas.evaluate("c => c.scrollIntoView({block: 'center'})")
    box = canvas.bounding_box()
    latencies, phases = [], []
    for i in range(clicks):
        fx, fy = 0.1 + 0.8 * ((i * 0.37) % 1.0), 0.1 + 0.8 * ((i * 0.61) % 1.0)
        page.mouse.click(box["x"] + fx * box["width"], box["y"] + fy * box["height"])
        page.wait_for_function(
            f"() => JSON.parse(document.querySelector('[data-testid=relief-canvas]').dataset.latencies || '[]')"
            f".length === {i + 1}",
            timeout=60_000,
        )
        data = canvas.evaluate("c => ({...c.dataset})")
        latencies.append(json.loads(data["latencies"])[-1])
        phases.append(json.loads(data["phases"]))
    edits = page.evaluate(
        "() => fetch(document.querySelector('[data-testid=relief-download]').href).then(r => r.json())"
    )["edits"]
    # the server alone: one edit more than the list it answered last
    server_ms = []
    for n in range(1, len(edits) + 1):
        t = time.perf_counter()
        answer = page.request.post(f"{server}api/results/{result_id}/relief", data={"edits": edits[:n]})
        server_ms.append((time.perf_counter() - t) * 1000)
        assert answer.ok, answer.text()
    page.close()

    def median(key: str) -> float:
        return statistics.median(p[key] for p in phases)

    ordered = sorted(latencies)
    return {
        "size": size,
        "clicks": clicks,
        "latency_median_ms": statistics.median(latencies),
        "latency_p90_ms": ordered[int(0.9 * (len(ordered) - 1))],
        "latency_max_ms": ordered[-1],
        "fetch_median_ms": median("fetch"),
        "trunk_median_ms": median("trunk"),
        "draw_median_ms": median("draw"),
        "server_median_ms": statistics.median(server_ms),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[512, 1024])
    parser.add_argument("--clicks", type=int, default=12)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if not CHROMIUM.exists():
        raise SystemExit("needs Debian's chromium at /usr/bin/chromium (scripts/test.sh installs it)")
    from playwright.sync_api import sync_playwright

    rows = []
    print(
        f"{'size':>6} {'edits':>5} {'median ms':>9} {'p90 ms':>7} {'max ms':>7} "
        f"{'answer':>7} {'trunk':>6} {'overlay':>7} {'server':>7}"
    )
    with tempfile.TemporaryDirectory() as folder, sync_playwright() as playwright:
        process, server = _serve(Path(folder) / "lib")
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            for size in args.sizes:
                row = measure(browser, server, size, args.clicks)
                rows.append(row)
                print(
                    f"{size:>5}² {row['clicks']:>5} {row['latency_median_ms']:9.0f} {row['latency_p90_ms']:7.0f} "
                    f"{row['latency_max_ms']:7.0f} {row['fetch_median_ms']:7.0f} {row['trunk_median_ms']:6.0f} "
                    f"{row['draw_median_ms']:7.0f} {row['server_median_ms']:7.0f}",
                    flush=True,
                )
        finally:
            browser.close()
            process.terminate()
            process.wait(timeout=30)
    print(
        "ms per edit, pointer to relit trunk (target: under 300 at 1024²); answer = the server's edited "
        "height received, trunk = its textures and frame, overlay = the change drawn on the texture; "
        "server = the one-edit step posted from Python"
    )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
