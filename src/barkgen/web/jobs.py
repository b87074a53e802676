"""The web app's job queue: generate requests run one at a time (both cores go to the solver),
in order, in a worker process (:mod:`.worker`); each finished job becomes a library result.
A photo's label map (the page shows it before any result exists) is a job too, of kind
``labels``: it goes ahead of the waiting generate jobs and its PNG goes into the library's
analyses. No request computes anything heavy itself.

A job is ``queued`` (with its position), ``running`` (with its progress), then ``done`` (with
its result id), ``failed`` (with a one-line error) or ``cancelled``. The queue is kept in the
library database (table ``jobs``) on every change of state, so a page reload or a restarted
server finds its job again: jobs that were waiting wait again, in order, and a job that was
running when the server stopped (Ctrl-C, a crash, a kill) is ``failed`` with the error
:data:`INTERRUPTED`, unless its result reached the library before the stop (then it is ``done``
with it: started again, it would be made twice). Results live in the library too. Cancelling a
running job ends the worker process at once; the next job starts a new one.
"""

from __future__ import annotations

import base64
import io
import itertools
import logging
import multiprocessing
import secrets
import sqlite3
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from datetime import UTC, datetime
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import cast

import numpy as np

from barkgen.errors import BarkgenError
from barkgen.library import Library, LibraryError, NotFoundError
from barkgen.web.worker import Done, Failed, JobSpec, LabelSpec, Progress, worker_main

STATES = ("queued", "running", "done", "failed", "cancelled")
FINISHED = ("done", "failed", "cancelled")
#: finished jobs kept in memory (their results stay in the library)
JOBS_KEPT = 500
#: most jobs waiting at once (more are refused: the queue holds requests, not photos)
MAX_QUEUED = 20
#: the error of a job that was running when its server stopped
INTERRUPTED = "interrupted: the server stopped while this job ran; start it again"

_log = logging.getLogger("barkgen.web")


class QueueFullError(BarkgenError):
    """The job queue is full."""


@dataclass
class Job:
    """One generate request and where it stands."""

    id: str
    exemplar_id: int
    params: dict
    spec: dict | None  # the JobSpec fields but the photo and job id (read when the job starts)
    parent_id: int | None = None
    labels_key: dict | None = None  # cache the result's labels_in.png under this analysis key
    kind: str = "generate"  # or "labels": the photo's label map of params["k"] labels
    state: str = "queued"
    progress: float = 0.0
    stage: str | None = None  # what the running job is doing (barkgen.pipeline.stage_at)
    result_id: int | None = None
    error: str | None = None
    created: float = field(default_factory=time.time)
    started: float | None = None
    finished: float | None = None
    order: int = 0
    version: int = 0  # bumped on every change (event streams watch it)


def spec_to_json(spec: dict | None) -> dict | None:
    """A job's spec fields as JSON values (the photo's label map and a painted level as
    base64), to keep in the library."""
    if spec is None:
        return None
    out = dict(spec)
    if "options" in out:
        out["options"] = {**out["options"], "size": list(out["options"]["size"])}
    if out.get("labels_in") is not None:
        out["labels_in"] = base64.b64encode(out["labels_in"]).decode("ascii")
    if out.get("resume") is not None:
        level, labels = out["resume"]
        buffer = io.BytesIO()
        np.save(buffer, labels, allow_pickle=False)
        out["resume"] = [int(level), base64.b64encode(buffer.getvalue()).decode("ascii")]
    return out


def spec_from_json(data: dict | None) -> dict | None:
    """The inverse of :func:`spec_to_json`."""
    if data is None:
        return None
    spec = dict(data)
    if "options" in spec:
        spec["options"] = {**spec["options"], "size": tuple(spec["options"]["size"])}
    if spec.get("labels_in") is not None:
        spec["labels_in"] = base64.b64decode(spec["labels_in"])
    if spec.get("resume") is not None:
        level, encoded = spec["resume"]
        spec["resume"] = (int(level), np.load(io.BytesIO(base64.b64decode(encoded)), allow_pickle=False))
    return spec


class JobManager:
    """A queue of jobs served by one worker process at a time (``start()`` / ``stop()``)."""

    def __init__(self, library: Library) -> None:
        self.library = library
        #: ``barkgen serve``'s way (:func:`barkgen.web.serve` sets it): the worker started with
        #: the queue, and label jobs that carry the page's default analysis run it next
        #: (:attr:`~barkgen.web.worker.LabelSpec.prefetch`)
        self.eager = False
        self._jobs: dict[str, Job] = {}
        self._queue: deque[str] = deque()
        self._lock = threading.Condition()
        self._counter = itertools.count(1)
        self._cancel: set[str] = set()
        self._stopping = False
        self._thread: threading.Thread | None = None
        self._process: BaseProcess | None = None
        self._conn: Connection | None = None
        with self._lock:
            self._restore()

    # -- public ---------------------------------------------------------------------------
    def start(self) -> None:
        if self._thread is None:
            self._stopping = False
            self._thread = threading.Thread(target=self._run, name="barkgen-jobs", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        with self._lock:
            self._stopping = True
            self._lock.notify_all()
        if self._thread is not None:
            self._thread.join(timeout=10)
            self._thread = None
        self._end_worker()

    @property
    def stopping(self) -> bool:
        return self._stopping

    def submit(
        self, exemplar_id: int, params: dict, spec: dict, parent_id: int | None = None, labels_key: dict | None = None
    ) -> Job:
        """Queue a job; ``spec``: the :class:`JobSpec` fields but ``job_id``, ``photo`` and
        ``photo_hash`` (the photo is read from the library when the job starts). Raises
        :class:`QueueFullError` when :data:`MAX_QUEUED` jobs are waiting. ``labels_key``: the
        analysis key under which the result's input label map is kept for the next jobs."""
        job_id = secrets.token_hex(8)
        job = Job(
            id=job_id,
            exemplar_id=exemplar_id,
            params=params,
            spec=spec,
            parent_id=parent_id,
            labels_key=labels_key,
            order=next(self._counter),
        )
        with self._lock:
            self._check_room()
            self._jobs[job_id] = job
            self._queue.append(job_id)
            self._save(job)
            self._forget_old()
            self._lock.notify_all()
        return job

    def submit_labels(
        self, exemplar_id: int, k: int, labels_key: dict, method: str = "color", prefetch: dict | None = None
    ) -> Job:
        """Queue the making of a photo's label map of ``k`` labels, ahead of the waiting
        generate jobs (it takes seconds); the PNG is stored as the library analysis
        ``labels_in`` under ``labels_key``. A label job of the same photo and ``k`` that is
        queued or running is returned instead of a second one. ``prefetch``: the
        :class:`~barkgen.pipeline.GenerateOptions` keywords of the analysis the worker makes
        next from this label map (with :attr:`eager`)."""
        with self._lock:
            for job in self._jobs.values():
                if (
                    job.kind == "labels"
                    and job.exemplar_id == exemplar_id
                    and job.params["k"] == k
                    and job.params.get("method", "color") == method
                    and job.state not in FINISHED
                ):
                    return job
            self._check_room()
            job = Job(
                id=secrets.token_hex(8),
                exemplar_id=exemplar_id,
                params={"k": k, "method": method},
                spec={"options": prefetch} if prefetch is not None else {},
                labels_key=labels_key,
                kind="labels",
                order=next(self._counter),
            )
            self._jobs[job.id] = job
            ahead = sum(1 for queued in self._queue if self._jobs[queued].kind == "labels")
            self._queue.insert(ahead, job.id)
            self._save(job)
            self._forget_old()
            self._lock.notify_all()
            return job

    def get(self, job_id: str) -> Job | None:
        with self._lock:
            return self._jobs.get(job_id)

    def snapshot(self, job_id: str) -> dict | None:
        """The job as the API shows it (or None)."""
        with self._lock:
            job = self._jobs.get(job_id)
            return None if job is None else self._describe(job)

    def list(self) -> list[dict]:
        """Queued and running jobs first (in queue order), then finished ones, newest first."""
        with self._lock:
            place = {job_id: i for i, job_id in enumerate(self._queue)}
            jobs = sorted(
                self._jobs.values(),
                key=lambda j: (j.state in FINISHED, place.get(j.id, -1) if j.state not in FINISHED else -j.order),
            )
            return [self._describe(j) for j in jobs]

    def cancel(self, job_id: str) -> dict | None:
        """Cancel a queued or running job (a finished one stays as it is)."""
        with self._lock:
            job = self._jobs.get(job_id)
            if job is None:
                return None
            if job.state == "queued":
                self._queue.remove(job_id)
                self._set(job, state="cancelled", spec=None, finished=time.time())
            elif job.state == "running":
                self._cancel.add(job_id)
                self._lock.notify_all()
            return self._describe(job)

    def cancel_exemplar(self, exemplar_id: int) -> None:
        """Cancel every queued or running job of an exemplar (it is being removed)."""
        with self._lock:
            ids = [j.id for j in self._jobs.values() if j.exemplar_id == exemplar_id and j.state not in FINISHED]
        for job_id in ids:
            self.cancel(job_id)

    # -- internals (call with the lock held) ------------------------------------------------
    def _check_room(self) -> None:
        if len(self._queue) >= MAX_QUEUED:
            raise QueueFullError(f"the queue is full ({MAX_QUEUED} jobs waiting); try again when some are done")

    def _describe(self, job: Job) -> dict:
        position = self._queue.index(job.id) + (1 if self._running() else 0) if job.state == "queued" else 0
        return {
            "id": job.id,
            "kind": job.kind,
            "number": job.order,
            "state": job.state,
            "progress": round(job.progress, 4),
            "stage": job.stage if job.state == "running" else None,
            "queue_position": position,
            "result_id": job.result_id,
            "error": job.error,
            "exemplar_id": job.exemplar_id,
            "params": job.params,
            "version": job.version,
            "created": job.created,
            "started": job.started,
            "finished": job.finished,
        }

    def _running(self) -> bool:
        return any(j.state == "running" for j in self._jobs.values())

    def _set(self, job: Job, **changes) -> None:
        for key, value in changes.items():
            setattr(job, key, value)
        job.version += 1
        if "state" in changes:
            self._save(job)
        # a move in the queue changes the others' positions: wake every watcher
        for other in self._jobs.values():
            if other is not job and other.state == "queued" and "state" in changes:
                other.version += 1
        self._lock.notify_all()

    def _forget_old(self) -> None:
        finished = [j for j in self._jobs.values() if j.state in FINISHED]
        old = sorted(finished, key=lambda j: j.order)[: max(0, len(finished) - JOBS_KEPT)]
        for job in old:
            del self._jobs[job.id]
        if old:
            self._keep(self.library.jobs.forget, [job.id for job in old])

    def _save(self, job: Job) -> None:
        """Keep the job's state in the library (its spec only while it may still run)."""
        self._keep(
            self.library.jobs.save,
            {
                "id": job.id,
                "number": job.order,
                "kind": job.kind,
                "exemplar_id": job.exemplar_id,
                "params": job.params,
                "state": job.state,
                "spec": spec_to_json(job.spec) if job.state not in FINISHED else None,
                "parent_id": job.parent_id,
                "labels_key": job.labels_key,
                "result_id": job.result_id,
                "error": job.error,
                "created": job.created,
                "started": job.started,
                "finished": job.finished,
            },
        )

    @staticmethod
    def _keep(write, argument) -> None:
        try:
            write(argument)
        except (LibraryError, sqlite3.Error, OSError) as exc:  # a read-only or full disk:
            _log.warning("the job queue is not kept in the library (%s)", exc)  # it runs on

    def _restore(self) -> None:
        """The queue kept in the library: waiting jobs wait again (label jobs first, as they
        were queued), a job that was running is failed with :data:`INTERRUPTED`."""
        try:
            records = self.library.jobs.saved()
        except (LibraryError, sqlite3.Error) as exc:
            _log.warning("the kept job queue cannot be read (%s)", exc)
            return
        for record in records:
            job = Job(
                id=record["id"],
                exemplar_id=record["exemplar_id"],
                params=record["params"],
                spec=spec_from_json(record["spec"]),
                parent_id=record["parent_id"],
                labels_key=record["labels_key"],
                kind=record["kind"],
                state=record["state"],
                result_id=record["result_id"],
                error=record["error"],
                created=record["created"],
                started=record["started"],
                finished=record["finished"],
                order=record["number"],
            )
            self._jobs[job.id] = job
        for job in [j for j in self._jobs.values() if j.state == "running"]:
            made = self._stored_result(job)
            if made is not None:  # stored, then the server stopped before the job said so
                self._set(job, state="done", progress=1.0, result_id=made, spec=None, finished=time.time())
            else:
                self._set(job, state="failed", error=INTERRUPTED, spec=None, finished=time.time())
        waiting = [j for j in self._jobs.values() if j.state == "queued"]
        self._queue.extend(j.id for j in sorted(waiting, key=lambda j: (j.kind != "labels", j.order)))
        self._counter = itertools.count(max((j.order for j in self._jobs.values()), default=0) + 1)

    def _stored_result(self, job: Job) -> int | None:
        """The result a job that was running when its server stopped had stored already (the
        stop fell between the library's write and the job's ``done``), else None: a result of
        its photo with its parameters, recorded since the job started and claimed by no other
        job (one job runs at a time, so nothing else made it)."""
        if job.kind != "generate" or job.started is None:
            return None
        claimed = {j.result_id for j in self._jobs.values() if j.result_id is not None}
        since = datetime.fromtimestamp(int(job.started), UTC)  # results are recorded to the second
        try:
            results = self.library.results(job.exemplar_id)
        except (LibraryError, sqlite3.Error):
            return None
        for result in results:
            if (
                result.id not in claimed
                and result.params == job.params
                and datetime.fromisoformat(result.created) >= since
            ):
                return result.id
        return None

    # -- the dispatcher thread --------------------------------------------------------------
    def _run(self) -> None:
        if self.eager:  # its start (a process, its imports) before the first job, not in it
            try:
                self._ensure_worker(load_ahead=True)
            except OSError as exc:
                _log.warning("the worker process did not start ahead (%s)", exc)
        while True:
            with self._lock:
                while not self._queue and not self._stopping:
                    self._lock.wait()
                if self._stopping:
                    return
                job = self._jobs[self._queue.popleft()]
                self._set(job, state="running", progress=0.0, started=time.time())
                fields = job.spec
            try:
                exemplar = self.library.exemplar(job.exemplar_id)
                photo = self.library.photo_bytes(exemplar.id)
                spec: JobSpec | LabelSpec
                if job.kind == "labels":
                    spec = LabelSpec(
                        job_id=job.id,
                        photo=photo,
                        k=job.params["k"],
                        method=job.params.get("method", "color"),
                        prefetch=(fields or {}).get("options") if self.eager and not exemplar.maps else None,
                        photo_hash=exemplar.image_hash,
                    )
                else:  # (a job without its fields: the TypeError below)
                    set_files = self.library.set_files(exemplar.id) if exemplar.maps else None
                    spec = JobSpec(
                        job_id=job.id,
                        photo=photo,
                        photo_hash=exemplar.image_hash,
                        set_files=set_files,
                        **cast(dict, fields),
                    )
            except (NotFoundError, OSError) as exc:
                self._finish(job, state="failed", error=f"the photo is gone ({exc})")
                continue
            except (TypeError, KeyError, ValueError) as exc:  # a kept job of another version
                self._finish(job, state="failed", error=f"the job cannot be run ({exc})")
                continue
            try:
                self._execute(job, spec)
            except Exception as exc:  # noqa: BLE001 - a bug must not stop the queue
                self._end_worker()
                self._finish(job, state="failed", error=f"internal error ({type(exc).__name__}: {exc})")

    def _ensure_worker(self, load_ahead: bool = False) -> None:
        if self._process is not None and self._process.is_alive():
            return
        self._end_worker()  # a worker that died between jobs: reap it, close its pipe
        context = multiprocessing.get_context("spawn")
        parent, child = context.Pipe()
        self._process = context.Process(
            target=worker_main, args=(child, load_ahead), daemon=True, name="barkgen-worker"
        )
        self._process.start()
        child.close()
        self._conn = parent

    def _end_worker(self) -> None:
        if self._process is not None:
            self._process.kill()
            self._process.join(timeout=10)
        if self._conn is not None:
            self._conn.close()
        self._process = self._conn = None

    def _finish(self, job: Job, **changes) -> None:
        with self._lock:
            self._cancel.discard(job.id)
            self._set(job, spec=None, finished=time.time(), **changes)

    def _execute(self, job: Job, spec: JobSpec | LabelSpec) -> None:
        try:
            self._ensure_worker()
            assert self._conn is not None  # _ensure_worker made the pipe
            self._conn.send(spec)
        except (OSError, EOFError) as exc:
            self._end_worker()
            self._finish(job, state="failed", error=f"could not start the worker process ({exc})")
            return
        while True:
            with self._lock:
                cancelled = job.id in self._cancel or self._stopping
            if cancelled:
                self._end_worker()
                if self._stopping and job.id not in self._cancel:
                    self._finish(job, state="failed", error=INTERRUPTED)
                else:
                    self._finish(job, state="cancelled")
                return
            assert self._conn is not None  # until _end_worker, which returns
            try:
                ready = self._conn.poll(0.1)
                message = self._conn.recv() if ready else None
            except (EOFError, OSError):
                if self._process is not None:
                    self._process.join(timeout=5)
                code = self._process.exitcode if self._process is not None else None
                self._end_worker()
                self._finish(job, state="failed", error=f"the worker process ended (exit code {code}; out of memory?)")
                return
            if message is None:
                continue
            if isinstance(message, Progress):
                with self._lock:
                    self._set(job, progress=float(message.fraction), stage=message.stage)
            elif isinstance(message, Failed):
                self._finish(job, state="failed", error=message.error)
                return
            elif isinstance(message, Done) and job.kind == "labels":
                try:
                    self.library.put_analysis(
                        job.exemplar_id, "labels_in", cast(dict, job.labels_key), message.files["labels_in.png"]
                    )
                except Exception as exc:  # the exemplar was removed, disk full, ...
                    self._finish(job, state="failed", error=f"could not store the label map ({exc})")
                    return
                self._finish(job, state="done", progress=1.0)
                return
            elif isinstance(message, Done):
                files, report = message.files, message.report
                try:
                    result = self.library.add_result(
                        job.exemplar_id,
                        job.params,
                        job.params["seed"],
                        files,
                        report.get("timings_s", {}),
                        parent_id=job.parent_id,
                    )
                except Exception as exc:  # the exemplar was removed, disk full, ...
                    self._finish(job, state="failed", error=f"could not store the result ({exc})")
                    return
                if job.labels_key is not None and "labels_in.png" in files:
                    try:  # the next jobs of this photo and k skip its label map
                        self.library.put_analysis(job.exemplar_id, "labels_in", job.labels_key, files["labels_in.png"])
                    except Exception:  # noqa: BLE001 - only a cache
                        pass
                self._finish(job, state="done", progress=1.0, result_id=result.id)
                return
