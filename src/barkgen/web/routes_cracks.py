"""The web app's crack view (sibbing2010 §6, Fig. 8): a photo's crack network as a structure the
page draws over the photo, the user's edits of it (extend a branch, add a furcation, delete a
sub-branch), the photo rectified from four clicked corners as a new exemplar, and the edited
network checked for a cracks job, which learns from it instead of extracting the photo's.

Thin routes over :mod:`barkgen.branching.edit`: each endpoint wraps a plain function of this
module that takes the app's :class:`~barkgen.web.state.AppState` and raises barkgen's errors,
which :mod:`barkgen.web.app` answers with their HTTP codes. The page keeps the undo history
(the structures it was answered); the server keeps nothing but the extracted network, cached in
the library's analyses.
"""

from __future__ import annotations

import json
from typing import Literal

from fastapi import APIRouter
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

from barkgen.errors import InvalidInputError
from barkgen.web.state import AppState, State

router = APIRouter()

#: the key of a photo's extracted crack network in the library's analyses
CRACKS_KEY = {"version": 1}
#: the most vertices an edited network may have (a 50 Mpx photo's network has ~10^5)
MAX_CRACK_VERTICES = 1_000_000


class CrackEditRequest(BaseModel):
    """One edit of the crack view: ``tool`` on ``structure`` at the clicked ``points``
    (photo pixels): extend (the branch near the first, to the second), furcation (from the
    branch near the first, to the second), delete (the branch near the only one)."""

    structure: dict
    tool: Literal["extend", "furcation", "delete"]
    points: list[tuple[float, float]] = Field(min_length=1, max_length=2)
    #: how far from a branch a click may be (photo pixels; the page sends a few screen pixels)
    tolerance: float = Field(default=16.0, gt=0, le=4096)


class RectifyRequest(BaseModel):
    """Four corners of a plane in the photo (photo pixels, in order around it) and the new
    exemplar's name (default: the photo's, rectified)."""

    corners: list[tuple[float, float]] = Field(min_length=4, max_length=4)
    name: str | None = Field(default=None, max_length=200)


def exemplar_cracks(state: AppState, exemplar_id: int) -> dict:
    """The photo's crack network as extracted (:func:`~barkgen.branching.extract_structure`,
    sibbing2010 §3), in its JSON form (:meth:`~barkgen.branching.Structure.to_dict`), cached in
    the library's analyses; :class:`~barkgen.errors.InvalidInputError` when it has none."""
    library = state.library
    library.exemplar(exemplar_id)
    cached = library.analysis(exemplar_id, "cracks", CRACKS_KEY)
    if cached is not None:
        return json.loads(cached)
    from barkgen.branching import extract_structure

    structure = extract_structure(library.photo(exemplar_id)).to_dict()
    library.put_analysis(exemplar_id, "cracks", CRACKS_KEY, json.dumps(structure).encode())
    return structure


def checked_structure(state: AppState, exemplar_id: int, data: object, where: str = "crack_structure"):
    """A crack network sent by a page, checked (:meth:`~barkgen.branching.Structure.from_dict`):
    of the photo's size, at most :data:`MAX_CRACK_VERTICES` vertices, not periodic."""
    from barkgen.branching import Structure

    exemplar = state.library.exemplar(exemplar_id)
    structure = Structure.from_dict(data, where)
    if structure.size != (exemplar.width, exemplar.height):
        raise InvalidInputError(
            f"{where}: size {structure.width}x{structure.height} is not the photo's "
            f"{exemplar.width}x{exemplar.height} px"
        )
    if structure.periodic:
        raise InvalidInputError(f"{where}: a photo's crack network is not periodic")
    if structure.n_vertices() > MAX_CRACK_VERTICES:
        raise InvalidInputError(f"{where}: more than {MAX_CRACK_VERTICES} vertices")
    return structure


def edit_cracks(state: AppState, exemplar_id: int, request: CrackEditRequest) -> dict:
    """Apply one edit to a crack network (:mod:`barkgen.branching.edit`, sibbing2010 §6):
    ``{"structure": the new network, "branch": the branch edited or added}``. The first
    point picks the branch (:func:`~barkgen.branching.nearest_branch`, within
    ``request.tolerance`` px); an extension runs from the picked branch's end nearer that
    point."""
    import numpy as np

    from barkgen.branching import add_furcation, delete_branch, extend_branch, nearest_branch

    structure = checked_structure(state, exemplar_id, request.structure, "structure")
    wanted = 1 if request.tool == "delete" else 2
    if len(request.points) != wanted:
        raise InvalidInputError(f"{request.tool} takes {wanted} point(s), got {len(request.points)}")
    first = request.points[0]
    index, distance = nearest_branch(structure, first)
    if distance > request.tolerance:
        raise InvalidInputError(
            f"no branch within {request.tolerance:g} px of ({first[0]:g}, {first[1]:g}): click on a crack"
        )
    if request.tool == "delete":
        edited, branch = delete_branch(structure, index), None
    elif request.tool == "furcation":
        edited = add_furcation(structure, index, first, request.points[1])
        branch = len(edited.branches) - 1
    else:
        xy = structure.branches[index].xy
        end: Literal["start", "end"] = "start" if np.hypot(*(xy[0] - first)) < np.hypot(*(xy[-1] - first)) else "end"
        edited, branch = extend_branch(structure, index, request.points[1], end=end), index
    return {"structure": edited.to_dict(), "branch": branch, "picked": index}


def rectify_exemplar(state: AppState, exemplar_id: int, request: RectifyRequest) -> dict:
    """The photo rectified from four clicked corners (:func:`~barkgen.branching.rectify_perspective`,
    sibbing2010 Fig. 8) added to the library as a new exemplar with the photo's species and
    licence: ``{"id", "existing"}`` as an upload answers."""
    from barkgen.branching import rectify_perspective
    from barkgen.io import encode_png

    library = state.library
    exemplar = library.exemplar(exemplar_id)
    rectified = rectify_perspective(library.photo(exemplar_id), request.corners)
    data = encode_png(rectified)
    name = (request.name or "").strip() or f"{exemplar.name} (rectified)"[:200]
    with state.upload_lock:
        existing = library.find_exemplar(data)
        if existing is not None:
            return {"id": existing.id, "existing": True}
        added = library.add_exemplar(
            data,
            name,
            species=exemplar.species,
            bark_type=exemplar.bark_type,
            licence=exemplar.licence,
            source=f"rectified from {exemplar.name}"[:500],
            max_pixels=state.limits.max_upload_pixels,
        )
    return {"id": added.id, "existing": False}


# -- endpoints ------------------------------------------------------------------------------
@router.get("/api/exemplars/{exemplar_id}/cracks")
def get_cracks(exemplar_id: int, state: State):
    """The photo's extracted crack network (structure JSON)."""
    return exemplar_cracks(state, exemplar_id)


@router.post("/api/exemplars/{exemplar_id}/cracks/edit")
def post_crack_edit(exemplar_id: int, request: CrackEditRequest, state: State):
    return edit_cracks(state, exemplar_id, request)


@router.post("/api/exemplars/{exemplar_id}/rectify", status_code=201)
def post_rectify(exemplar_id: int, request: RectifyRequest, state: State):
    answer = rectify_exemplar(state, exemplar_id, request)
    if answer["existing"]:  # rectified the same way before: that exemplar
        return JSONResponse(answer, status_code=200)
    return answer
