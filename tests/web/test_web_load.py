"""A minute of load (issue 67): ``benchmarks/bench_load.py`` with 4 users for 60 s on a real
``barkgen serve`` (loopback, a key), killed with -9 halfway and restarted on the same library.
No answer is a 5xx, no job is lost or run twice (a job the kill interrupted is failed, and its user
starts it again), every user gets jobs done, and the library is whole at the end (every listed
photo and result has its files, SQLite's integrity check is ok).

The benchmark runs as a program of its own (tests never import the benchmarks); it stops by itself
(a hard deadline) and kills its server and worker whatever happens."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import psutil

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_load.py"


def test_a_minute_of_load_with_a_kill_loses_and_doubles_nothing(tmp_path):
    figures = tmp_path / "load.json"
    run = subprocess.run(
        [sys.executable, str(SCRIPT), "--users", "4", "--seconds", "60", "--drain", "30", "--json", str(figures)]
        + ["--folder", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert figures.exists(), run.stdout + run.stderr
    report = json.loads(figures.read_text())
    table = run.stdout
    assert report["kill"] is not None and report["kill"]["restart_s"] > 0, table
    assert report["server_errors"] == 0, table
    assert report["odd_count"] == 0, report["odd"]
    jobs, library = report["jobs"], report["library"]
    assert jobs["submitted"] > 4 and jobs["done"] > 4, table
    assert library["lost"] == [], table
    assert library["results_of_two_jobs"] == [] and library["results_of_no_job"] == [], table
    assert jobs["seen_done_then_not"] == 0, table
    assert jobs["failed_other"] == [], table
    assert jobs["failed_interrupted"] == jobs["retried"], table  # each interrupted job started again
    assert all(user["done"] > 0 for user in jobs["per_user"]), table  # no user starved
    assert library["problems"] == [] and library["integrity_check"] == "ok", table
    assert library["results"] > 0 and library["files_checked"] > 0, table
    assert run.returncode == 0, table + run.stderr
    assert _processes_of(tmp_path) == [], "the benchmark left processes behind"


def _processes_of(folder) -> list[int]:
    """The processes (the server, its worker) whose analysis cache is in ``folder``."""
    found = []
    for process in psutil.process_iter():
        try:
            if str(folder) in process.environ().get("BARKGEN_CACHE_DIR", ""):
                found.append(process.pid)
        except psutil.Error:
            pass
    return found
