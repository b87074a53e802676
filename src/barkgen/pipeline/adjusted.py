"""A run's material set given the depth and the photo light an edit list chose (the web app's
sliders, saved in ``edits.json``), after :func:`~barkgen.pipeline.generate` replayed its height
edits: ``barkgen generate --edits`` and the web app's Save both call :func:`adjusted_result`, so
they write the same bytes."""

from __future__ import annotations

import dataclasses

from barkgen.errors import InvalidInputError
from barkgen.material import EditList, adjust_material
from barkgen.pipeline.core import GenerateResult
from barkgen.pipeline.materials import WindowedMaterial


def check_edit_list(edit_list: EditList, material: bool) -> None:
    """Before a run: an edit list that changes the depth or the light needs the run's material
    set (``material``: the run makes one); :class:`~barkgen.errors.InvalidInputError` if not."""
    if edit_list.adjusts and not material:
        raise InvalidInputError("the edit list's depth and light apply to a material set: turn material on")


def adjusted_result(result: GenerateResult, edit_list: EditList) -> GenerateResult:
    """``result`` with its material set passed through :func:`barkgen.material.adjust_material`
    (``relief`` and ``light_equalization`` of ``edit_list``; its height edits are
    :func:`~barkgen.pipeline.generate`'s ``edits``, replayed before).

    Parameters
    ----------
    result : GenerateResult
        A run with ``edit_list.edits`` replayed on its set.
    edit_list : EditList
        The edit list (:func:`barkgen.material.parse_edit_list`).

    Returns
    -------
    GenerateResult
        The same run, its set's height scaled (normals and AO made again) and its colour
        relit, and its report saying so (``adjusted``); ``result`` itself when the list
        changes neither.

    Raises
    ------
    InvalidInputError
        A run without a material set, a scanned set's relief scaled (it is the scan's own), or
        a light to change on a set that carries none.
    """
    if not edit_list.adjusts:
        return result
    material = result.material
    check_edit_list(edit_list, material is not None)
    assert material is not None  # (checked)
    if isinstance(material, WindowedMaterial):  # (a large set: scaled and relit whole)
        material = material.whole()
    if edit_list.relief != 1.0 and {"height", "normals"} & set(material.scanned):
        raise InvalidInputError("the depth of a scanned set's relief is the scan's own: leave relief at 1")
    adjusted = adjust_material(material, relief=edit_list.relief, equalization=edit_list.light_equalization)
    report = {
        **result.report,
        "adjusted": {"relief": edit_list.relief, "light_equalization": round(float(adjusted.equalization), 4)},
    }
    return dataclasses.replace(result, material=adjusted, report=report)
