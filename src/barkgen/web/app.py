"""The web app (FastAPI): the exemplar library as pages, one-click generation with progress,
the result with its maps on a WebGL trunk, a label painter to steer the large-scale pattern
(laitoch2018 §1), a relief editor (wang2003 §3.3), a crack view to edit the crack network a
crack job learns from and rectify the photo (sibbing2010 §6) and the material set as a zip.

The pages (``static/*.html``, plain JavaScript) drive the JSON API, which scripts can use too
(docs, "Web app and library"). This module builds the app: its state (:class:`~.state.AppState`), its
middleware (:mod:`.middleware`), the one place barkgen's errors become HTTP codes, and the
routers of :mod:`.routes_pages`, :mod:`.routes_exemplars`, :mod:`.routes_cracks`, :mod:`.routes_jobs`,
:mod:`.routes_results` and :mod:`.relief`, whose endpoints wrap plain functions. The app adds no algorithm: it
calls :mod:`barkgen.library`, :func:`barkgen.pipeline.generate` (in :mod:`.jobs`' worker
process) and :mod:`barkgen.io`.
"""

from __future__ import annotations

import asyncio
import logging
import sys
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.staticfiles import StaticFiles

from barkgen.errors import BarkgenError, ImageTooLargeError
from barkgen.library import Library, NotFoundError
from barkgen.web.jobs import JobManager, QueueFullError
from barkgen.web.middleware import ACCESS_LOG, AccessKey, BodyLimit, BodyTooLarge, SameOrigin
from barkgen.web.relief import router as relief_routes
from barkgen.web.routes_cracks import router as crack_routes
from barkgen.web.routes_exemplars import router as exemplar_routes
from barkgen.web.routes_jobs import router as job_routes
from barkgen.web.routes_pages import router as page_routes
from barkgen.web.routes_results import router as result_routes
from barkgen.web.state import STATIC, AppState, WebAccess, WebLimits, is_loopback

__all__ = [
    "AccessKey",
    "AppState",
    "BodyLimit",
    "BodyTooLarge",
    "SameOrigin",
    "WebAccess",
    "WebLimits",
    "allowed_hosts",
    "build_server",
    "create_app",
    "is_loopback",
    "serve",
    "served_address",
]

#: barkgen's errors as HTTP status codes (the most specific class that matches wins)
ERROR_STATUS = {NotFoundError: 404, ImageTooLargeError: 413, QueueFullError: 429, BarkgenError: 400}


def allowed_hosts(host: str) -> list[str] | None:
    """The Host names a server bound to ``host`` answers: loopback names, plus ``host``
    itself; None (any) when it listens on every address."""
    if host in ("0.0.0.0", "::", ""):
        return None
    return sorted({"127.0.0.1", "localhost", "::1", host.strip("[]")})


def served_address(host: str, port: int, token: str | None = None) -> str:
    """The address ``barkgen serve`` prints: this machine's for a server on every address,
    with ``?token=KEY`` when it has a key (as Jupyter's; the first visit moves the key to a
    cookie)."""
    shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host.strip("[]")
    shown = f"[{shown}]" if ":" in shown else shown
    return f"http://{shown}:{port}/" + (f"?token={token}" if token else "")


def _answer_error(status: int):
    async def answer(request: Request, exc: BarkgenError) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=status)

    return answer


async def _answer_invalid_request(request, exc) -> JSONResponse:
    """422 with FastAPI's own detail, minus the values it echoes: a NaN seed or an exemplar id
    of 1e400 cannot be written as JSON, and the default answer to them was a 500 (and a
    traceback in the log). Each error keeps where and what; the input is left out."""
    detail = [{key: value for key, value in error.items() if key in ("loc", "msg", "type")} for error in exc.errors()]
    return JSONResponse(status_code=422, content={"detail": detail})


def create_app(
    library: Library,
    *,
    limits: WebLimits | None = None,
    run_jobs: bool = True,
    hosts: list[str] | None = None,
    access: WebAccess | None = None,
) -> FastAPI:
    """The app on ``library``. ``run_jobs=False`` queues jobs without running them (tests);
    ``hosts``: the Host names it answers (None: any; :func:`serve` passes
    :func:`allowed_hosts`); ``access``: its key and read-only mode (default: on loopback, no
    key; :func:`serve` passes ``WebAccess(host, ...)``, so the bind decides)."""
    access = access or WebAccess()
    state = AppState(library=library, jobs=JobManager(library), limits=limits or WebLimits(), access=access)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        if run_jobs:
            state.jobs.start()
        yield
        state.jobs.stop()

    # no /docs or /redoc: FastAPI's pages load their scripts from a CDN, and the app works
    # offline and loads nothing from elsewhere; the schema itself stays at /openapi.json
    app = FastAPI(
        title="barkgen",
        lifespan=lifespan,
        docs_url=None,
        redoc_url=None,
        description="Bark textures from one photo: library, jobs, results.",
    )
    app.state.barkgen = state
    app.state.library = library
    app.state.jobs = state.jobs
    app.mount("/static", StaticFiles(directory=STATIC), name="static")

    # a painted level arrives as base64 in JSON: a third larger than its PNG
    body_limit = state.limits.max_upload_bytes * 4 // 3 + 1024**2
    app.add_middleware(BodyLimit, limit=body_limit, detail=state.limits.upload_too_large)
    app.add_middleware(SameOrigin, hosts=hosts)
    app.add_middleware(AccessKey, access=access)  # the outermost: no key, nothing else is read

    @app.get("/api/server")
    def server_settings() -> dict:
        """What the pages adapt to: ``read_only`` (they hide what would be refused)."""
        return {"read_only": access.read_only}

    for error, status in ERROR_STATUS.items():
        app.add_exception_handler(error, _answer_error(status))
    app.add_exception_handler(RequestValidationError, _answer_invalid_request)

    for router in (page_routes, exemplar_routes, crack_routes, job_routes, result_routes, relief_routes):
        app.include_router(router)
    return app


def build_server(
    library: Library,
    host: str = "127.0.0.1",
    port: int = 8000,
    *,
    limits: WebLimits | None = None,
    access: WebAccess | None = None,
    on_ready=None,
):
    """The uvicorn server of :func:`serve`, not yet started. ``access``: defaults to
    ``WebAccess(host)`` (a random key beyond loopback). uvicorn's own access log is off (it
    writes the query, where a key may be): the app's access lines go to :mod:`barkgen.web.middleware`'s logger,
    shown on stderr."""
    import uvicorn

    access = access or WebAccess(host)
    app = create_app(library, limits=limits, hosts=allowed_hosts(host), access=access)
    # the worker starts with the server and makes a new photo's label map, then the analysis of
    # the page's defaults, before they are asked for
    app.state.barkgen.jobs.eager = True
    # open event streams must not hold a Ctrl-C: they are cut after 2 s
    config = uvicorn.Config(
        app, host=host, port=port, log_level="warning", access_log=False, timeout_graceful_shutdown=2
    )
    server = uvicorn.Server(config)
    app.state.barkgen.should_exit = lambda: server.should_exit
    if not ACCESS_LOG.handlers:
        shown = logging.StreamHandler(sys.stderr)
        shown.setFormatter(logging.Formatter("barkgen: %(asctime)s %(message)s", "%Y-%m-%dT%H:%M:%S%z"))
        ACCESS_LOG.addHandler(shown)
        ACCESS_LOG.setLevel(logging.INFO)

    if on_ready is not None:
        original = server.startup

        async def startup(sockets=None):
            await original(sockets=sockets)
            if server.started:
                bound = port or next(
                    (s.getsockname()[1] for srv in getattr(server, "servers", []) for s in srv.sockets), port
                )
                on_ready(served_address(host, bound, access.token))

        server.startup = startup  # type: ignore[method-assign]  # wrapped: uvicorn has no on-listening hook
    return server


def serve(
    library: Library,
    host: str = "127.0.0.1",
    port: int = 8000,
    *,
    limits: WebLimits | None = None,
    access: WebAccess | None = None,
    on_ready=None,
) -> None:
    """Run the app with uvicorn until interrupted (:func:`build_server`). ``on_ready(url)`` is
    called once it listens, with the address to open (its key included)."""
    asyncio.run(build_server(library, host, port, limits=limits, access=access, on_ready=on_ready).serve())
