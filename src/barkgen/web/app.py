"""The web app (FastAPI): the exemplar library as pages, one-click generation with progress,
the result with its maps on a WebGL trunk, a label painter to steer the large-scale pattern
(laitoch2018 §1) and the material set as a zip.

The pages (``static/*.html``, plain JavaScript) drive the JSON API below, which scripts can use
too (README, "Web app"). The app adds no algorithm: it calls :mod:`barkgen.library`,
:func:`barkgen.pipeline.generate` (in :mod:`.jobs`' worker process) and :mod:`barkgen.io`.
"""

from __future__ import annotations

import asyncio
import base64
import binascii
import io
import ipaddress
import json
import re
import secrets
import threading
import warnings
import zipfile
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fastapi import FastAPI, File, Form, HTTPException, Request, UploadFile
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import FileResponse, JSONResponse, Response, StreamingResponse
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, Field

from barkgen.errors import BarkgenError, ImageTooLargeError
from barkgen.library import Library, NotFoundError
from barkgen.web.jobs import FINISHED, JobManager, QueueFullError

STATIC = Path(__file__).parent / "static"
#: label maps of the photos are made the way `barkgen generate` makes them
LABEL_METHOD = "color"
#: the photo as pages show it, and its thumbnail: at most this many px a side
DISPLAY_SIDE = 2048
THUMBNAIL_SIDE = 320


@dataclass(frozen=True)
class WebLimits:
    """Upload and job limits (defaults: 25 MB and 50 megapixels per upload; outputs up to
    4096 px a side)."""

    max_upload_bytes: int = 25 * 1024**2
    max_upload_pixels: int = 50_000_000
    max_output_side: int = 4096


class ResumeRequest(BaseModel):
    result_id: int
    level: int = Field(ge=0)
    labels: str  # data:image/png;base64,...


class JobRequest(BaseModel):
    exemplar_id: int
    size: str = "512x512"
    seed: int | None = Field(default=None, ge=0, lt=2**63)
    k: int = 3
    tile: bool = True
    material: bool = True
    resume: ResumeRequest | None = None


class BodyTooLarge(HTTPException):
    """A request body over the limit (raised while it arrives, answered 413)."""


class BodyLimit:
    """ASGI middleware: a request body may hold at most ``limit`` bytes, whether its length is
    declared (refused before it is read) or not (chunked: refused as soon as it goes over), so
    no upload fills memory or disk past the limit."""

    def __init__(self, app, limit: int, detail: str) -> None:
        self.app, self.limit, self.detail = app, limit, detail

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        length = dict(scope["headers"]).get(b"content-length", b"")
        if length.isdigit() and int(length) > self.limit:
            return await JSONResponse({"detail": self.detail}, status_code=413)(scope, receive, send)
        received = 0

        async def limited():
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.limit:
                    raise BodyTooLarge(413, self.detail)
            return message

        return await self.app(scope, limited, send)


class SameOrigin:
    """ASGI middleware against cross-site requests and DNS rebinding: the ``Host`` header must
    be one of ``hosts`` (when given), and a request that changes anything (not GET/HEAD) from
    a browser must come from the app's own origin."""

    def __init__(self, app, hosts: list[str] | None) -> None:
        self.app, self.hosts = app, hosts

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        headers = dict(scope["headers"])
        host = headers.get(b"host", b"").decode("latin-1")
        name = host.rsplit(":", 1)[0] if not host.endswith("]") else host
        if self.hosts is not None and name.strip("[]") not in self.hosts:
            return await JSONResponse({"detail": f"unknown host {host!r}"}, status_code=400)(scope, receive, send)
        origin = headers.get(b"origin")
        if scope["method"] not in ("GET", "HEAD") and origin is not None:
            if origin.decode("latin-1").split("://", 1)[-1] != host:
                return await JSONResponse({"detail": "cross-site requests are not allowed"},
                                          status_code=403)(scope, receive, send)
        return await self.app(scope, receive, send)


def allowed_hosts(host: str) -> list[str] | None:
    """The Host names a server bound to ``host`` answers: loopback names, plus ``host``
    itself; None (any) when it listens on every address."""
    if host in ("0.0.0.0", "::", ""):
        return None
    return sorted({"127.0.0.1", "localhost", "::1", host.strip("[]")})


def is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return host == "localhost"


def _bad(status: int, detail: str) -> HTTPException:
    return HTTPException(status_code=status, detail=detail)


def _png(data: bytes) -> Response:
    return Response(data, media_type="image/png", headers={"Cache-Control": "max-age=3600"})


_MEDIA = {".png": "image/png", ".jpg": "image/jpeg", ".json": "application/json"}


def create_app(library: Library, *, limits: WebLimits | None = None, run_jobs: bool = True,
               hosts: list[str] | None = None) -> FastAPI:
    """The app on ``library``. ``run_jobs=False`` queues jobs without running them (tests);
    ``hosts``: the Host names it answers (None: any; :func:`serve` passes
    :func:`allowed_hosts`)."""
    from barkgen.io import AlphaDroppedWarning, decode_image, encode_png
    from barkgen.labels import label_colour_map
    from barkgen.labels.preview import label_colours
    from barkgen.pipeline import ANALYSIS_SEED, GenerateOptions
    from barkgen._shared.checks import parse_size

    limits = limits or WebLimits()
    jobs = JobManager(library)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        if run_jobs:
            jobs.start()
        yield
        jobs.stop()

    app = FastAPI(title="barkgen", lifespan=lifespan,
                  description="Bark textures from one photo: library, jobs, results.")
    app.state.library = library
    app.state.jobs = jobs
    #: set by :func:`serve`: true once the server is asked to stop (event streams end then)
    app.state.should_exit = lambda: False
    app.mount("/static", StaticFiles(directory=STATIC), name="static")

    # a painted level arrives as base64 in JSON: a third larger than its PNG
    body_limit = limits.max_upload_bytes * 4 // 3 + 1024**2
    app.add_middleware(BodyLimit, limit=body_limit,
                       detail=f"the upload is larger than the limit of {limits.max_upload_bytes // 1024**2} MB")
    app.add_middleware(SameOrigin, hosts=hosts)

    @app.exception_handler(NotFoundError)
    async def not_found(request: Request, exc: NotFoundError):
        return JSONResponse({"detail": str(exc)}, status_code=404)

    @app.exception_handler(ImageTooLargeError)
    async def too_large(request: Request, exc: ImageTooLargeError):
        return JSONResponse({"detail": str(exc)}, status_code=413)

    @app.exception_handler(QueueFullError)
    async def queue_full(request: Request, exc: QueueFullError):
        return JSONResponse({"detail": str(exc)}, status_code=429)

    @app.exception_handler(BarkgenError)
    async def bad_input(request: Request, exc: BarkgenError):
        return JSONResponse({"detail": str(exc)}, status_code=400)

    # -- pages ------------------------------------------------------------------------------
    @app.get("/", include_in_schema=False)
    def index_page():
        return FileResponse(STATIC / "index.html")

    # the pages load their data from the API and say themselves when an id is unknown
    @app.get("/exemplars/{exemplar_id}", include_in_schema=False)
    def exemplar_page(exemplar_id: str):
        return FileResponse(STATIC / "exemplar.html")

    @app.get("/results/{result_id}", include_in_schema=False)
    def result_page(result_id: str):
        return FileResponse(STATIC / "result.html")

    # -- exemplars --------------------------------------------------------------------------
    def exemplar_json(exemplar) -> dict:
        return {**exemplar.to_dict(), "photo_url": f"/api/exemplars/{exemplar.id}/photo",
                "thumbnail_url": f"/api/exemplars/{exemplar.id}/thumbnail.jpg"}

    def result_summary(result) -> dict:
        return {"id": result.id, "exemplar_id": result.exemplar_id, "created": result.created,
                "params": result.params, "thumbnail_url": f"/api/results/{result.id}/files/thumbnail.jpg"}

    @app.get("/api/exemplars")
    def list_exemplars():
        return [exemplar_json(e) for e in library.exemplars()]

    @app.post("/api/exemplars", status_code=201)
    async def add_exemplar(request: Request, file: UploadFile = File(...), name: str | None = Form(None),
                           species: str | None = Form(None), licence: str | None = Form(None)):
        data = await file.read(limits.max_upload_bytes + 1)
        if len(data) > limits.max_upload_bytes:
            raise _bad(413, f"the upload is larger than the limit of {limits.max_upload_bytes // 1024**2} MB")
        # the client's file name is only a default display name: it never touches the filesystem
        display = (name or Path(file.filename or "").stem or "uploaded bark").strip()[:200]
        existing = library.find_exemplar(data)
        if existing is not None:  # the same photo again: its entry (the page says so)
            return JSONResponse({"id": existing.id, "existing": True}, status_code=200)
        exemplar = await run_in_threadpool(
            library.add_exemplar, data, display, species=species or None, licence=licence or None,
            source="uploaded", max_pixels=limits.max_upload_pixels)
        return {"id": exemplar.id, "existing": False}

    @app.get("/api/exemplars/{exemplar_id}")
    def get_exemplar(exemplar_id: int):
        exemplar = library.exemplar(exemplar_id)
        return {**exemplar_json(exemplar),
                "results": [result_summary(r) for r in library.results(exemplar_id)]}

    @app.delete("/api/exemplars/{exemplar_id}")
    def remove_exemplar(exemplar_id: int):
        library.exemplar(exemplar_id)
        jobs.cancel_exemplar(exemplar_id)
        library.remove_exemplar(exemplar_id)
        return {"removed": exemplar_id}

    @app.get("/api/exemplars/{exemplar_id}/photo")
    def exemplar_photo(exemplar_id: int):
        return Response(preview_jpeg(exemplar_id, DISPLAY_SIDE), media_type="image/jpeg",
                        headers={"Cache-Control": "max-age=3600"})

    def preview_jpeg(exemplar_id: int, side: int) -> bytes:
        """The photo at most ``side`` px a side as a JPEG, cached in the library's analyses."""
        key = {"side": side, "format": "jpeg"}
        cached = library.analysis(exemplar_id, "preview", key)
        if cached is not None:
            return cached
        from PIL import Image

        from barkgen._shared.arrays import as_uint8

        image = Image.fromarray(as_uint8(library.photo(exemplar_id)).squeeze())
        image.thumbnail((side, side))
        buffer = io.BytesIO()
        image.convert("RGB").save(buffer, "JPEG", quality=90)
        library.put_analysis(exemplar_id, "preview", key, buffer.getvalue())
        return buffer.getvalue()

    @app.get("/api/exemplars/{exemplar_id}/thumbnail.jpg")
    def exemplar_thumbnail(exemplar_id: int):
        return Response(preview_jpeg(exemplar_id, THUMBNAIL_SIDE), media_type="image/jpeg",
                        headers={"Cache-Control": "max-age=3600"})

    label_locks: dict[tuple[int, int], threading.Lock] = {}
    label_locks_guard = threading.Lock()

    def labels_key(k: int) -> dict:
        return {"k": k, "method": LABEL_METHOD, "seed": ANALYSIS_SEED}

    def labels_in(exemplar_id: int, k: int) -> bytes:
        """The photo's input label map (grey values, as ``barkgen generate`` makes it), cached
        in the library's analyses (made once however many pages ask at the same time)."""
        with label_locks_guard:
            lock = label_locks.setdefault((exemplar_id, k), threading.Lock())
        with lock:
            cached = library.analysis(exemplar_id, "labels_in", labels_key(k))
            if cached is not None:
                return cached
            from barkgen.labels import color_regions

            data = encode_png(color_regions(library.photo(exemplar_id), k, seed=ANALYSIS_SEED))
            library.put_analysis(exemplar_id, "labels_in", labels_key(k), data)
            return data

    @app.get("/api/exemplars/{exemplar_id}/labels.png")
    def exemplar_labels(exemplar_id: int, k: int = 3):
        if not 2 <= k <= 8:
            raise _bad(400, "k must be between 2 and 8")
        library.exemplar(exemplar_id)
        grey = decode_image(labels_in(exemplar_id, k), "labels")
        return _png(encode_png(label_colour_map(grey[..., 0])))

    # -- jobs -------------------------------------------------------------------------------
    def check_size(text: str) -> tuple[int, int]:
        height, width = parse_size(text)
        if max(width, height) > limits.max_output_side:
            raise _bad(400, f"size {text} is larger than this server's limit of "
                            f"{limits.max_output_side} px a side")
        return height, width

    def painted_level(request: ResumeRequest, exemplar_id: int, params: dict) -> tuple[int, np.ndarray]:
        """The painted level as a label map of the parent result's label values."""
        parent = library.result(request.result_id)
        if parent.exemplar_id != exemplar_id:
            raise _bad(400, f"result {parent.id} belongs to exemplar {parent.exemplar_id}, not {exemplar_id}")
        if [params["size"][0], params["size"][1], params["k"]] != [*parent.params["size"], parent.params["k"]]:
            raise _bad(400, "continuing a result keeps its size and k")
        level_name = f"level_{request.level}.png"
        if level_name not in parent.files:
            raise _bad(400, f"result {parent.id} has no label-map level {request.level}")
        match = re.fullmatch(r"data:image/png;base64,([A-Za-z0-9+/=\s]+)", request.labels)
        if not match:
            raise _bad(400, "the painted labels must be a PNG data URL (data:image/png;base64,...)")
        try:
            data = base64.b64decode(match.group(1), validate=False)
        except (binascii.Error, ValueError):
            raise _bad(400, "the painted labels are not valid base64") from None
        with warnings.catch_warnings():  # a canvas PNG has alpha, which says nothing here
            warnings.simplefilter("ignore", AlphaDroppedWarning)
            painted = decode_image(data, "the painted labels", max_pixels=limits.max_upload_pixels)
        level = decode_image(library.result_file(parent.id, level_name), "level")[..., 0]
        if painted.shape[:2] != level.shape:
            raise _bad(400, f"the painted labels are {painted.shape[1]}x{painted.shape[0]} px but level "
                            f"{request.level} is {level.shape[1]}x{level.shape[0]} px")
        values = np.unique(decode_image(library.result_file(parent.id, "labels_in.png"), "labels"))
        if painted.dtype != np.uint8:
            raise _bad(400, "the painted labels must be an 8-bit PNG")
        rgb = np.broadcast_to(painted, painted.shape[:2] + (3,))
        codes = np.full(rgb.shape[:2], -1, np.int64)
        for index, colour in enumerate(label_colours(values.size)):
            codes[(rgb == colour).all(-1)] = index
        off = codes < 0
        if off.any():
            y, x = np.argwhere(off)[0]
            raise _bad(400, f"the painted pixel at x={x}, y={y} has colour {tuple(int(c) for c in rgb[y, x])}, "
                            "which is no label's colour; paint with the palette only")
        return request.level, values[codes].astype(level.dtype)

    @app.post("/api/jobs", status_code=201)
    async def submit_job(request: JobRequest):
        exemplar = library.exemplar(request.exemplar_id)
        height, width = check_size(request.size)
        seed = request.seed if request.seed is not None else secrets.randbelow(100_000)
        options = GenerateOptions(size=(height, width), k=request.k, tile=request.tile, seed=seed,
                                  material=request.material, method=LABEL_METHOD)
        params = {"size": [width, height], "k": options.k, "tile": options.tile, "seed": seed,
                  "material": options.material, "resumed_from": None}
        resume = None
        if request.resume is not None:
            resume = await run_in_threadpool(painted_level, request.resume, exemplar.id, params)
            params["resumed_from"] = {"result_id": request.resume.result_id, "level": resume[0]}
        # the photo's label map when a page has made it already (else the worker makes it)
        grey = library.analysis(exemplar.id, "labels_in", labels_key(options.k))
        spec = {"source": exemplar.name, "set_name": f"bark{exemplar.id}_seed{seed}",
                "options": {"size": (height, width), "k": options.k, "tile": options.tile,
                            "seed": seed, "material": options.material, "method": LABEL_METHOD},
                "labels_in": grey, "resume": resume}
        job = jobs.submit(exemplar.id, params, spec,
                          parent_id=request.resume.result_id if request.resume else None,
                          labels_key=labels_key(options.k) if grey is None else None)
        return {"id": job.id}

    @app.get("/api/jobs")
    def list_jobs():
        return jobs.list()

    def job_or_404(job_id: str) -> dict:
        snapshot = jobs.snapshot(job_id)
        if snapshot is None:
            raise _bad(404, f"no job {job_id}")
        return snapshot

    @app.get("/api/jobs/{job_id}")
    def get_job(job_id: str):
        return job_or_404(job_id)

    @app.delete("/api/jobs/{job_id}")
    def cancel_job(job_id: str):
        job_or_404(job_id)
        return jobs.cancel(job_id)

    @app.get("/api/jobs/{job_id}/events")
    async def job_events(job_id: str, request: Request):
        """Server-sent events: the job's JSON on every change, until it is finished."""
        snapshot = job_or_404(job_id)

        async def stream():
            current, sent_at = snapshot, asyncio.get_running_loop().time()
            yield f"data: {json.dumps(current)}\n\n"
            while current["state"] not in FINISHED:
                # poll without holding a thread: any number of pages may watch
                await asyncio.sleep(0.1)
                if jobs.stopping or app.state.should_exit() or await request.is_disconnected():
                    return
                latest = jobs.snapshot(job_id)
                if latest is None:
                    return
                now = asyncio.get_running_loop().time()
                if latest["version"] != current["version"] or now - sent_at > 10:  # or keep-alive
                    current, sent_at = latest, now
                    yield f"data: {json.dumps(current)}\n\n"

        return StreamingResponse(stream(), media_type="text/event-stream",
                                 headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})

    # -- results ----------------------------------------------------------------------------
    def result_json(result) -> dict:
        base = f"/api/results/{result.id}"
        files = {name: f"{base}/files/{name}" for name in result.files}
        material_name = next((n[:-len("_Color.png")] for n in result.files if n.endswith("_Color.png")), None)
        maps = None
        depth = None
        if material_name is not None:
            from barkgen.io import MAP_SUFFIXES

            maps = {suffix: files[f"{material_name}_{suffix}.png"] for suffix in MAP_SUFFIXES}
            meta = json.loads(library.result_file(result.id, f"{material_name}.json"))
            depth = meta.get("displacement_depth_px")
        from PIL import Image

        levels, sizes = [], []
        for name in sorted(result.files):
            m = re.fullmatch(r"level_(\d+)\.png", name)
            if m:
                levels.append(int(m.group(1)))
                with Image.open(io.BytesIO(library.result_file(result.id, name))) as header:
                    sizes.append(header.size)
        values = np.unique(decode_image(library.result_file(result.id, "labels_in.png"), "labels"))
        return {**result_summary(result), "timings": result.timings, "parent_id": result.parent_id,
                "files": files, "labels_in_url": f"{base}/labels/labels_in.png",
                "labels_out_url": f"{base}/labels/labels_out.png", "maps": maps,
                "displacement_depth_px": depth,
                "levels": [{"level": n, "width": w, "height": h, "url": f"{base}/labels/level_{n}.png"}
                           for n, (w, h) in sorted(zip(levels, sizes))],
                "palette": label_colours(values.size).tolist(),
                "label_looks": label_looks(result.exemplar_id, result.id, values),
                "download_url": f"{base}/download"}

    def label_looks(exemplar_id: int, result_id: int, values: np.ndarray) -> list[dict]:
        """What each label is in the photo: its mean colour and its share of the photo (the
        legend of the label colours), cached in the library's analyses."""
        key = {"values": [int(v) for v in values], "method": LABEL_METHOD}
        cached = library.analysis(exemplar_id, "label_looks", key)
        if cached is not None:
            return json.loads(cached)
        from barkgen._shared.arrays import as_uint8

        photo = as_uint8(library.photo(exemplar_id)).astype(np.float64)
        photo = np.broadcast_to(photo, photo.shape[:2] + (3,))
        grey = decode_image(library.result_file(result_id, "labels_in.png"), "labels")[..., 0]
        looks = []
        for value in values:
            inside = grey == value
            mean = photo[inside].mean(axis=0) if inside.any() else np.zeros(3)
            looks.append({"colour": [int(round(c)) for c in mean], "share": round(float(inside.mean()), 4)})
        library.put_analysis(exemplar_id, "label_looks", key, json.dumps(looks).encode())
        return looks

    @app.get("/api/results")
    def list_results():
        return [result_summary(r) for r in library.results()]

    @app.get("/api/results/{result_id}")
    def get_result(result_id: int):
        return result_json(library.result(result_id))

    @app.delete("/api/results/{result_id}")
    def remove_result(result_id: int):
        library.remove_result(result_id)
        return {"removed": result_id}

    @app.get("/api/results/{result_id}/files/{name}")
    def result_file(result_id: int, name: str):
        data = library.result_file(result_id, name)  # a name of the result's own list, or 404
        return Response(data, media_type=_MEDIA.get(Path(name).suffix, "application/octet-stream"),
                        headers={"Cache-Control": "max-age=3600"})

    @app.get("/api/results/{result_id}/labels/{name}")
    def result_labels(result_id: int, name: str):
        """A label map of the result (``labels_in.png``, ``labels_out.png``, ``level_N.png``)
        in the label colours (those of ``palette``)."""
        if not re.fullmatch(r"labels_in\.png|labels_out\.png|level_\d+\.png", name):
            raise _bad(404, f"no label map {name!r}")
        values = np.unique(decode_image(library.result_file(result_id, "labels_in.png"), "labels"))
        grey = decode_image(library.result_file(result_id, name), name)[..., 0]
        return _png(encode_png(label_colour_map(grey, values)))

    @app.get("/api/results/{result_id}/download")
    def download(result_id: int):
        """The result as a zip: the material set (ambientCG names) when it has one, the texture,
        its label maps, reference map, contact sheet and report."""
        result = library.result(result_id)
        exemplar = library.exemplar(result.exemplar_id)
        names = [n for n in sorted(result.files) if not n.startswith("level_") and n != "thumbnail.jpg"]
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as archive:
            for name in names:
                archive.writestr(name, library.result_file(result_id, name))
            archive.writestr("README.txt", _zip_readme(exemplar.name, result, names))
        slug = re.sub(r"[^A-Za-z0-9]+", "-", exemplar.name).strip("-").lower()[:40] or "bark"
        width, height = result.params["size"]
        filename = f"barkgen_{slug}_seed{result.params['seed']}_{width}x{height}.zip"
        return Response(buffer.getvalue(), media_type="application/zip", headers={
            "Content-Disposition": f'attachment; filename="{filename}"'})

    return app


_FILE_NOTES = {
    "_Color.png": "base colour (sRGB), shading removed",
    "_NormalGL.png": "normal map, OpenGL convention (Y up: Blender, Unity, three.js)",
    "_NormalDX.png": "normal map, DirectX convention (Y down: Unreal, Substance)",
    "_Displacement.png": "height, 16-bit, 0 = deepest (depth in the .json)",
    "_Roughness.png": "roughness (linear)",
    "_AmbientOcclusion.png": "ambient occlusion (linear)",
    ".json": "the material set's record: size, tileable, seed, source photo, displacement depth",
    "texture.png": "the new bark, as synthesized (before shading removal)",
    "labels_in.png": "the photo's label map (one grey value per region type)",
    "labels_out.png": "the new bark's label map (same grey values)",
    "reference.png": "16-bit: for each output pixel, the photo pixel (x, y) it copies "
                     "(barkgen apply-reference re-applies it to any map of the photo)",
    "preview.png": "contact sheet: photo, labels in, labels out, result",
    "report.json": "parameters, seed, label areas and timings of the run",
}


def _zip_readme(photo: str, result, names: list[str]) -> str:
    """What each file of a downloaded result is."""
    width, height = result.params["size"]
    lines = [f"barkgen result {result.id}: {width}x{height} px from \"{photo}\", seed {result.params['seed']}"
             f"{', tileable' if result.params.get('tile') else ''}.", ""]
    for name in names:
        note = next((text for key, text in _FILE_NOTES.items() if name == key or
                     (key.startswith(("_", ".")) and name.endswith(key) and name != "report.json")), "")
        lines.append(f"{name:40s} {note}".rstrip())
    return "\n".join(lines) + "\n"


def serve(library: Library, host: str = "127.0.0.1", port: int = 8000, *,
          limits: WebLimits | None = None, on_ready=None) -> None:
    """Run the app with uvicorn until interrupted. ``on_ready(url)`` is called once it listens."""
    import uvicorn

    app = create_app(library, limits=limits, hosts=allowed_hosts(host))
    # open event streams must not hold a Ctrl-C: they are cut after 2 s
    config = uvicorn.Config(app, host=host, port=port, log_level="warning", timeout_graceful_shutdown=2)
    server = uvicorn.Server(config)
    app.state.should_exit = lambda: server.should_exit

    if on_ready is not None:
        original = server.startup

        async def startup(sockets=None):
            await original(sockets=sockets)
            if server.started:
                shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
                shown = f"[{shown}]" if ":" in shown else shown
                on_ready(f"http://{shown}:{port}/")

        server.startup = startup
    asyncio.run(server.serve())
