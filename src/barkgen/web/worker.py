"""The process that runs the web app's jobs: :func:`barkgen.pipeline.generate` on a library
photo, its files encoded as ``barkgen generate`` writes them, and the photos' label maps
(:class:`LabelSpec`: the label map a page shows before any result exists).

It lives in its own process so that the server stays responsive while the solvers keep both
cores busy, and so that cancelling a running job is immediate (the process is ended and a new
one started). It keeps the last few :class:`~barkgen.pipeline.PhotoAnalysis` so that another
seed of the same photo skips the per-photo analysis (same bytes either way), and below them the
analysis cache on disk that ``barkgen generate`` and ``batch`` share
(:func:`barkgen.pipeline.cached_analysis`).

A label job may carry the options of the page's defaults (:attr:`LabelSpec.prefetch`): once the
label map is sent, the worker goes on to make the photo's analysis for them from that label map,
so that the Generate most users click next pays only for its seed. It is a guess: a job that
arrives meanwhile with other analysis options stops it at its next step (a job with the same
ones takes it over).
"""

from __future__ import annotations

import dataclasses
import hashlib
import time
import traceback
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Progress:
    """A job's progress: the fraction done and the stage it is in."""

    job_id: str
    fraction: float
    stage: str | None = None


@dataclass(frozen=True)
class Done:
    """A job's files (name -> bytes) and its report (generate's ``report``; empty for a label
    map)."""

    job_id: str
    files: dict[str, bytes]
    report: dict


@dataclass(frozen=True)
class Failed:
    """A job that failed, in one line."""

    job_id: str
    error: str


#: what the worker sends back for a job (picklable)
WorkerMessage = Progress | Done | Failed

#: photo analyses kept in the worker (each is tens of MB for a 1024 px photo)
ANALYSES_KEPT = 3
#: a result's thumbnail: at most this many px a side, in the result's aspect
THUMBNAIL_SIDE = 320
#: at most one progress message per this many seconds
PROGRESS_INTERVAL_S = 0.1


@dataclass(frozen=True)
class JobSpec:
    """What the worker needs for one job (picklable; made by the server)."""

    job_id: str
    photo: bytes
    photo_hash: str
    source: str
    options: dict
    #: the material set's asset name and variant (:mod:`barkgen.io.asset_names`): its files are
    #: ``ASSET_VARIANT_SIZE_*``
    asset: str = "bark"
    variant: str | None = None
    #: the photo's licence, recorded in the set's JSON
    licence: str | None = None
    #: a job queued before the sets carried their size: the whole set name (``oak_seed7``)
    set_name: str | None = None
    labels_in: bytes | None = None
    resume: tuple[int, np.ndarray] | None = None
    #: the files of a scanned set whose colour is ``photo`` (by name), read when the job starts
    set_files: dict[str, bytes] | None = None
    #: the material set's file layout (:data:`barkgen.material.presets.PRESETS`)
    preset: str = "ambientcg"
    #: the edit list replayed on the result's set: its ``edits.json`` document (height edits, depth,
    #: light; :func:`barkgen.material.parse_edit_list`)
    edits: dict | None = None
    #: the photo's crack network as the user edited it (structure JSON), learned from instead
    #: of the extracted one (``structure="cracks"``, sibbing2010 §6)
    crack_structure: dict | None = None


@dataclass(frozen=True)
class LabelSpec:
    """A label-map job: the photo's input label map of ``k`` labels, made as ``barkgen
    generate`` makes it (picklable; made by the server)."""

    job_id: str
    photo: bytes
    k: int
    method: str = "color"
    #: the :class:`~barkgen.pipeline.GenerateOptions` keywords of the analysis to make next
    #: (the page's defaults), from this label map; None: none
    prefetch: dict | None = None
    #: the photo's hash (the worker's analyses are kept under it)
    photo_hash: str = ""


class _Superseded(Exception):
    """A job with other analysis options arrived while an analysis was made ahead."""


def run_labels(spec: LabelSpec, send) -> np.ndarray | None:
    """Make one photo's label map, reporting :class:`Done` (``{"labels_in.png": PNG}``) or
    :class:`Failed` through ``send``; the label map as its PNG reads (None when it failed)."""
    from barkgen.errors import BarkgenError
    from barkgen.io import decode_image, encode_png
    from barkgen.pipeline import GenerateOptions
    from barkgen.pipeline.labelmaps import photo_label_map
    from barkgen.synth import resolve_exemplar_wrap

    send(Progress(spec.job_id, 0.0, "label map"))
    try:
        photo = decode_image(spec.photo, "photo")
        # the label map generate makes of this photo: its broad light out, across its edges
        # where it tiles
        defaults = GenerateOptions()
        wrap = resolve_exemplar_wrap(defaults.exemplar_wrap, photo)
        label_map = photo_label_map(photo, spec.k, spec.method, wrap=wrap, equalize_light=defaults.equalize_light)
        data = encode_png(label_map)
    except BarkgenError as exc:
        send(Failed(spec.job_id, str(exc)))
        return None
    except MemoryError:
        send(Failed(spec.job_id, "out of memory while making the label map"))
        return None
    send(Done(spec.job_id, {"labels_in.png": data}, {}))
    return decode_image(data, "labels")  # as a generate job receives it (its analysis' key)


def job_analysis_key(
    photo_hash: str,
    options,
    scan: bool = False,
    cracks_digest: str | None = None,
    labels: np.ndarray | None = None,
) -> tuple:
    """The key of the worker's kept analyses: the photo, whether a scan makes its material
    set, the options the analysis depends on, an edited crack network's digest and the label
    map given (its pixels' digest: another label map of one photo is another analysis)."""
    from barkgen.pipeline import analysis_key

    labels_digest = None
    if labels is not None:
        array = np.ascontiguousarray(labels)
        labels_digest = hashlib.sha256(repr((array.shape, array.dtype.str)).encode() + array.tobytes()).hexdigest()
    return (photo_hash, scan, analysis_key(options), cracks_digest, labels_digest)


def prefetch_analysis(
    spec: LabelSpec, label_map: np.ndarray, analyses: OrderedDict, conn
) -> list[JobSpec | LabelSpec | None]:
    """Make the analysis of ``spec.prefetch`` from the label map just made (into ``analyses``,
    and the analysis cache on disk), watching ``conn``: the message received meanwhile, if any,
    is returned (in a list) for the caller to take next; the analysis is given up for it at its next step unless it
    needs the same analysis. Any failure only ends the guess."""
    from barkgen.io import decode_image
    from barkgen.pipeline import GenerateOptions, cached_analysis, open_store

    pending: list[JobSpec | LabelSpec | None] = []
    try:
        options = GenerateOptions(**(spec.prefetch or {}))
        key = job_analysis_key(spec.photo_hash, options, labels=label_map)
        if key in analyses:
            return pending

        def watch(done: int, total: int) -> None:
            if pending or not conn.poll():
                return
            pending.append(conn.recv())
            job = pending[0]
            if not (
                isinstance(job, JobSpec)
                and not job.set_files
                and not job.crack_structure
                and job.labels_in is not None
                and job_analysis_key(
                    job.photo_hash, GenerateOptions(**job.options), labels=decode_image(job.labels_in, "labels")
                )
                == key
            ):
                raise _Superseded

        photo = decode_image(spec.photo, "photo")
        analyses[key] = cached_analysis(
            photo, options, labels_in=label_map, progress=watch, store=open_store(), wait=False
        )
        while len(analyses) > ANALYSES_KEPT:
            analyses.popitem(last=False)
    except _Superseded:
        pass
    except Exception:  # noqa: BLE001 - only a guess: the job that needs it makes it
        traceback.print_exc()
    return pending


def encode_result(photo: np.ndarray, result, spec: JobSpec) -> dict[str, bytes]:
    """Every file of a job's result: those of ``barkgen generate`` (:func:`barkgen.pipeline.encode_generate`,
    with the material set named ``ASSET_VARIANT_SIZE`` from ``spec``), every level of the output
    label map as ``level_N.png`` and a ``thumbnail.jpg`` of the texture in its own aspect (at most
    :data:`THUMBNAIL_SIDE` px a side: a 1024x512 result's is 320x160)."""
    import io

    from PIL import Image

    from barkgen._shared.arrays import as_uint8
    from barkgen.io import encode_png
    from barkgen.pipeline import WindowedMaterial, encode_generate

    if isinstance(result.material, WindowedMaterial):  # (a server whose outputs exceed 4096²: the set whole)
        result = dataclasses.replace(result, material=result.material.whole())
    also = {}
    if result.material is not None:  # the bark on a trunk, for any glTF viewer or engine
        from barkgen.io import encode_glb
        from barkgen.render import trunk_mesh

        also["trunk.glb"] = encode_glb(trunk_mesh(result.material), result.material)
    # (a job queued by an older server: its whole set name, no variant)
    name, variant = (spec.set_name, None) if spec.set_name is not None else (spec.asset, spec.variant)
    files = encode_generate(
        photo, result, spec.source, name=name, variant=variant, licence=spec.licence, preset=spec.preset, also=also
    )
    files.update(
        {f"level_{i}.png": encode_png(level) for i, level in enumerate(result.label_levels) if level is not None}
    )
    if spec.edits:  # the relief editor's list, for `barkgen generate --material --edits`
        import json

        files["edits.json"] = (json.dumps(spec.edits, indent=1) + "\n").encode()
    thumb = Image.fromarray(as_uint8(result.texture).squeeze())
    thumb.thumbnail((THUMBNAIL_SIDE, THUMBNAIL_SIDE))
    buffer = io.BytesIO()
    thumb.convert("RGB").save(buffer, "JPEG", quality=88)
    files["thumbnail.jpg"] = buffer.getvalue()
    return files


def _edited_cracks(data: dict | None):
    """An edited crack network's :class:`~barkgen.branching.Structure` and a digest of it (the
    analysis it makes is kept under it); ``(None, None)`` without one."""
    if not data:
        return None, None
    import hashlib
    import json

    from barkgen.branching import Structure

    digest = hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()
    return Structure.from_dict(data, "crack_structure"), digest


def run_job(spec: JobSpec, analyses: OrderedDict, send) -> None:
    """Run one job, reporting through ``send(message)``: :class:`Progress` messages, then
    :class:`Done` or :class:`Failed`."""
    from barkgen.errors import BarkgenError
    from barkgen.io import decode_image, scanned_set_from_files
    from barkgen.material import EditList, parse_edit_list
    from barkgen.pipeline import (
        GenerateOptions,
        adjusted_result,
        cached_analysis,
        generate,
        open_store,
        stage_at,
        stage_span,
    )

    last = [0.0]
    material = bool(spec.options.get("material", False))

    def progress(done: int, total: int) -> None:
        now = time.monotonic()
        if now - last[0] >= PROGRESS_INTERVAL_S or done >= total:
            last[0] = now
            fraction = done / max(total, 1)
            send(Progress(spec.job_id, fraction, stage_at(fraction, material)))

    try:
        photo = decode_image(spec.photo, spec.source)
        options = GenerateOptions(**spec.options)
        cracks, digest = _edited_cracks(spec.crack_structure)
        labels_in = decode_image(spec.labels_in, "labels") if spec.labels_in is not None else None
        # a scanned set's own maps make the material set (without material: the colour alone)
        scan = None
        if spec.set_files and options.material:
            scan = scanned_set_from_files(spec.set_files, where=spec.source)
        # an edited crack network is another analysis of the same photo
        key = job_analysis_key(spec.photo_hash, options, scan is not None, digest, labels_in)
        analysis = analyses.get(key)
        if analysis is None:
            # generate() given an analysis reports from the end of its analysis stage on; under
            # the analyses kept here, the analysis cache on disk (barkgen serve --no-cache: none)
            share = stage_span("analysis", options.material)[1]
            analysis = cached_analysis(
                photo,
                options,
                labels_in=labels_in,
                progress=lambda done, total: progress(round(1000 * share * done / max(total, 1)), 1000),
                scan=scan,
                cracks=cracks,
                store=open_store(),
                wait=False,  # written on a thread while the job goes on
            )
            analyses[key] = analysis
            while len(analyses) > ANALYSES_KEPT:
                analyses.popitem(last=False)
        else:
            analyses.move_to_end(key)
        edit_list = parse_edit_list(spec.edits) if spec.edits else EditList()
        result = generate(
            photo, options, analysis=analysis, resume=spec.resume, progress=progress, scan=scan, edits=edit_list.edits
        )
        result = adjusted_result(result, edit_list)  # the sliders' depth and light, after the edits
        files = encode_result(photo, result, spec)
    except BarkgenError as exc:
        send(Failed(spec.job_id, str(exc)))
        return
    except MemoryError:
        send(Failed(spec.job_id, "out of memory: try a smaller size"))
        return
    except Exception as exc:  # a bug: report it in one line, keep the worker alive
        traceback.print_exc()
        send(Failed(spec.job_id, f"internal error ({type(exc).__name__}: {exc})"))
        return
    try:
        send(Done(spec.job_id, files, result.report))
    except (OSError, ValueError, TypeError) as exc:  # a pipe error, a report that does not pickle
        send(Failed(spec.job_id, f"could not send the result ({exc})"))


def load_generate(spec: LabelSpec, conn) -> None:
    """A small generate of a corner of the photo with ``spec.prefetch``'s options, so that the
    first job of a new worker finds its kernels loaded and its modules imported (about 2 s of a
    first generate's); given up as soon as a message waits on ``conn``."""
    from barkgen.io import decode_image
    from barkgen.pipeline import GenerateOptions, generate

    def watch(done: int, total: int) -> None:
        if conn.poll():
            raise _Superseded

    try:
        corner = decode_image(spec.photo, "photo")[:96, :96]
        options = GenerateOptions(**{**(spec.prefetch or {}), "size": (64, 64), "seed": 0})
        generate(corner, options, progress=watch)
    except _Superseded:
        pass
    except Exception:  # noqa: BLE001 - only a warm-up: the job reports its own errors
        traceback.print_exc()


def _load_modules(conn) -> None:
    """Import what the jobs run (the pipeline, the label maps' OpenCV and scikit-learn), so that
    a worker started ahead of its first job (``barkgen serve``) spends none of it importing;
    it stops as soon as a job waits on ``conn`` (the job imports what it needs)."""
    import importlib

    for name in (
        "barkgen.pipeline",
        "barkgen.pipeline.core",
        "barkgen.pipeline.labelmaps",
        "barkgen.labels",
        "barkgen.material",
        "barkgen.synth",
        "barkgen.io",
        "sklearn.cluster",
        "PIL.Image",
    ):
        if conn.poll():
            return
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - the job that needs it reports the error
            pass


def worker_main(conn, load_ahead: bool = False) -> None:
    """The worker process: run the jobs received on ``conn`` one after the other until it is
    closed (or the process is ended); ``load_ahead``: import the jobs' modules first (a worker
    started before it has a job)."""
    if load_ahead:
        _load_modules(conn)
    analyses: OrderedDict = OrderedDict()
    pending: list[JobSpec | LabelSpec | None] = []  # a message received while making a guess
    loaded = False  # a generate has run in this process (its kernels are loaded)
    while True:
        spec: JobSpec | LabelSpec | None
        if pending:
            spec = pending.pop()
        else:
            try:
                spec = conn.recv()
            except (EOFError, OSError):
                return
        if spec is None:
            return
        if isinstance(spec, LabelSpec):
            label_map = run_labels(spec, conn.send)
            if label_map is not None and spec.prefetch is not None:
                try:
                    pending = prefetch_analysis(spec, label_map, analyses, conn)
                    if not pending and not loaded:
                        load_generate(spec, conn)
                        loaded = True
                except (EOFError, OSError):
                    return
        else:
            run_job(spec, analyses, conn.send)
            loaded = True
