"""The web app's jobs: a generate request checked and queued (:func:`start_job`), optionally
continuing a result from a label-map level the user painted (the large-scale pattern steered
by hand, laitoch2018 §1) or learning a crack network the user edited (sibbing2010 §6), then followed (its JSON, or server-sent events) and cancelled.

Each endpoint wraps a plain function of the same module that takes the app's
:class:`~barkgen.web.state.AppState`; they raise barkgen's errors, which :mod:`barkgen.web.app`
answers with their HTTP codes. The request's numbers are checked by
:class:`~barkgen.pipeline.GenerateOptions`, the server's own limits here.
"""

from __future__ import annotations

import asyncio
import base64
import binascii
import json
import re
import secrets
import warnings
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from fastapi import APIRouter, Request
from fastapi.responses import StreamingResponse
from pydantic import BaseModel, Field, create_model

from barkgen._shared.checks import parse_size
from barkgen._shared.options import OptionField, option_fields, option_schema
from barkgen.errors import InvalidInputError
from barkgen.io import AlphaDroppedWarning, decode_image
from barkgen.io.asset_names import asset_slug, base_name, material_set_name, variant_name
from barkgen.labels.preview import label_colours
from barkgen.library import NotFoundError
from barkgen.material.presets import PRESETS
from barkgen.pipeline import GenerateOptions
from barkgen.web.jobs import FINISHED
from barkgen.web.routes_cracks import checked_structure
from barkgen.web.state import WEB_K, AppState, State, WebLimits, labels_key

router = APIRouter()


class ResumeRequest(BaseModel):
    result_id: int
    level: int = Field(ge=0)
    labels: str  # data:image/png;base64,...


class ReliefSaveRequest(BaseModel):
    """A result's relief edits to replay on it, and the depth and photo light its sliders chose
    (the relief editor's Save)."""

    result_id: int
    edits: list[dict]
    #: the depth, a multiple of the result's own (:data:`barkgen.web.relief.RELIEF_RANGE`)
    relief: float = 1.0
    #: how much of the photo's broad light is out of the colour, 0 to 1 (``None``: the result's own)
    light_equalization: float | None = None


#: the web app's defaults where they are not GenerateOptions' own (the CLI's), each on purpose:
#: a seed of None (a random one: each Generate a new bark, where the CLI's 0 repeats one) and
#: the material set on (the set is what the page is for, as ``scripts/quickstart.sh`` makes it
#: with ``--material``); ``tests/web/test_web_names.py`` holds the form to exactly these
WEB_DEFAULTS: dict[str, Any] = {"seed": None, "material": True}


def job_request_model(options_class: type = GenerateOptions) -> type[BaseModel]:
    """The generate request's schema: the exemplar, a painted level to continue from, and every
    field of ``options_class`` the web offers (:mod:`barkgen._shared.options`) with its help,
    range and the web's default."""
    fields: dict = {
        "exemplar_id": (int, ...),
        "resume": (ResumeRequest | None, None),
        "relief_edits": (ReliefSaveRequest | None, None),
        "preset": (Literal[PRESETS], Field(default="ambientcg", description="The material set's file layout.")),
        "crack_structure": (
            dict | None,
            Field(
                default=None,
                description="With structure 'cracks': the photo's crack network as edited in the crack view "
                "(structure JSON of the photo's size), learned from instead of the extracted one.",
            ),
        ),
    }
    for f in option_fields(options_class, "web"):
        default = WEB_DEFAULTS.get(f.name, f.default_text)
        kind: Any = Literal[f.info.choices] if f.info.choices else f.info.kind
        kind = kind if default is not None else kind | None
        limits: dict[str, Any] = {}
        if f.info.kind in (int, float):
            limits = {"ge": f.info.minimum, "le": f.info.maximum}
        if f.name == "seed":
            limits["lt"] = 2**63
        fields[f.name] = (kind, Field(default=default, description=f.info.help, **limits))
    return create_model("JobRequest", **fields)


if TYPE_CHECKING:  # create_model's class: its fields are known at run time only
    JobRequest = Any
else:
    JobRequest = job_request_model()


def _shown(field: OptionField, value):
    """An option's value as the job's JSON shows it (a light as ``"AZ,EL"``)."""
    return field.info.text(value) if field.info.text is not None and value is not None else value


def request_options(request: BaseModel, options_class: type = GenerateOptions, **given) -> dict:
    """The ``options_class`` keywords of a request: each web field read from its text (a size,
    a light), ``given`` in place of the request's own."""
    return {
        f.name: given[f.name] if f.name in given else f.read(getattr(request, f.name))
        for f in option_fields(options_class, "web")
    }


def page_default_options() -> dict:
    """The :class:`~barkgen.pipeline.GenerateOptions` keywords of a generate request with the
    page's defaults (seed 0): the analysis most first jobs of a photo need."""
    return request_options(JobRequest(exemplar_id=0), seed=0)


def check_size(limits: WebLimits, text: str) -> tuple[int, int]:
    """``"WxH"`` as ``(height, width)``, within the server's largest output side."""
    height, width = parse_size(text)
    if max(width, height) > limits.max_output_side:
        raise InvalidInputError(f"size {text} is larger than this server's limit of {limits.max_output_side} px a side")
    return height, width


def _painted_codes(painted: np.ndarray, count: int) -> np.ndarray:
    """The label index of each painted pixel: its colour's place among the ``count`` label
    colours; a pixel of any other colour is refused."""
    if painted.dtype != np.uint8:
        raise InvalidInputError("the painted labels must be an 8-bit PNG")
    rgb = np.broadcast_to(painted, painted.shape[:2] + (3,))
    codes = np.full(rgb.shape[:2], -1, np.int64)
    for index, colour in enumerate(label_colours(count)):
        codes[(rgb == colour).all(-1)] = index
    off = codes < 0
    if off.any():
        y, x = np.argwhere(off)[0]
        raise InvalidInputError(
            f"the painted pixel at x={x}, y={y} has colour {tuple(int(c) for c in rgb[y, x])}, "
            "which is no label's colour; paint with the palette only"
        )
    return codes


def painted_level(state: AppState, request: ResumeRequest, exemplar_id: int, params: dict) -> tuple[int, np.ndarray]:
    """The painted level as a label map of the parent result's label values."""
    library = state.library
    parent = library.result(request.result_id)
    if parent.exemplar_id != exemplar_id:
        raise InvalidInputError(f"result {parent.id} belongs to exemplar {parent.exemplar_id}, not {exemplar_id}")
    if [params["size"][0], params["size"][1], params["k"]] != [*parent.params["size"], parent.params["k"]]:
        raise InvalidInputError("continuing a result keeps its size and k")
    level_name = f"level_{request.level}.png"
    if level_name not in parent.files:
        raise InvalidInputError(f"result {parent.id} has no label-map level {request.level}")
    match = re.fullmatch(r"data:image/png;base64,([A-Za-z0-9+/=\s]+)", request.labels)
    if not match:
        raise InvalidInputError("the painted labels must be a PNG data URL (data:image/png;base64,...)")
    try:
        data = base64.b64decode(match.group(1), validate=False)
    except (binascii.Error, ValueError):
        raise InvalidInputError("the painted labels are not valid base64") from None
    with warnings.catch_warnings():  # a canvas PNG has alpha, which says nothing here
        warnings.simplefilter("ignore", AlphaDroppedWarning)
        painted = decode_image(data, "the painted labels", max_pixels=state.limits.max_upload_pixels)
    level = decode_image(library.result_file(parent.id, level_name), "level")[..., 0]
    if painted.shape[:2] != level.shape:
        raise InvalidInputError(
            f"the painted labels are {painted.shape[1]}x{painted.shape[0]} px but level "
            f"{request.level} is {level.shape[1]}x{level.shape[0]} px"
        )
    values = np.unique(decode_image(library.result_file(parent.id, "labels_in.png"), "labels"))
    codes = _painted_codes(painted, values.size)
    return request.level, values[codes].astype(level.dtype)


def relief_edits(state: AppState, request: ReliefSaveRequest, exemplar_id: int, params: dict) -> dict:
    """The relief editor's Save of a result, checked against it (same photo, size, material
    maps), as the JSON document of its edit list (``edits.json``,
    :func:`barkgen.material.parse_edit_list`): the height edits, then the depth and the light.

    A result sculpted or adjusted before is saved from its own run: its edit list comes first,
    the new edits' deltas in its run's heights (divided by its depth multiplier), the depth
    multipliers multiplied and the light the one chosen last."""
    import dataclasses

    from barkgen.material import EditList, edits_document, parse_edit_list
    from barkgen.web.relief import checked_edits, checked_sliders

    parent = state.library.result(request.result_id)
    if parent.exemplar_id != exemplar_id:
        raise InvalidInputError(f"result {parent.id} belongs to exemplar {parent.exemplar_id}, not {exemplar_id}")
    if params["size"] != list(parent.params["size"]) or not params["material"]:
        raise InvalidInputError("saving a relief keeps the result's size and its material maps")
    edits = checked_edits(request.edits, tuple(params["size"]))
    relief, light = checked_sliders(state, parent, request.relief, request.light_equalization)
    if not edits and relief == 1.0 and light is None:
        raise InvalidInputError("there is no relief edit, depth or light change to save")
    before = EditList()
    if "edits.json" in parent.files:  # a result sculpted before: its edits first, then these
        before = parse_edit_list(json.loads(state.library.result_file(parent.id, "edits.json")))
    if before.relief != 1.0:  # the page edited heights already deepened by the parent's relief
        edits = [dataclasses.replace(e, delta=e.delta / before.relief) for e in edits]
    return edits_document(
        [*before.edits, *edits],
        relief=before.relief * relief,
        light_equalization=light if light is not None else before.light_equalization,
    )


def set_names(
    photo_name: str, seed: int, edits: dict | None = None, resume: tuple[int, np.ndarray] | None = None
) -> tuple[str, str]:
    """A web result's asset name and variant (:mod:`barkgen.io.asset_names`): the photo's name
    made file-safe, and the seed, the relief edits' tag where it replays some (``seed7-edit3f9a1c``)
    and a painted label map's (``-paint`` and six hex digits of the painted level's digest), so
    that no two results of one photo share a name."""
    import hashlib

    variant = variant_name(seed, edits) or f"seed{seed}"
    if resume is not None:
        level, labels = resume
        array = np.ascontiguousarray(labels)
        digest = hashlib.sha256(f"{level}:{array.shape}:{array.dtype.str}:".encode() + array.tobytes())
        variant += f"-paint{digest.hexdigest()[:6]}"
    return asset_slug(photo_name), variant


def start_job(state: AppState, request: JobRequest) -> dict:
    """Check a generate request and queue it: ``{"id": job id}``. A request without a seed gets
    a random one (the job's params say which)."""
    library = state.library
    exemplar = library.exemplar(request.exemplar_id)
    height, width = check_size(state.limits, request.size)
    seed = request.seed if request.seed is not None else secrets.randbelow(100_000)
    values = request_options(request, size=(height, width), seed=seed)
    options = GenerateOptions(**values)
    if not WEB_K[0] <= options.k <= WEB_K[1]:
        raise InvalidInputError(f"k must be between {WEB_K[0]} and {WEB_K[1]}")
    params = {
        "size": [width, height],
        "k": options.k,
        "tile": options.tile,
        "seed": seed,
        "material": options.material,
        "resumed_from": None,
    }
    # the other options, where the request changed them
    params.update(
        {
            f.name: _shown(f, getattr(options, f.name))
            for f in option_fields(GenerateOptions, "web")
            if f.name not in params and getattr(options, f.name) != f.default
        }
    )
    resume = None
    if request.resume is not None:
        resume = painted_level(state, request.resume, exemplar.id, params)
        params["resumed_from"] = {"result_id": request.resume.result_id, "level": resume[0]}
    parent_id = request.resume.result_id if request.resume is not None else None
    edits = None
    if request.relief_edits is not None:
        parent_id = request.relief_edits.result_id
        edits = relief_edits(state, request.relief_edits, exemplar.id, params)
        params["relief_from"] = {
            "result_id": request.relief_edits.result_id,
            "edits": len(edits["edits"]),
            **{k: edits[k] for k in ("relief", "light_equalization") if k in edits},
        }
    # the photo's label map when a page has made it already (else the worker makes it); cracks
    # and bi-layer textures have label maps of their own (barkgen.pipeline.variants), and one with
    # another share of the photo's light out is not the pages' (the label job's, the default)
    plain = (
        options.structure == "labels"
        and options.model == "patches"
        and options.equalize_light == GenerateOptions().equalize_light
    )
    key = labels_key(options.k, options.method)
    grey = library.analysis(exemplar.id, "labels_in", key) if plain else None
    if request.preset != "ambientcg":
        params["preset"] = request.preset
    cracks = None
    if request.crack_structure is not None:
        if options.structure != "cracks":
            raise InvalidInputError("crack_structure goes with structure 'cracks' only")
        cracks = checked_structure(state, exemplar.id, request.crack_structure).to_dict()
        params["crack_structure"] = {"edited": True, "branches": len(cracks["branches"])}
    asset, variant = set_names(exemplar.name, seed, edits, resume)
    params["set_name"] = material_set_name(base_name(asset, variant), (height, width))
    spec = {
        "source": exemplar.name,
        "asset": asset,
        "variant": variant,
        "licence": exemplar.licence,
        "options": values,
        "labels_in": grey,
        "resume": resume,
        "preset": request.preset,
        "edits": edits,
        "crack_structure": cracks,
    }
    job = state.jobs.submit(
        exemplar.id,
        params,
        spec,
        parent_id=parent_id,
        labels_key=key if plain and grey is None else None,
    )
    return {"id": job.id}


def job_snapshot(state: AppState, job_id: str) -> dict:
    """The job as the API shows it; :class:`~barkgen.library.NotFoundError` when it is unknown."""
    snapshot = state.jobs.snapshot(job_id)
    if snapshot is None:
        raise NotFoundError(f"no job {job_id}")
    return snapshot


def stop_job(state: AppState, job_id: str) -> dict | None:
    """Cancel a queued or running job (a finished one stays as it is): the job's JSON."""
    job_snapshot(state, job_id)
    return state.jobs.cancel(job_id)


async def job_event_stream(
    state: AppState, snapshot: dict, is_disconnected: Callable[[], Awaitable[bool]]
) -> AsyncIterator[str]:
    """Server-sent events of a job (``snapshot``: its JSON now): its JSON on every change (or
    every 10 s, to keep the stream alive) until it is finished, the server stops or the page
    goes (``is_disconnected``)."""
    job_id = snapshot["id"]
    current, sent_at = snapshot, asyncio.get_running_loop().time()
    yield f"data: {json.dumps(current)}\n\n"
    while current["state"] not in FINISHED:
        # poll without holding a thread: any number of pages may watch
        await asyncio.sleep(0.1)
        if state.jobs.stopping or state.should_exit() or await is_disconnected():
            return
        latest = state.jobs.snapshot(job_id)
        if latest is None:
            return
        now = asyncio.get_running_loop().time()
        if latest["version"] != current["version"] or now - sent_at > 10:  # or keep-alive
            current, sent_at = latest, now
            yield f"data: {json.dumps(current)}\n\n"


# -- endpoints ------------------------------------------------------------------------------
def web_options(state: AppState, options_class: type = GenerateOptions) -> dict:
    """What the generate form offers, the source of its fields (``exemplar.js`` builds a control
    for every option it has none of its own for): every option of
    :class:`~barkgen.pipeline.GenerateOptions` the web has, with its kind, default (the CLI's
    own), range, choices, help, form group and the option it needs
    (:func:`barkgen._shared.options.option_schema`); the server's largest output side, the k
    the pages offer and the material set's layouts."""
    return {
        "fields": option_schema(options_class, "web", WEB_DEFAULTS),
        "max_output_side": state.limits.max_output_side,
        "k_range": list(WEB_K),
        "presets": list(PRESETS),
    }


@router.get("/api/options")
def get_options(state: State):
    return web_options(state)


@router.post("/api/jobs", status_code=201)
def submit_job(request: JobRequest, state: State):
    return start_job(state, request)


@router.get("/api/jobs")
def list_jobs(state: State):
    return state.jobs.list()


@router.get("/api/jobs/{job_id}")
def get_job(job_id: str, state: State):
    return job_snapshot(state, job_id)


@router.delete("/api/jobs/{job_id}")
def cancel_job(job_id: str, state: State):
    return stop_job(state, job_id)


@router.get("/api/jobs/{job_id}/events")
async def job_events(job_id: str, request: Request, state: State):
    """Server-sent events: the job's JSON on every change, until it is finished."""
    snapshot = job_snapshot(state, job_id)
    return StreamingResponse(
        job_event_stream(state, snapshot, request.is_disconnected),
        media_type="text/event-stream",
        headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"},
    )
