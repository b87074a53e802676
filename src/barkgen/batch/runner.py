"""Running a batch on Dask's distributed scheduler (an embedded LocalCluster by default, any
Dask cluster when given its address).

Task graph per exemplar: one task holds the photo (the array travels in the graph, so the
scheduler can make it again when the worker keeping it dies: scattered data has no recipe, and
Dask keeps one copy of it); one task analyses it
(:func:`barkgen.pipeline.analyze_photo`: label map, k-coherence sets, material source), once;
one task per seed synthesizes a variant from that shared analysis and returns its encoded files
(:func:`barkgen.pipeline.encode_generate`). The client writes each variant's folder atomically
(:func:`barkgen.io.write_folder_atomic`) and records it in the manifest, so workers need no
access to the output folder and a worker killed mid-task leaves nothing behind: Dask reruns its
task elsewhere.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import re
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from barkgen.batch.manifest import MANIFEST_NAME, Manifest
from barkgen.batch.spec import BatchSpec, ExemplarJob
from barkgen.errors import InvalidInputError


@dataclass
class VariantOutput:
    """What a variant task sends back: its files, the seconds it computed, where, and what
    the shared analysis it used had cost."""

    files: dict[str, bytes]
    seconds: float
    worker: str
    analysis_seconds: float


@dataclass
class BatchReport:
    """The outcome of :func:`run_batch`: variants in the spec, already done before (skipped),
    made now, failed now (``(exemplar, seed, error)``); wall-clock seconds; seconds computed
    inside variant tasks and inside analysis tasks; the workers and the dashboard address."""

    total: int
    skipped: int = 0
    made: int = 0
    failed: list[tuple[str, int, str]] = field(default_factory=list)
    seconds: float = 0.0
    variant_seconds: list[float] = field(default_factory=list)
    analysis_seconds: dict[str, float] = field(default_factory=dict)
    workers: int = 0
    dashboard: str | None = None


def _photo_task(photo):
    """Worker side: the photo, kept as a task's result so that a lost copy can be made again."""
    return photo


def _analyse_task(photo, labels, options, scan=None, cache=True):
    """Worker side: the photo's analysis (:func:`barkgen.pipeline.analyze_photo`; a scanned
    set's own maps make its material set), from the worker machine's analysis cache when it
    holds it, else made and kept there (:func:`barkgen.pipeline.cached_analysis`; ``cache``
    false: neither)."""
    from barkgen.pipeline import cached_analysis, open_store

    return cached_analysis(photo, options, labels_in=labels, scan=scan, store=open_store(cache))


def _variant_task(photo, analysis, options, source: str, job: ExemplarJob):
    """Worker side: one variant from the shared analysis, encoded exactly as
    ``barkgen generate`` encodes it (the job's material name, bits, preset and sizes)."""
    from barkgen.pipeline import encode_generate, generate

    t0 = time.perf_counter()
    result = generate(photo, options, analysis=analysis)
    asset, variant = job.set_base_name(options.seed)
    files = encode_generate(
        photo,
        result,
        source,
        name=asset,
        variant=variant,
        licence=job.licence,
        bits=job.bits,
        preset=job.preset,
        sizes=job.sizes,
    )
    try:
        from distributed import get_worker

        worker = get_worker().address
    except ValueError:
        worker = "local"
    return VariantOutput(
        files=files, seconds=time.perf_counter() - t0, worker=worker, analysis_seconds=analysis.seconds
    )


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return f"{type(exc).__name__}: {text}"[:500]


def local_cluster(workers: int | None = None, threads: int | None = None):
    """A Dask LocalCluster for batches: ``workers`` processes (default: one per core), one task
    at a time each, with numba/OpenMP pools of ``threads`` threads (default: cores / workers),
    a dashboard on a free port, and barkgen imported as each worker starts
    (:mod:`barkgen.batch.preload`)."""
    import dask
    from distributed import LocalCluster

    workers = workers or os.cpu_count() or 1
    threads = threads or max(1, (os.cpu_count() or 1) // workers)
    environ = {
        "NUMBA_NUM_THREADS": threads,
        "OMP_NUM_THREADS": threads,
        "BARKGEN_LOCAL_WORKER": 1,
    }  # its Ctrl-C is ours (barkgen.batch.preload)
    # set in each worker process as it starts, before barkgen (and numba) is imported there;
    # not "pre-spawn-environ", which writes them into this process's own environment for good
    # (a later numba compile here then fails: its pool was launched with another size)
    with dask.config.set({f"distributed.nanny.environ.{k}": v for k, v in environ.items()}):
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.CRITICAL,
            preload=["barkgen.batch.preload"],
        )


#: a scheduler address: PROTOCOL://HOST:PORT
_ADDRESS = re.compile(r"^(tcp|tls)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]{1,253}):(\d{1,5})$")


def check_scheduler_address(address: str) -> str:
    """A Dask scheduler's address as ``tcp://HOST:PORT`` (or ``tls://``), checked before any
    work: a port from 1 to 65535, a host that is an IP address or a host name. A malformed one
    (``tcp://256.1.1.1:99999``, ``not-a-url``, ``http://...``) is refused at once instead of
    after a 20 s connection timeout. Raises :class:`InvalidInputError`."""
    import ipaddress

    m = _ADDRESS.match(address) if isinstance(address, str) else None
    shown = repr(address)[:60]
    if not m:
        raise InvalidInputError(
            f"--scheduler {shown}: give the scheduler's address as tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786)"
        )
    host, port = m.group(2).strip("[]"), int(m.group(3))
    if not 1 <= port <= 65535:
        raise InvalidInputError(f"--scheduler {shown}: port {port} is not 1-65535")
    if re.fullmatch(r"[0-9.]+", host) or ":" in host:
        try:
            ipaddress.ip_address(host)
        except ValueError:
            raise InvalidInputError(f"--scheduler {shown}: {host!r} is not an IP address") from None
    return address


def _knock(address: str) -> None:
    """One TCP connection to a scheduler's (checked) address, so that nothing listening there is
    said at once (the Dask client retries a refused connection until its 20 s timeout).
    Raises OSError."""
    import socket

    m = _ADDRESS.match(address)
    assert m is not None  # (checked by check_scheduler_address)
    with socket.create_connection((m.group(2).strip("[]"), int(m.group(3))), timeout=20):
        pass


def _client(scheduler: str | None, workers: int | None, threads: int | None):
    """A Dask client of ``scheduler``, or of a new :func:`local_cluster` (returned too, to close)."""
    from distributed import Client

    if scheduler is not None:
        try:
            _knock(scheduler)
            return Client(scheduler, timeout="20s"), None
        except (OSError, TimeoutError) as exc:
            raise InvalidInputError(f"cannot reach the Dask scheduler at {scheduler}: {_one_line(exc)}") from None
    cluster = local_cluster(workers, threads)
    return Client(cluster), cluster


def run_batch(
    spec: BatchSpec,
    output_dir: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    threads: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    log: Callable[[str], None] | None = None,
    client=None,
    cache: bool = True,
) -> BatchReport:
    """Make every variant of ``spec`` that ``output_dir`` does not hold yet.

    Args:
        spec: a validated :class:`BatchSpec` (:func:`barkgen.batch.load_spec`).
        output_dir: variants go to ``output_dir/<exemplar>/<seed>/`` with the files of
            ``barkgen generate``; ``output_dir/manifest.sqlite`` records their states.
        scheduler: address of a running Dask scheduler (``tcp://host:8786``); None starts a
            LocalCluster on this machine.
        workers: LocalCluster worker processes (default: one per core).
        threads: numba/faiss threads per variant (default: cores / workers on a LocalCluster,
            all cores of the worker with ``scheduler``).
        progress: ``progress(done, total)`` over the variants to make.
        log: receives one-line messages (dashboard address, what is skipped).
        client: an existing ``distributed.Client`` to run on (left open), instead of
            ``scheduler`` / a new LocalCluster.
        cache: each photo's analysis from the workers' analysis cache, or made and kept there
            (:func:`barkgen.pipeline.cached_analysis`); False: neither (``--no-cache``).
    """
    from barkgen.io import check_replaceable, remove_staging, write_folder_atomic

    say = log or (lambda message: None)
    if scheduler is not None:
        check_scheduler_address(scheduler)
    cores = os.cpu_count() or 1
    if workers is not None and not 1 <= workers <= 1024:
        raise InvalidInputError(f"workers must be 1..1024, not {workers}")
    if threads is not None and not 1 <= threads <= 1024:
        raise InvalidInputError(f"threads must be 1..1024, not {threads}")
    if (scheduler is not None or client is not None) and workers is not None:
        raise InvalidInputError(
            "--workers sizes the local cluster; with --scheduler the cluster's own workers are used"
        )
    if scheduler is None and client is None:
        workers = workers or cores
        threads = threads or max(1, cores // workers)
    output_dir = Path(output_dir)
    t0 = time.perf_counter()
    report = BatchReport(total=spec.n_variants)
    todo: list[tuple[ExemplarJob, list[int]]] = []
    manifest_path = output_dir / MANIFEST_NAME
    if manifest_path.exists() and not manifest_path.is_file():  # (refused before the cluster starts)
        raise InvalidInputError(f"{manifest_path}: the batch's manifest is not a file; move it away or pick another -o")
    done_before = Manifest(manifest_path) if manifest_path.is_file() else None
    try:
        for job in spec.exemplars:
            fingerprint = job.fingerprint()
            seeds = [
                s
                for s in job.seeds
                if done_before is None
                or not done_before.is_done(job.name, s, fingerprint, output_dir / job.name / str(s))
            ]
            report.skipped += len(job.seeds) - len(seeds)
            if seeds:
                todo.append(
                    (dataclasses.replace(job, options=dataclasses.replace(job.options, threads=threads)), seeds)
                )
    finally:
        if done_before is not None:
            done_before.close()
    n_todo = sum(len(seeds) for _, seeds in todo)
    if not n_todo:
        say(f"nothing to do: all {report.total} variants are already in {output_dir}")
        report.seconds = time.perf_counter() - t0
        return report
    # every photo is read and checked before any work starts (or any file is written), and
    # every variant's folder may be replaced: missing, empty, or a run barkgen wrote
    inputs = {job.name: _read_inputs(job) for job, _ in todo}
    for job, seeds in todo:
        for seed in seeds:
            check_replaceable(output_dir / job.name / str(seed))
    if report.skipped:
        say(f"{report.skipped} of {report.total} variants already done; making the other {n_todo}")
    own = client is None
    cluster = None
    if own:  # connected (or started) before anything is written
        client, cluster = _client(scheduler, workers, threads)
    try:
        with Manifest(manifest_path) as manifest:
            for job, _ in todo:
                remove_staging(output_dir / job.name)
            report.workers = len(client.scheduler_info(n_workers=-1)["workers"])
            report.dashboard = client.dashboard_link
            say(f"Dask dashboard: {report.dashboard} ({report.workers} workers)")
            _run(client, todo, inputs, output_dir, manifest, report, n_todo, progress, write_folder_atomic, cache)
            for job, _ in todo:
                remove_staging(output_dir / job.name)
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
    report.seconds = time.perf_counter() - t0
    return report


def _read_inputs(job: ExemplarJob):
    """A job's photo (and label map, and scanned set when its path is a set's folder), read and
    checked as the pipeline will check them."""
    from barkgen._shared.checks import MAX_PHOTO_PIXELS, check_image
    from barkgen.errors import BarkgenError, ImageTooLargeError
    from barkgen.io import image_size, read_image, read_scanned_set
    from barkgen.pipeline.core import check_generate_memory

    try:
        scan = read_scanned_set(job.path) if job.path.is_dir() else None
        if scan is None:
            width, height = image_size(job.path)  # from the header: a 144 MP photo is not decoded
            if width * height > MAX_PHOTO_PIXELS:
                raise ImageTooLargeError(
                    f"{width}x{height} px is more than the {MAX_PHOTO_PIXELS / 1e6:g} "
                    "megapixels a photo may be; scale it down"
                )
        photo = scan.color if scan is not None else read_image(job.path)
        check_image(photo)
        check_generate_memory(photo, job.options)  # before the cluster, not inside a worker
        labels = None if job.labels is None else read_image(job.labels)
        if labels is not None and labels.shape[:2] != photo.shape[:2]:
            raise InvalidInputError(
                f"the label map is {labels.shape[1]}x{labels.shape[0]} px but the "
                f"photo is {photo.shape[1]}x{photo.shape[0]} px"
            )
    except BarkgenError as exc:
        raise InvalidInputError(f"exemplar {job.name!r}: {exc}") from None
    return photo, labels, scan


def _run(
    client,
    todo,
    inputs,
    output_dir: Path,
    manifest: Manifest,
    report: BatchReport,
    n_todo: int,
    progress,
    write_folder,
    cache: bool = True,
) -> None:
    from distributed import as_completed

    from barkgen.io import set_asset_name

    futures = {}
    remaining: dict[str, int] = {}
    shared: dict[str, list] = {}
    for job, seeds in todo:
        photo, labels, scan = inputs[job.name]
        with warnings.catch_warnings():  # a 4096² photo is a "large graph"; it is sent once
            warnings.filterwarnings("ignore", message="Sending large graph")
            photo_f = client.submit(
                _photo_task, photo, pure=False, key=f"barkgen-photo-{job.name}-{os.urandom(4).hex()}"
            )
        analysis_f = client.submit(
            _analyse_task,
            photo_f,
            labels,
            job.options,
            scan,
            cache,
            pure=False,
            key=f"barkgen-analyse-{job.name}-{os.urandom(4).hex()}",
        )
        shared[job.name] = [photo_f, analysis_f]
        remaining[job.name] = len(seeds)
        fingerprint = job.fingerprint()
        named = job if scan is None else dataclasses.replace(job, asset=set_asset_name(scan.name))
        for seed in seeds:
            future = client.submit(
                _variant_task,
                photo_f,
                analysis_f,
                job.options_for(seed),
                job.source_name,
                named,
                pure=False,
                key=f"barkgen-variant-{job.name}-{seed}-{os.urandom(4).hex()}",
            )
            futures[future] = (job, seed, fingerprint)
            manifest.mark(job.name, seed, fingerprint, "running")
    done = 0
    for future in as_completed(list(futures)):
        job, seed, fingerprint = futures.pop(future)
        if future.status == "finished":
            out: VariantOutput = future.result()
            write_folder(output_dir / job.name / str(seed), out.files)
            manifest.mark(job.name, seed, fingerprint, "done", seconds=out.seconds, worker=out.worker)
            report.made += 1
            report.variant_seconds.append(out.seconds)
            report.analysis_seconds[job.name] = out.analysis_seconds
        else:
            exc = future.exception() if future.status == "error" else None
            error = _one_line(exc) if exc is not None else f"the task was {future.status} on the cluster"
            manifest.mark(job.name, seed, fingerprint, "failed", error=error)
            report.failed.append((job.name, seed, error))
        future.release()
        remaining[job.name] -= 1
        if remaining[job.name] == 0:  # the exemplar's shared data is no longer needed
            photo_f, analysis_f = shared.pop(job.name)
            analysis_f.release()
            photo_f.release()
        done += 1
        if progress:
            progress(done, n_todo)
