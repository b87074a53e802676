"""A day of load in ten minutes (issue 67): ``--users`` simulated users on a real ``barkgen serve``
for ``--seconds``, with a kill -9 of the server and its worker in the middle and a restart on the
same library.

    .venv/bin/python benchmarks/bench_load.py [--users 20] [--seconds 600] [--no-kill] [--json F]

The server listens on 127.0.0.1 only (a free port, a key given with ``--token`` that every request
carries), on a fresh library and analysis cache in a temporary folder. Each user (a thread with its
own httpx client, a timeout on every request) loops over a weighted mix with think times: upload a
crop (128-256 px) of the bundled sample photo, start a generate job (64-128 px, some with the
material set), paint a level of a result and continue from it (the result page's painter), view,
download the zip and single files, list, delete results and photos. A user waits for its own job
(one at a time, as the page does); a job failed by the kill (``interrupted``) is started again.

Measured: the responses by status and route kind (p50/p95/p99 of their times); the jobs submitted,
done, failed, interrupted and retried, lost (unknown to the server or never finished) and run twice
(seen done then again not done, one result for two jobs, or a result no job made); per user the
jobs done and the longest wait in the queue; the peak RSS of the server and of its worker; at the
end every listed exemplar and result has its files, and SQLite's ``integrity_check`` is ``ok``.

The run is bounded: a hard deadline (the load, the restart, a drain of the queue and the checks)
after which every child is killed; every child is killed on Ctrl-C or an error too.
"""

from __future__ import annotations

import argparse
import base64
import io
import json
import os
import random
import secrets
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import psutil

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))

#: the error of a job its server's stop interrupted (barkgen.web.jobs.INTERRUPTED starts so)
INTERRUPTED = "interrupted"
REQUEST_TIMEOUT_S = 30.0
SIZES = ("64x64", "96x96", "128x128")
#: the weighted mix of a user's actions
MIX = {"upload": 1.0, "generate": 4.0, "paint": 1.5, "view": 2.0, "download": 1.5, "file": 2.0, "list": 3.0}
MIX_DELETE = {"delete_result": 0.7, "delete_exemplar": 0.3}


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class Server:
    """``barkgen serve`` on loopback in a session of its own (so that its worker dies with it)."""

    def __init__(self, folder: Path, token: str) -> None:
        self.folder, self.token = folder, token
        self.library = folder / "library"
        self.port = _free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.process: subprocess.Popen | None = None
        self.known: dict[int, psutil.Process] = {}  # every process seen, to kill at the end
        self.peak = {"server_mb": 0.0, "worker_mb": 0.0, "total_mb": 0.0}

    def start(self, timeout_s: float = 120.0) -> float:
        """Start it and wait until it answers: the seconds it took."""
        began = time.monotonic()
        env = {k: v for k, v in os.environ.items() if k not in ("BARKGEN_TOKEN", "BARKGEN_LIBRARY")}
        env["BARKGEN_CACHE_DIR"] = str(self.folder / "cache")
        log = (self.folder / "serve.log").open("a")
        command = [sys.executable, "-m", "barkgen", "serve", "--host", "127.0.0.1", "--port", str(self.port)]
        command += ["--library", str(self.library), "--token", self.token]
        self.process = subprocess.Popen(
            command, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True, cwd=self.folder
        )
        log.close()
        self.known[self.process.pid] = psutil.Process(self.process.pid)
        headers = {"X-Barkgen-Token": self.token}
        while time.monotonic() - began < timeout_s:
            if self.process.poll() is not None:
                raise RuntimeError(f"barkgen serve ended (code {self.process.returncode}); see {self.folder}/serve.log")
            try:
                if httpx.get(f"{self.base}/api/jobs", headers=headers, timeout=2).status_code == 200:
                    return time.monotonic() - began
            except httpx.HTTPError:
                pass
            time.sleep(0.2)
        raise RuntimeError(f"barkgen serve did not answer within {timeout_s:.0f} s")

    def print_log_tail(self, lines: int = 40) -> None:
        """The end of the server's log, on stderr."""
        log = self.folder / "serve.log"
        if log.exists():
            tail = log.read_text(errors="replace").splitlines()[-lines:]
            print("bench_load: the end of serve.log:", *tail, sep="\n  ", file=sys.stderr)

    def sample_memory(self) -> None:
        """Note the server's and its children's RSS (peaks in MB)."""
        if self.process is None:
            return
        try:
            main = psutil.Process(self.process.pid)
            children = main.children(recursive=True)
            for child in children:
                self.known.setdefault(child.pid, child)
            server = main.memory_info().rss / 2**20
            worker = max((c.memory_info().rss for c in children), default=0) / 2**20
            total = server + sum(c.memory_info().rss for c in children) / 2**20
        except psutil.Error:
            return
        for key, value in (("server_mb", server), ("worker_mb", worker), ("total_mb", total)):
            self.peak[key] = max(self.peak[key], value)

    def kill(self) -> None:
        """kill -9 of the server, its worker and every process of its session."""
        if self.process is None:
            return
        self.sample_memory()
        try:
            os.killpg(self.process.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        self.process.wait(timeout=10)
        self._kill_known()

    def stop(self) -> None:
        """Stop it as Ctrl-C does (a kill after 20 s)."""
        if self.process is None or self.process.poll() is not None:
            self._kill_known()
            return
        self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.kill()
        self._kill_known()

    def _kill_known(self) -> None:
        for process in self.known.values():
            try:
                if process.is_running():
                    process.kill()
            except psutil.Error:
                pass


@dataclass
class JobRecord:
    user: int
    kind: str
    submitted: float
    states: list[str] = field(default_factory=list)
    final: dict | None = None
    retried: bool = False


class Recorder:
    """Every response and job, shared by the users (under a lock)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.status: Counter = Counter()  # (kind, status)
        self.times: dict[str, list[float]] = defaultdict(list)
        self.odd: list[str] = []  # 5xx, unexpected 4xx, failed checks: a line each
        self.jobs: dict[str, JobRecord] = {}
        self.down = threading.Event()  # the server is being killed and restarted
        self.down_errors = 0
        self.counts: Counter = Counter()

    def note(self, kind: str, status: int, seconds: float, detail: str = "") -> None:
        with self.lock:
            self.status[(kind, status)] += 1
            if status:
                self.times[kind].append(seconds)
            if status >= 500 or (400 <= status < 500 and status != 429):
                self.odd.append(f"{kind} {status} {detail[:160]}")
            if status == 0:
                if self.down.is_set():
                    self.down_errors += 1
                else:
                    self.odd.append(f"{kind}: no answer ({detail[:120]})")

    def job_seen(self, job_id: str, snapshot: dict) -> None:
        with self.lock:
            record = self.jobs.get(job_id)
            if record is None:
                return
            state = snapshot["state"]
            if record.states and record.states[-1] == "done" and state != "done":
                self.odd.append(f"job {job_id} was done, then {state}")
                self.counts["run twice"] += 1
            if not record.states or record.states[-1] != state:
                record.states.append(state)
            if state in ("done", "failed", "cancelled"):
                record.final = snapshot


class User(threading.Thread):
    """One simulated user of the page, on its own photos and results."""

    def __init__(self, number: int, server: Server, recorder: Recorder, stop: threading.Event, photo) -> None:
        super().__init__(name=f"user-{number}", daemon=True)
        self.number, self.server, self.rec, self.stop_event, self.photo = number, server, recorder, stop, photo
        self.rng = random.Random(1000 + number)
        self.exemplars: list[int] = []
        self.results: dict[int, int] = {}  # result id -> its exemplar id
        self.pending: str | None = None
        self.pending_body: dict | None = None
        self.unanswered: tuple[dict, bool] | None = None  # a submit that got no answer
        self.refused_upload: bytes | None = None  # a photo answered 429, to send again
        self.client = httpx.Client(headers={"X-Barkgen-Token": server.token}, timeout=REQUEST_TIMEOUT_S)

    def call(self, kind: str, method: str, path: str, **kwargs) -> httpx.Response | None:
        began = time.perf_counter()
        try:
            response = self.client.request(method, self.server.base + path, **kwargs)
        except httpx.HTTPError as exc:
            self.rec.note(kind, 0, time.perf_counter() - began, f"{type(exc).__name__}: {exc}")
            return None
        detail = response.text if response.status_code >= 400 else ""
        self.rec.note(kind, response.status_code, time.perf_counter() - began, f"{method} {path}: {detail}")
        return response

    def run(self) -> None:
        try:
            while not self.stop_event.is_set():
                if self.unanswered is not None and not self.rec.down.is_set():
                    self.find_unanswered()
                if self.pending is not None:
                    self.poll()
                action = self.choose()
                getattr(self, action)()
                self.stop_event.wait(self.rng.uniform(0.3, 1.5))  # the user thinks
        except Exception as exc:  # noqa: BLE001 - the benchmark reports it
            with self.rec.lock:
                self.rec.odd.append(f"user {self.number} stopped: {type(exc).__name__}: {exc}")
        finally:
            self.client.close()

    def choose(self) -> str:
        weights = dict(MIX)
        if not self.exemplars:
            weights = {"upload": 1.0, "list": 0.5}
        if len(self.exemplars) >= 3:
            weights["upload"] = 0.1
        if self.pending is not None or self.unanswered is not None:
            weights["generate"] = weights["paint"] = 0.0
        if not self.results:
            for name in ("paint", "view", "download", "file"):
                weights[name] = 0.0
        if self.pending is None and len(self.results) > 2:
            weights.update(MIX_DELETE)
        names = [n for n, w in weights.items() if w > 0]
        return self.rng.choices(names, [weights[n] for n in names])[0]

    # -- the actions -----------------------------------------------------------------------
    def upload(self) -> None:
        data, self.refused_upload = self.refused_upload, None  # a refused photo is sent again
        retried = data is not None
        if data is None:
            side = self.rng.randrange(128, 257)
            x, y = self.rng.randrange(0, self.photo.width - side), self.rng.randrange(0, self.photo.height - side)
            buffer = io.BytesIO()
            self.photo.crop((x, y, x + side, y + side)).save(buffer, "PNG")
            data = buffer.getvalue()
        files = {"file": (f"bark-u{self.number}.png", data, "image/png")}
        response = self.call("upload", "POST", "/api/exemplars", files=files)
        if response is not None and response.status_code == 429:
            self.refused_upload = data
            self.stop_event.wait(self.rng.uniform(2, 5))  # the user waits, then tries again
        if response is not None and response.status_code in (200, 201):
            answer = response.json()
            if answer["existing"] and retried:
                with self.rec.lock:  # refused as busy, yet kept
                    self.rec.counts["upload refused, yet kept"] += 1
            exemplar_id = answer["id"]
            if exemplar_id not in self.exemplars:
                self.exemplars.append(exemplar_id)
            self.call("labels", "POST", f"/api/exemplars/{exemplar_id}/labels?k=3")  # as the page asks

    def generate(self) -> None:
        body = {
            "exemplar_id": self.rng.choice(self.exemplars),
            "size": self.rng.choice(SIZES),
            "tile": self.rng.random() < 0.5,
            "material": self.rng.random() < 0.3,
            "seed": self.rng.randrange(100_000),
        }
        self.submit(body)

    def submit(self, body: dict, retried: bool = False) -> None:
        response = self.call("submit", "POST", "/api/jobs", json=body)
        if response is not None and response.status_code == 201:
            job_id = response.json()["id"]
            with self.rec.lock:
                kind = "paint" if "resume" in body else "generate"
                self.rec.jobs[job_id] = JobRecord(self.number, kind, time.time(), retried=retried)
            self.pending, self.pending_body = job_id, body
        elif response is not None and response.status_code == 429:
            self.stop_event.wait(self.rng.uniform(2, 5))  # the queue is full: the user waits
        elif response is None:  # the server went down: was the job queued before?
            self.unanswered = (body, retried)

    def find_unanswered(self) -> None:
        """After a submit with no answer, look for its job in the server's list (a page's job
        panel shows it): follow it if it is there, else it was never queued."""
        response = self.call("list", "GET", "/api/jobs")
        if response is None or response.status_code != 200:
            return
        assert self.unanswered is not None  # (the caller's condition)
        body, retried = self.unanswered
        width, height = (int(n) for n in body["size"].split("x"))
        resumed = body["resume"]["result_id"] if "resume" in body else None
        with self.rec.lock:
            for job in response.json():
                if (
                    job["id"] not in self.rec.jobs
                    and job["kind"] == "generate"
                    and job["exemplar_id"] == body["exemplar_id"]
                    and job["params"]["seed"] == body["seed"]
                    and job["params"]["size"] == [width, height]
                    and (job["params"].get("resumed_from") or {}).get("result_id") == resumed
                ):
                    record = JobRecord(self.number, "paint" if resumed else "generate", time.time(), retried=retried)
                    self.rec.jobs[job["id"]] = record
                    self.rec.counts["unanswered, queued"] += 1
                    self.pending, self.pending_body = job["id"], body
                    break
            else:
                self.rec.counts["unanswered, not queued"] += 1
        self.unanswered = None

    def poll(self) -> None:
        response = self.call("poll", "GET", f"/api/jobs/{self.pending}")
        if response is None or response.status_code != 200:
            return
        snapshot = response.json()
        self.rec.job_seen(self.pending, snapshot)
        if snapshot["state"] == "done":
            self.results[snapshot["result_id"]] = snapshot["exemplar_id"]
        elif snapshot["state"] == "failed" and (snapshot["error"] or "").startswith(INTERRUPTED):
            body, self.pending = self.pending_body, None
            with self.rec.lock:
                self.rec.counts["retried"] += 1
            self.submit(cast_dict(body), retried=True)  # the page's "start it again"
            return
        if snapshot["state"] in ("done", "failed", "cancelled"):
            self.pending = self.pending_body = None

    def paint(self) -> None:
        from PIL import Image

        result_id = self.rng.choice(sorted(self.results))
        response = self.call("result", "GET", f"/api/results/{result_id}")
        if response is None or response.status_code != 200:
            return
        result = response.json()
        if not result["levels"]:
            return
        level = self.rng.choice(result["levels"])
        picture = self.call("file", "GET", level["url"])
        if picture is None or picture.status_code != 200:
            return
        image = Image.open(io.BytesIO(picture.content)).convert("RGB")
        colour = tuple(self.rng.choice(result["palette"]))
        w, h = image.size
        x, y = self.rng.randrange(w), self.rng.randrange(h)
        image.paste(colour, (x, y, min(w, x + max(2, w // 4)), min(h, y + max(2, h // 4))))  # a brush stroke
        buffer = io.BytesIO()
        image.save(buffer, "PNG")
        labels = "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")
        params = result["params"]
        body = {
            "exemplar_id": result["exemplar_id"],
            "size": f"{params['size'][0]}x{params['size'][1]}",
            "k": params["k"],
            "tile": params["tile"],
            "material": params["material"],
            "seed": params["seed"],
            "resume": {"result_id": result_id, "level": level["level"], "labels": labels},
        }
        self.submit(body)

    def view(self) -> None:
        result_id = self.rng.choice(sorted(self.results))
        self.call("result", "GET", f"/api/results/{result_id}")

    def download(self) -> None:
        result_id = self.rng.choice(sorted(self.results))
        response = self.call("zip", "GET", f"/api/results/{result_id}/download")
        if response is not None and response.status_code == 200:
            with zipfile.ZipFile(io.BytesIO(response.content)) as archive:
                if archive.testzip() is not None:
                    with self.rec.lock:
                        self.rec.odd.append(f"result {result_id}: a broken zip")

    def file(self) -> None:
        result_id = self.rng.choice(sorted(self.results))
        response = self.call("result", "GET", f"/api/results/{result_id}")
        if response is not None and response.status_code == 200:
            url = self.rng.choice(sorted(response.json()["files"].values()))
            self.call("file", "GET", url)

    def list(self) -> None:
        path = self.rng.choice(("/api/exemplars", "/api/results", "/api/jobs"))
        self.call("list", "GET", path)

    def delete_result(self) -> None:
        result_id = self.rng.choice(sorted(self.results))
        del self.results[result_id]
        self.call("delete", "DELETE", f"/api/results/{result_id}")

    def delete_exemplar(self) -> None:
        if len(self.exemplars) < 2:
            return
        exemplar_id = self.exemplars.pop(0)
        self.call("delete", "DELETE", f"/api/exemplars/{exemplar_id}")
        self.results = {r: e for r, e in self.results.items() if e != exemplar_id}  # they went with it


def cast_dict(value: dict | None) -> dict:
    assert value is not None
    return value


# -- the run -------------------------------------------------------------------------------------
def _kill_in_the_middle(server: Server, recorder: Recorder, headers: dict) -> dict:
    """kill -9 the server and its worker (while a job runs, if one does within 15 s), restart it
    on the same library: what was in flight and how long it took."""
    in_flight: list[dict] = []
    waited_until = time.monotonic() + 15
    while time.monotonic() < waited_until:
        try:
            in_flight = [j for j in httpx.get(f"{server.base}/api/jobs", headers=headers, timeout=10).json()]
        except httpx.HTTPError:
            in_flight = []
        in_flight = [j for j in in_flight if j["state"] in ("queued", "running")]
        if any(j["state"] == "running" and j["kind"] == "generate" for j in in_flight):
            break
        time.sleep(0.3)
    recorder.down.set()
    began = time.monotonic()
    server.kill()
    restart_s = server.start()
    recorder.down.clear()
    return {
        "running_at_kill": sum(j["state"] == "running" for j in in_flight),
        "queued_at_kill": sum(j["state"] == "queued" for j in in_flight),
        "down_s": round(time.monotonic() - began, 2),
        "restart_s": round(restart_s, 2),
    }


def _drain(server: Server, recorder: Recorder, headers: dict, limit_s: float) -> None:
    """Follow every job a user submitted until it is finished (or ``limit_s`` passed)."""
    until = time.monotonic() + limit_s
    client = httpx.Client(headers=headers, timeout=REQUEST_TIMEOUT_S)
    try:
        while time.monotonic() < until:
            with recorder.lock:
                open_ids = [i for i, r in recorder.jobs.items() if r.final is None]
            if not open_ids:
                return
            for job_id in open_ids:
                try:
                    response = client.get(f"{server.base}/api/jobs/{job_id}")
                except httpx.HTTPError:
                    continue
                if response.status_code == 200:
                    recorder.job_seen(job_id, response.json())
            time.sleep(1.0)
    finally:
        client.close()


class _Rereading:
    """GETs of a client, each asked once more on a new connection when the one it went out on was
    closed under it (reset, or no answer): what HTTP/1.1 clients may do for idempotent requests
    (RFC 9112, section 9.3.1). A server that is down still fails the second try."""

    def __init__(self, client: httpx.Client) -> None:
        self.client, self.reasked = client, []

    def get(self, url: str) -> httpx.Response:
        try:
            return self.client.get(url)
        except httpx.TransportError as exc:
            self.reasked.append(f"GET {url}: {type(exc).__name__}: {exc}")
            time.sleep(0.5)
            return self.client.get(url)


def _check_library(server: Server, recorder: Recorder, headers: dict) -> dict:
    """Every exemplar and result the API lists has its files; the jobs the server lists agree
    with what the users saw; no result without the job that made it."""
    problems: list[str] = []
    with httpx.Client(base_url=server.base, headers=headers, timeout=REQUEST_TIMEOUT_S) as plain:
        client = _Rereading(plain)
        exemplars = client.get("/api/exemplars").json()
        for exemplar in exemplars:
            for url in (exemplar["photo_url"], exemplar["thumbnail_url"]):
                response = client.get(url)
                if response.status_code != 200 or not response.content:
                    problems.append(f"exemplar {exemplar['id']}: {url} answered {response.status_code}")
        results = client.get("/api/results").json()
        files = 0
        for summary in results:
            detail = client.get(f"/api/results/{summary['id']}")
            if detail.status_code != 200:
                problems.append(f"result {summary['id']} answered {detail.status_code}")
                continue
            for url in detail.json()["files"].values():
                files += 1
                response = client.get(url)
                if response.status_code != 200 or not response.content:
                    problems.append(f"result {summary['id']}: {url} answered {response.status_code}")
        served = {j["id"]: j for j in client.get("/api/jobs").json()}
        reasked = client.reasked
    done: dict[int, list[tuple[str, dict]]] = defaultdict(list)  # result id -> the jobs that made it
    lost = []
    for job_id, record in recorder.jobs.items():
        now = served.get(job_id)  # (None: finished long ago, beyond the jobs the server keeps)
        if record.final is None or (now is not None and now["state"] not in ("done", "failed", "cancelled")):
            lost.append(job_id)
            continue
        if record.final["state"] == "done":
            if now is not None and (now["state"] != "done" or now["result_id"] != record.final["result_id"]):
                problems.append(f"job {job_id} was done with result {record.final['result_id']}, now {now}")
            done[record.final["result_id"]].append((job_id, record.final))
    # ids of deleted results come again (SQLite's rowid): a job made a listed result when its id,
    # photo and parameters are the result's
    made_by = {r["id"]: [i for i, f in done.get(r["id"], []) if _same_run(f, r)] for r in results}
    doubled = [rid for rid, ids in made_by.items() if len(ids) > 1]
    orphans = [rid for rid, ids in made_by.items() if not ids]
    return {
        "asked_again": reasked,
        "exemplars": len(exemplars),
        "results": len(results),
        "files_checked": files,
        "problems": problems,
        "lost": lost,
        "results_of_two_jobs": doubled,
        "results_of_no_job": orphans,
        "jobs_no_longer_kept": sum(1 for job_id in recorder.jobs if job_id not in served),
    }


def _same_run(job: dict, result: dict) -> bool:
    keys = ("seed", "size", "set_name", "resumed_from")
    return job["exemplar_id"] == result["exemplar_id"] and all(
        job["params"].get(k) == result["params"].get(k) for k in keys
    )


def _integrity(library: Path) -> str:
    with sqlite3.connect(library / "library.sqlite") as conn:
        return "; ".join(row[0] for row in conn.execute("PRAGMA integrity_check"))


def _percentiles(values: list[float]) -> dict:
    if not values:
        return {"n": 0}
    ordered = sorted(values)

    def at(q: float) -> float:
        return round(1000 * ordered[min(len(ordered) - 1, int(q * len(ordered)))], 1)

    return {"n": len(values), "p50_ms": at(0.50), "p95_ms": at(0.95), "p99_ms": at(0.99), "max_ms": at(1.0)}


def _summary(recorder: Recorder, users: int) -> dict:
    """The figures of the jobs and the users (fairness)."""
    jobs = list(recorder.jobs.values())
    finals = [r.final or {} for r in jobs]
    per_user = []
    for number in range(users):
        mine = [r.final for r in jobs if r.user == number and r.final is not None]
        waits = [f["started"] - f["created"] for f in mine if f.get("started")]
        per_user.append(
            {
                "user": number,
                "submitted": sum(r.user == number for r in jobs),
                "done": sum(f["state"] == "done" for f in mine),
                "longest_wait_s": round(max(waits, default=0.0), 1),
            }
        )
    failed = [f for f in finals if f.get("state") == "failed"]
    return {
        "submitted": len(jobs),
        "paint": sum(r.kind == "paint" for r in jobs),
        "done": sum(f.get("state") == "done" for f in finals),
        "failed_interrupted": sum((f.get("error") or "").startswith(INTERRUPTED) for f in failed),
        "failed_other": [f.get("error") for f in failed if not (f.get("error") or "").startswith(INTERRUPTED)],
        "cancelled": sum(f.get("state") == "cancelled" for f in finals),
        "retried": recorder.counts["retried"],
        "seen_done_then_not": recorder.counts["run twice"],
        "uploads_refused_yet_kept": recorder.counts["upload refused, yet kept"],
        "unanswered_submits_queued": recorder.counts["unanswered, queued"],
        "unanswered_submits_not_queued": recorder.counts["unanswered, not queued"],
        "per_user": per_user,
    }


def run(
    users: int = 20,
    seconds: float = 600,
    kill: bool = True,
    drain_s: float = 240,
    parent: Path | None = None,
    log=print,
) -> dict:
    """The load: start the server, the users, the kill and restart halfway; stop, drain, check."""
    from PIL import Image

    from barkgen.data import sample_exemplar_path

    photo = Image.open(sample_exemplar_path()).convert("RGB")
    token = secrets.token_urlsafe(24)
    headers = {"X-Barkgen-Token": token}
    hard_deadline = time.monotonic() + seconds + drain_s + 300  # + two starts and the checks
    with tempfile.TemporaryDirectory(prefix="barkgen-load-", dir=parent) as folder:
        server = Server(Path(folder), token)
        done = threading.Event()

        def watchdog() -> None:  # the hard deadline: every child killed, this process ended
            while not done.wait(0.5):
                server.sample_memory()
                if time.monotonic() > hard_deadline:
                    print("bench_load: hard deadline passed; killing the server", file=sys.stderr)
                    server.kill()
                    os._exit(3)

        recorder = Recorder()
        stop = threading.Event()
        threading.Thread(target=watchdog, name="watchdog", daemon=True).start()
        try:
            start_s = server.start()
            log(f"server up in {start_s:.1f} s at {server.base}; {users} users for {seconds:.0f} s")
            crowd = [User(i, server, recorder, stop, photo) for i in range(users)]
            began = time.monotonic()
            for user in crowd:
                user.start()
                time.sleep(0.1)
            restart = None
            if kill:
                stop.wait(max(0.0, seconds / 2 - (time.monotonic() - began)))
                restart = _kill_in_the_middle(server, recorder, headers)
                log(f"killed and restarted: {restart}")
            stop.wait(max(0.0, seconds - (time.monotonic() - began)))
            stop.set()
            for user in crowd:
                user.join(timeout=REQUEST_TIMEOUT_S * 3)
            load_s = time.monotonic() - began
            _drain(server, recorder, headers, drain_s)
            library = _check_library(server, recorder, headers)
            server.stop()
            library["integrity_check"] = _integrity(server.library)
        except Exception:
            server.print_log_tail()  # (the folder goes with this block)
            raise
        finally:
            done.set()
            server.kill()
    statuses: dict[str, dict[str, int]] = defaultdict(dict)
    for (kind, status), count in sorted(recorder.status.items()):
        statuses[kind][str(status)] = count
    return {
        "users": users,
        "seconds": round(load_s, 1),
        "kill": restart,
        "statuses": statuses,
        "server_errors": sum(c for (_, s), c in recorder.status.items() if s >= 500),
        "refused_busy": sum(c for (_, s), c in recorder.status.items() if s == 429),
        "no_answer_while_down": recorder.down_errors,
        "odd": recorder.odd[:50],
        "odd_count": len(recorder.odd),
        "latency": {kind: _percentiles(values) for kind, values in sorted(recorder.times.items())},
        "jobs": _summary(recorder, users),
        "library": library,
        "memory_peak_mb": {k: round(v, 1) for k, v in server.peak.items()},
    }


def clean(report: dict) -> list[str]:
    """What is wrong with a run (empty: clean)."""
    wrong = []
    if report["server_errors"]:
        wrong.append(f"{report['server_errors']} responses 5xx")
    if report["odd_count"]:
        wrong.append(f"{report['odd_count']} unexpected answers: {report['odd'][:3]}")
    library, jobs = report["library"], report["jobs"]
    for key in ("lost", "results_of_two_jobs", "results_of_no_job", "problems"):
        if library[key]:
            wrong.append(f"{key}: {library[key][:5]}")
    if jobs["seen_done_then_not"]:
        wrong.append(f"{jobs['seen_done_then_not']} jobs seen done then not")
    if jobs["failed_other"]:
        wrong.append(f"failed jobs: {jobs['failed_other'][:3]}")
    if library["integrity_check"] != "ok":
        wrong.append(f"integrity_check: {library['integrity_check']}")
    starved = [u["user"] for u in jobs["per_user"] if u["submitted"] and not u["done"]]
    if starved:
        wrong.append(f"users with no job done: {starved}")
    return wrong


def table(report: dict) -> str:
    jobs, library, memory = report["jobs"], report["library"], report["memory_peak_mb"]
    per_user = jobs["per_user"]
    done = [u["done"] for u in per_user]
    lines = [
        f"users {report['users']}, load {report['seconds']:.0f} s, kill -9 and restart: {report['kill']}",
        f"{'route kind':<10} {'n':>6} {'p50 ms':>8} {'p95 ms':>8} {'p99 ms':>8} {'max ms':>8}  statuses",
    ]
    for kind, figures in report["latency"].items():
        codes = " ".join(f"{s}:{c}" for s, c in report["statuses"][kind].items())
        lines.append(
            f"{kind:<10} {figures['n']:>6} {figures['p50_ms']:>8} {figures['p95_ms']:>8} "
            f"{figures['p99_ms']:>8} {figures['max_ms']:>8}  {codes}"
        )
    rows = [
        ("responses 5xx", report["server_errors"]),
        ("refused busy (429, queue full)", report["refused_busy"]),
        ("no answer while down", report["no_answer_while_down"]),
        ("unexpected answers", report["odd_count"]),
        ("jobs submitted (of them painted)", f"{jobs['submitted']} ({jobs['paint']})"),
        ("done / cancelled", f"{jobs['done']} / {jobs['cancelled']}"),
        ("failed: interrupted (retried)", f"{jobs['failed_interrupted']} ({jobs['retried']})"),
        ("failed: other", len(jobs["failed_other"])),
        ("uploads refused busy (429) yet kept", jobs["uploads_refused_yet_kept"]),
        (
            "submits unanswered: queued / not",
            f"{jobs['unanswered_submits_queued']} / {jobs['unanswered_submits_not_queued']}",
        ),
        (
            "lost / run twice",
            f"{len(library['lost'])} / {len(library['results_of_two_jobs']) + jobs['seen_done_then_not']}",
        ),
        ("results of no job", len(library["results_of_no_job"])),
        ("jobs done per user (min-max)", f"{min(done, default=0)}-{max(done, default=0)}"),
        ("longest wait of a job (s)", max((u["longest_wait_s"] for u in per_user), default=0)),
        (
            "peak RSS server / worker / all (MB)",
            f"{memory['server_mb']} / {memory['worker_mb']} / {memory['total_mb']}",
        ),
        (
            "library: exemplars, results, files",
            f"{library['exemplars']}, {library['results']}, {library['files_checked']}",
        ),
        ("library problems / integrity_check", f"{len(library['problems'])} / {library['integrity_check']}"),
        ("check's GETs asked again", f"{len(library['asked_again'])} {library['asked_again'][:2]}"),
    ]
    lines += [f"{name:<38} {value}" for name, value in rows]
    wrong = clean(report)
    lines.append("CLEAN" if not wrong else "NOT CLEAN: " + "; ".join(wrong))
    return "\n".join(lines)


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--users", type=int, default=20)
    parser.add_argument("--seconds", type=float, default=600)
    parser.add_argument("--no-kill", action="store_true", help="no kill -9 and restart in the middle")
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--folder", type=Path, help="make the temporary folder in this one")
    parser.add_argument("--drain", type=float, default=240, help="most seconds to wait for the queue after the load")
    args = parser.parse_args()
    if not 1 <= args.users <= 100 or not 10 <= args.seconds <= 3600 or not 0 <= args.drain <= 3600:
        parser.error("--users must be 1-100, --seconds 10-3600 and --drain 0-3600")
    signal.signal(signal.SIGTERM, _interrupt)  # as Ctrl-C: the finally blocks kill the server
    signal.signal(signal.SIGINT, _interrupt)  # (also when started in the background)
    try:
        report = run(args.users, args.seconds, kill=not args.no_kill, drain_s=args.drain, parent=args.folder)
    except KeyboardInterrupt:
        sys.exit("bench_load: interrupted; the server and its worker are stopped")
    print(table(report))
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    sys.exit(0 if not clean(report) else 1)


if __name__ == "__main__":
    main()
