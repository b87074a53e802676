"""The web app's exemplars: the library's photos listed, uploaded, shown (at display and
thumbnail size, JPEG) and removed, and each photo's input label map in the label colours (the
regions synthesis follows, laitoch2018 §1), made by a label job in the worker when first
asked for (``POST .../labels``), never inside a request.

Each endpoint wraps a plain function of the same module that takes the app's
:class:`~barkgen.web.state.AppState`; they raise barkgen's errors, which :mod:`barkgen.web.app`
answers with their HTTP codes.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path

from fastapi import APIRouter, File, Form, UploadFile
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import JSONResponse

from barkgen.errors import ImageTooLargeError, InvalidInputError
from barkgen.io import decode_image, encode_png
from barkgen.labels import label_colour_map
from barkgen.library import NotFoundError
from barkgen.web.routes_results import result_summary
from barkgen.web.state import DISPLAY_SIDE, THUMBNAIL_SIDE, WEB_K, AppState, State, cached_response, labels_key

router = APIRouter()

#: how a zip file starts
ZIP_MAGIC = b"PK\x03\x04"
#: a zipped set's images may unpack to this many times the upload limit
ZIP_UNPACK_FACTOR = 4


def exemplar_json(exemplar) -> dict:
    """An exemplar as the API shows it: its record and the URLs of its pictures."""
    return {
        **exemplar.to_dict(),
        "photo_url": f"/api/exemplars/{exemplar.id}/photo",
        "thumbnail_url": f"/api/exemplars/{exemplar.id}/thumbnail.jpg",
    }


def all_exemplars(state: AppState) -> list[dict]:
    return [exemplar_json(e) for e in state.library.exemplars()]


def store_upload(
    state: AppState,
    data: bytes,
    filename: str | None,
    *,
    name: str | None = None,
    species: str | None = None,
    licence: str | None = None,
) -> dict:
    """Add an uploaded photo, or a zip of a scanned material set, to the library: ``{"id",
    "existing"}``, ``existing`` true when the same photo (or the same set) is there already (its
    entry is answered, nothing is added); a set is never merged into a photo of its colour. The client's file name is only a default display name: it
    never touches the filesystem."""
    limits = state.limits
    if len(data) > limits.max_upload_bytes:
        raise ImageTooLargeError(limits.upload_too_large)
    if data[:4] == ZIP_MAGIC:
        return _store_set(state, data, filename, name=name, species=species, licence=licence)
    display = (name or Path(filename or "").stem or "uploaded bark").strip()[:200]
    with state.upload_lock:
        existing = state.library.find_exemplar(data)
        if existing is not None:
            return {"id": existing.id, "existing": True}
        exemplar = state.library.add_exemplar(
            data,
            display,
            species=species or None,
            licence=licence or None,
            source="uploaded",
            max_pixels=limits.max_upload_pixels,
        )
    if state.jobs.eager:  # the page asks for it next: its label job starts now
        from barkgen.pipeline import GenerateOptions
        from barkgen.web.jobs import QueueFullError

        defaults = GenerateOptions()
        try:
            request_labels(state, exemplar.id, defaults.k, defaults.method)
        except QueueFullError:  # the photo is stored: the upload succeeded; its page asks again
            pass
    return {"id": exemplar.id, "existing": False}


def _store_set(state: AppState, data: bytes, filename: str | None, *, name, species, licence) -> dict:
    """Add a zip of a scanned set (:meth:`~barkgen.library.Library.add_scanned_set`): named
    after the set (``Bark001``) unless ``name`` is given, an entry of its own even when a photo
    (or another set) of the same colour is in the library; the same zip again is its entry.
    ``left_out``: a line for each file of the zip the set is made without, where there are any."""
    from barkgen.io import read_set_zip

    where = Path(filename or "").name or "the zip"
    # a zip of images barely compresses: its images are allowed a few times the upload's bytes
    files = read_set_zip(data, max_unpacked_bytes=ZIP_UNPACK_FACTOR * state.limits.max_upload_bytes, where=where)
    with state.upload_lock, warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        before = {e.id for e in state.library.exemplars()}
        exemplar = state.library.add_scanned_set(
            files,
            (name or "").strip()[:200] or None,
            species=species or None,
            licence=licence or None,
            source="uploaded set",
            max_pixels=state.limits.max_upload_pixels,
            where=where,
        )
    # one line per file of the zip the set was made without (the page shows them)
    left_out = [str(w.message) for w in said if issubclass(w.category, UserWarning)]
    return {"id": exemplar.id, "existing": exemplar.id in before, **({"left_out": left_out} if left_out else {})}


def exemplar_details(state: AppState, exemplar_id: int) -> dict:
    """An exemplar with the summaries of its results."""
    exemplar = state.library.exemplar(exemplar_id)
    return {**exemplar_json(exemplar), "results": [result_summary(r) for r in state.library.results(exemplar_id)]}


def delete_exemplar(state: AppState, exemplar_id: int) -> dict:
    """Remove an exemplar, its results and its jobs (queued or running ones are cancelled)."""
    state.library.exemplar(exemplar_id)
    state.jobs.cancel_exemplar(exemplar_id)
    state.library.remove_exemplar(exemplar_id)
    return {"removed": exemplar_id}


def preview_jpeg(state: AppState, exemplar_id: int, side: int) -> bytes:
    """The photo at most ``side`` px a side as a JPEG, cached in the library's analyses."""
    library = state.library
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


def _check_labels(k: int, method: str) -> None:
    from barkgen.pipeline import LABEL_METHODS

    if not WEB_K[0] <= k <= WEB_K[1]:
        raise InvalidInputError(f"k must be between {WEB_K[0]} and {WEB_K[1]}")
    if method not in LABEL_METHODS:
        raise InvalidInputError(f"method must be one of {', '.join(LABEL_METHODS)}, not {method!r}")


def request_labels(state: AppState, exemplar_id: int, k: int, method: str = "color") -> dict:
    """Ask for the photo's input label map of ``k`` labels (2 to 8, the page's choice) by
    ``method``: its ``url`` and, while it is being made, its label ``job`` (queued in the
    worker, cancellable; None once the map is in the library's analyses). Asking again while
    it is made returns the same job."""
    _check_labels(k, method)
    state.library.exemplar(exemplar_id)
    url = f"/api/exemplars/{exemplar_id}/labels.png?k={k}&method={method}"
    if state.library.analysis(exemplar_id, "labels_in", labels_key(k, method)) is not None:
        return {"k": k, "method": method, "url": url, "job": None}
    prefetch = None
    if state.jobs.eager:  # the label map of the page's defaults: their analysis follows it
        from barkgen.web.routes_jobs import page_default_options

        defaults = page_default_options()
        prefetch = defaults if (defaults["k"], defaults["method"]) == (k, method) else None
    job = state.jobs.submit_labels(exemplar_id, k, labels_key(k, method), method, prefetch=prefetch)
    return {"k": k, "method": method, "url": url, "job": state.jobs.snapshot(job.id)}


def coloured_labels(state: AppState, exemplar_id: int, k: int, method: str = "color") -> bytes:
    """The photo's input label map of ``k`` labels by ``method`` in the label colours, as a
    PNG, once it is made (:func:`request_labels`; :class:`~barkgen.library.NotFoundError`
    before)."""
    _check_labels(k, method)
    state.library.exemplar(exemplar_id)
    grey = state.library.analysis(exemplar_id, "labels_in", labels_key(k, method))
    if grey is None:
        raise NotFoundError(
            f"the label map of {k} labels is not made yet: POST /api/exemplars/{exemplar_id}/labels?k={k} first"
        )
    return encode_png(label_colour_map(decode_image(grey, "labels")[..., 0]))


def bark_kinds(state: AppState, exemplar_id: int) -> dict:
    """Which kinds of bark the photo suits, each ``{"suits": bool, "why": sentence}``: its
    regions in new shapes (any photo), a crack network grown anew (where the photo has one:
    its network is extracted, sibbing2010 §3) and a bi-layer texture (any photo; guingo2017).
    Cached in the library's analyses."""
    import json

    library = state.library
    key = {"version": 1}
    cached = library.analysis(exemplar_id, "kinds", key)
    if cached is not None:
        return json.loads(cached)
    from barkgen.branching import extract_structure
    from barkgen.errors import BarkgenError

    photo = library.photo(exemplar_id)
    try:
        cracks = extract_structure(photo)
        share = cracks.total_length() / (photo.shape[0] * photo.shape[1]) * 1000
        crack = {
            "suits": True,
            "why": f"{len(cracks.branches)} crack branches found ({share:.0f} px of crack per 1000 px²); "
            "a new network with their bends, forks and merges is grown",
        }
    except BarkgenError as exc:
        crack = {"suits": False, "why": f"no crack network to grow from: {exc}"}
    kinds = {
        "labels": {"suits": True, "why": "the photo's regions (its label map) in new shapes"},
        "cracks": crack,
        "bilayer": {
            "suits": True,
            "why": "the photo's structure in new pieces plus fresh fine grain (best for speckled, "
            "lichen-covered or grainy bark)",
        },
    }
    library.put_analysis(exemplar_id, "kinds", key, json.dumps(kinds).encode())
    return kinds


# -- endpoints ------------------------------------------------------------------------------
@router.get("/api/exemplars")
def list_exemplars(state: State):
    return all_exemplars(state)


@router.post("/api/exemplars", status_code=201)
async def add_exemplar(
    state: State,
    file: UploadFile = File(...),
    name: str | None = Form(None),
    species: str | None = Form(None),
    licence: str | None = Form(None),
):
    data = await file.read(state.limits.max_upload_bytes + 1)
    answer = await run_in_threadpool(
        store_upload, state, data, file.filename, name=name, species=species, licence=licence
    )
    if answer["existing"]:  # the same photo again: its entry (the page says so)
        return JSONResponse(answer, status_code=200)
    return answer


@router.get("/api/exemplars/{exemplar_id}")
def get_exemplar(exemplar_id: int, state: State):
    return exemplar_details(state, exemplar_id)


@router.delete("/api/exemplars/{exemplar_id}")
def remove_exemplar(exemplar_id: int, state: State):
    return delete_exemplar(state, exemplar_id)


@router.get("/api/exemplars/{exemplar_id}/photo")
def exemplar_photo(exemplar_id: int, state: State):
    return cached_response(preview_jpeg(state, exemplar_id, DISPLAY_SIDE), "image/jpeg")


@router.get("/api/exemplars/{exemplar_id}/thumbnail.jpg")
def exemplar_thumbnail(exemplar_id: int, state: State):
    return cached_response(preview_jpeg(state, exemplar_id, THUMBNAIL_SIDE), "image/jpeg")


@router.post("/api/exemplars/{exemplar_id}/labels")
def exemplar_labels_request(exemplar_id: int, state: State, k: int = 3, method: str = "color"):
    return request_labels(state, exemplar_id, k, method)


@router.get("/api/exemplars/{exemplar_id}/labels.png")
def exemplar_labels(exemplar_id: int, state: State, k: int = 3, method: str = "color"):
    return cached_response(coloured_labels(state, exemplar_id, k, method), "image/png")


@router.get("/api/exemplars/{exemplar_id}/kinds")
def exemplar_kinds(exemplar_id: int, state: State):
    """Which kinds of bark (``structure`` / ``model``) the photo suits, and why."""
    return bark_kinds(state, exemplar_id)
