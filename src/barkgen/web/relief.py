"""The web app's relief editor (wang2003 §3.3, Fig. 6): height edits on a result, spread to the
self-similar places of the texture, answered at once so the page relights its trunk.

The page sends its whole edit list each time (``POST /api/results/{id}/relief``); the server
keeps, per result, the heights after the last edits it replayed, so a new edit costs one edit
(:class:`~barkgen.material.HeightEditor`) and an undo none. The answer is the edited height,
float32 little-endian, row by row.

The page's Depth and Photo light sliders change its views at once, on the page alone: it scales
the displacement and the normals' slopes, and relights the colour with the photo's broad light
(``GET /api/results/{id}/illumination``, fetched once) as
:meth:`barkgen.material.MaterialSet.relit_color` does. Saving is a job like any other: the
result's settings with ``relief_edits: {result_id, edits, relief, light_equalization}``
(:mod:`.routes_jobs`); its ``edits.json`` holds all of it, and ``barkgen generate --material
--edits`` replays it to the same bytes.
"""

from __future__ import annotations

import json
import threading
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
from fastapi import APIRouter
from fastapi.responses import Response
from pydantic import BaseModel

from barkgen.errors import InvalidInputError
from barkgen.io import decode_image
from barkgen.library import NotFoundError
from barkgen.material import Boundary, HeightEdit, HeightEditor, parse_edits
from barkgen.pipeline.files import ILLUMINATION_FILE
from barkgen.web.state import AppState, State

router = APIRouter()

#: results whose editing state is kept (each holds its texture's luminance and a few heights)
SESSIONS_KEPT = 2
#: bytes of edited heights kept per result (the last edits' heights: an undo costs nothing)
CHECKPOINT_BYTES = 256 * 2**20
#: the depth multipliers the page's Depth slider offers, of the result's own depth
RELIEF_RANGE = (0.25, 4.0)


class ReliefRequest(BaseModel):
    """The page's edit list (:func:`barkgen.material.parse_edits`'s items)."""

    edits: list[dict]


@dataclass
class ReliefSession:
    """One result's editor: its base height, and the heights after the first ``n`` edits of
    ``edits`` for the ``n`` in ``heights`` (0, the base, always)."""

    editor: HeightEditor
    edits: list[HeightEdit] = field(default_factory=list)
    heights: dict[int, np.ndarray] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def height_after(self, edits: list[HeightEdit]) -> np.ndarray:
        """The height after ``edits``, from the longest kept prefix they share."""
        with self.lock:
            shared = 0
            while shared < min(len(edits), len(self.edits)) and edits[shared] == self.edits[shared]:
                shared += 1
            start = max(n for n in self.heights if n <= shared)
            self.edits = list(edits)
            self.heights = {n: h for n, h in self.heights.items() if n <= start}
            self.editor.height = self.heights[start].copy()
            for n, edit in enumerate(edits[start:], start + 1):
                self.editor.edit(edit.x, edit.y, edit.delta, edit.radius, edit.threshold)
                self.heights[n] = self.editor.height.copy()
            keep = max(2, CHECKPOINT_BYTES // max(self.editor.height.nbytes, 1))
            for n in sorted(self.heights)[1:-keep]:  # the base and the last ``keep``
                del self.heights[n]
            return self.editor.height.copy()


def _material_name(files) -> str:
    name = next((n[: -len("_Displacement.png")] for n in files if n.endswith("_Displacement.png")), None)
    if name is None or f"{name}.json" not in files:
        raise InvalidInputError("this result has no height to edit: make it with material maps (ambientCG layout)")
    return name


def open_session(state: AppState, result_id: int) -> ReliefSession:
    """A result's relief session, made from its files (texture, output labels, displacement)."""
    sessions: OrderedDict = state.relief_sessions
    with state.relief_lock:
        session = sessions.get(result_id)
        if session is not None:
            sessions.move_to_end(result_id)
            return session
    library = state.library
    result = library.result(result_id)
    name = _material_name(result.files)
    meta = json.loads(library.result_file(result_id, f"{name}.json"))
    displacement = decode_image(library.result_file(result_id, f"{name}_Displacement.png"), "displacement")
    levels = np.asarray(displacement[..., 0] if displacement.ndim == 3 else displacement, np.float64)
    depth, midlevel = float(meta["displacement_depth_px"]), float(meta["displacement_midlevel"])
    height = ((levels / np.iinfo(displacement.dtype).max - midlevel) * depth).astype(np.float32)
    texture = decode_image(library.result_file(result_id, "texture.png"), "texture")
    labels = decode_image(library.result_file(result_id, "labels_out.png"), "labels")
    labels = labels[..., 0] if labels.ndim == 3 else labels
    editor = HeightEditor(texture, height, labels, boundary=Boundary(bool(result.params.get("tile"))))
    session = ReliefSession(editor, heights={0: height})
    with state.relief_lock:
        sessions[result_id] = session
        while len(sessions) > SESSIONS_KEPT:
            sessions.popitem(last=False)
    return session


def checked_edits(items: list[dict], size: tuple[int, int]) -> list[HeightEdit]:
    """The page's edit items as edits (an empty list is the base height), each inside a result
    of ``size`` ``(width, height)``."""
    edits = parse_edits({"version": 1, "edits": items}) if items else []
    width, height = size
    for i, edit in enumerate(edits):
        if not (0 <= edit.x < width and 0 <= edit.y < height):
            raise InvalidInputError(f"edit {i} at ({edit.x}, {edit.y}) is outside the {width}x{height} result")
    return edits


def checked_sliders(state: AppState, result, relief: float, light: float | None) -> tuple[float, float | None]:
    """The page's depth multiplier and photo light for a Save of ``result`` (a library
    result): the depth within :data:`RELIEF_RANGE`, the light in [0, 1] on a result that
    carries its photo's light (``illumination.png``); ``None`` for a light that is the
    result's own."""
    low, high = RELIEF_RANGE
    if not (np.isfinite(relief) and low <= relief <= high):
        raise InvalidInputError(f"the depth must be {low:g}x to {high:g}x the result's, not {relief:g}x")
    if light is None:
        return float(relief), None
    if not (np.isfinite(light) and 0.0 <= light <= 1.0):
        raise InvalidInputError(f"the photo light taken out must be 0 to 1, not {light:g}")
    meta = json.loads(state.library.result_file(result.id, f"{_material_name(result.files)}.json"))
    own = meta.get("light_equalization")
    if own is not None and abs(light - float(own)) < 5e-5:
        return float(relief), None
    if ILLUMINATION_FILE not in result.files:
        raise InvalidInputError(
            f"result {result.id} has no record of its photo's light (no {ILLUMINATION_FILE}: made before "
            "barkgen kept it), so its light cannot change"
        )
    return float(relief), float(light)


def illumination(state: AppState, result_id: int) -> tuple[np.ndarray, str]:
    """The photo's broad light ``L`` carried to a result (:func:`barkgen.material.decode_illumination`
    of its ``illumination.png``), float32, and its size as ``WxH``."""
    from barkgen.material import decode_illumination

    result = state.library.result(result_id)
    if ILLUMINATION_FILE not in result.files:
        raise NotFoundError(f"result {result_id} has no {ILLUMINATION_FILE} (made before barkgen kept the light)")
    light = decode_illumination(decode_image(state.library.result_file(result_id, ILLUMINATION_FILE), "illumination"))
    return light, f"{light.shape[1]}x{light.shape[0]}"


def edited_height(state: AppState, result_id: int, items: list[dict]) -> np.ndarray:
    """The result's height after the edits (pixels, float32)."""
    session = open_session(state, result_id)
    h, w = session.editor.shape
    return session.height_after(checked_edits(items, (w, h)))


@router.post("/api/results/{result_id}/relief")
def relief(result_id: int, request: ReliefRequest, state: State):
    """The result's height after the page's edits: float32 little-endian, row by row; its size
    in ``X-Height-Size`` (``WxH``)."""
    height = edited_height(state, result_id, request.edits)
    h, w = height.shape
    return Response(
        height.astype("<f4").tobytes(),
        media_type="application/octet-stream",
        headers={"X-Height-Size": f"{w}x{h}", "Cache-Control": "no-store"},
    )


@router.get("/api/results/{result_id}/illumination")
def result_illumination(result_id: int, state: State):
    """The photo's broad light carried to the result (what the page's Photo light slider puts
    back or takes out): float32 little-endian, row by row; its size in ``X-Height-Size``
    (``WxH``, as the relief's)."""
    light, size = illumination(state, result_id)
    return Response(
        light.astype("<f4").tobytes(),
        media_type="application/octet-stream",
        headers={"X-Height-Size": size, "Cache-Control": "max-age=3600"},
    )
