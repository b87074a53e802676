"""What the web app's routes share: its limits (:class:`WebLimits`), who may use it
(:class:`WebAccess`: the key and read-only mode), its state (:class:`AppState`: the library, the
job queue, the limits, the access), the FastAPI dependency that hands the state to an
endpoint (:func:`get_state`) and the few settings every route module reads.

The routes' plain functions take an :class:`AppState` as their first argument, so tests can call
them without a server: ``AppState(library, JobManager(library))``.
"""

from __future__ import annotations

import ipaddress
import re
import secrets
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

from fastapi import Depends, Request
from fastapi.responses import Response

from barkgen._shared.checks import MAX_PHOTO_PIXELS
from barkgen.errors import InvalidInputError
from barkgen.library import Library
from barkgen.pipeline import ANALYSIS_SEED
from barkgen.web.jobs import JobManager

STATIC = Path(__file__).parent / "static"
#: label maps of the photos are made the way `barkgen generate` makes them by default
LABEL_METHOD = "color"
#: the number of labels (k) the pages offer
WEB_K = (2, 8)
#: the photo as pages show it, and its thumbnail: at most this many px a side
DISPLAY_SIDE = 2048
THUMBNAIL_SIDE = 320


@dataclass(frozen=True)
class WebLimits:
    """Upload and job limits (defaults: 25 MB and 50 megapixels per upload; outputs up to
    4096 px a side)."""

    max_upload_bytes: int = 25 * 1024**2
    max_upload_pixels: int = MAX_PHOTO_PIXELS  # the largest photo a run analyses
    max_output_side: int = 4096

    @property
    def upload_too_large(self) -> str:
        """The one line an upload over :attr:`max_upload_bytes` is answered with."""
        return f"the upload is larger than the limit of {self.max_upload_bytes // 1024**2} MB"


#: a key is URL-safe (it travels in the printed address) and long enough not to be guessed
KEY_PATTERN = re.compile(r"[A-Za-z0-9_.~-]{16,256}")


def is_loopback(host: str) -> bool:
    """Whether a server bound to ``host`` is reachable from this machine only (127.0.0.0/8,
    ::1, ``localhost``); any other host, ``0.0.0.0`` and ``::`` above all, reaches a network."""
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return host == "localhost"


@dataclass(frozen=True)
class WebAccess:
    """Who may use the server: the key every request must carry (``token``; None: none) and
    whether it refuses every change (``read_only``: a library shared to viewers).

    The bind decides: a server on a host beyond loopback (:func:`is_loopback`) always has a
    key, a random one (``secrets.token_urlsafe``) unless ``token`` is given; on loopback it
    has one only when ``token`` is given. A ``token`` must be 16-256 URL-safe characters.
    """

    host: str = "127.0.0.1"
    token: str | None = None
    read_only: bool = False

    def __post_init__(self) -> None:
        token = self.token or None  # an empty BARKGEN_TOKEN is no token
        if token is not None and not KEY_PATTERN.fullmatch(token):
            raise InvalidInputError(
                "--token (or BARKGEN_TOKEN) must be 16-256 letters, digits or '-', '_', '.', '~' "
                f"(it goes in the address); this one has {len(token)} characters"
            )
        if token is None and not is_loopback(self.host):
            token = secrets.token_urlsafe(32)
        object.__setattr__(self, "token", token)

    def __repr__(self) -> str:  # the key never shows in a log or a traceback
        return f"WebAccess(host={self.host!r}, key={'yes' if self.token else 'no'}, read_only={self.read_only})"


@dataclass
class AppState:
    """The app's shared state: its library, its job queue, its limits and who may use it
    (``access``). ``should_exit``:
    true once the server is asked to stop (event streams end then; set by
    :func:`barkgen.web.serve`)."""

    library: Library
    jobs: JobManager
    limits: WebLimits = field(default_factory=WebLimits)
    access: WebAccess = field(default_factory=WebAccess)
    should_exit: Callable[[], bool] = lambda: False
    #: uploads look up and add their photo under it, so one photo uploaded ten times at once
    #: is added once and nine answers say it was there
    upload_lock: threading.Lock = field(default_factory=threading.Lock, repr=False)
    #: the relief editor's open results (:mod:`barkgen.web.relief`), the oldest first, and
    #: their lock
    relief_sessions: OrderedDict = field(default_factory=OrderedDict, repr=False)
    relief_lock: threading.Lock = field(default_factory=threading.Lock, repr=False)


def get_state(request: Request) -> AppState:
    """FastAPI dependency: the :class:`AppState` of the app serving ``request``."""
    return request.app.state.barkgen


#: an endpoint parameter of this type receives the app's state
State = Annotated[AppState, Depends(get_state)]


def name_slug(name: str, fallback: str = "bark") -> str:
    """A photo's name as a file-name part: letters, digits and dashes, at most 40."""
    import re

    return re.sub(r"[^A-Za-z0-9]+", "-", name).strip("-").lower()[:40] or fallback


def labels_key(k: int, method: str = LABEL_METHOD) -> dict:
    """The analysis key of a photo's input label map of ``k`` labels by ``method`` in the library."""
    return {"k": k, "method": method, "seed": ANALYSIS_SEED}


def cached_response(data: bytes, media_type: str) -> Response:
    """``data`` as a response the browser may keep for an hour (files of the library never
    change under their URL)."""
    return Response(data, media_type=media_type, headers={"Cache-Control": "max-age=3600"})
