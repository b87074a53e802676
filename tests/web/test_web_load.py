"""Half a minute of load (issue 67): ``benchmarks/bench_load.py`` with 4 users for 30 s on a real
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
import time
from pathlib import Path

import numpy as np
import psutil

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_load.py"


def test_half_a_minute_of_load_with_a_kill_loses_and_doubles_nothing(tmp_path):
    figures = tmp_path / "load.json"
    run = subprocess.run(
        [sys.executable, str(SCRIPT), "--users", "4", "--seconds", "30", "--drain", "30", "--json", str(figures)]
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


def test_a_job_whose_result_was_stored_before_the_kill_is_done_not_run_again(tmp_path):
    """A kill between the library's write of a result and the job's ``done``: after the restart
    the job is done with that result (started again, it would be made twice); a job with no
    stored result is failed as interrupted, as before."""
    from barkgen.io import encode_png
    from barkgen.library import Library
    from barkgen.web.jobs import INTERRUPTED, JobManager

    library = Library(tmp_path / "lib")
    photo = np.random.default_rng(0).integers(0, 255, (64, 64, 3), dtype=np.uint8)
    exemplar = library.add_exemplar(encode_png(photo), "oak")
    params = {"size": [64, 64], "k": 3, "tile": False, "seed": 5, "material": False, "resumed_from": None}
    manager = JobManager(library)  # not started: the jobs stay as they are saved
    stored = manager.submit(exemplar.id, params, {})
    twin = manager.submit(exemplar.id, dict(params), {})  # the same request, its result not stored
    other = manager.submit(exemplar.id, {**params, "seed": 6}, {})
    began = time.time()
    for job in (stored, twin, other):  # the server was killed while they "ran"
        record = next(r for r in library.jobs.saved() if r["id"] == job.id)
        library.jobs.save({**record, "state": "running", "started": began})
    result = library.add_result(exemplar.id, params, 5, {"texture.png": encode_png(photo)})
    restored = JobManager(Library(library.path))
    done = restored.snapshot(stored.id)
    assert done["state"] == "done" and done["result_id"] == result.id
    for job in (twin, other):
        assert restored.snapshot(job.id)["state"] == "failed"
        assert restored.snapshot(job.id)["error"] == INTERRUPTED
    # a result older than the job is not its own
    record = next(r for r in library.jobs.saved() if r["id"] == other.id)
    library.jobs.save({**record, "state": "running", "started": began + 5, "params": params})
    assert JobManager(Library(library.path)).snapshot(other.id)["state"] == "failed"
