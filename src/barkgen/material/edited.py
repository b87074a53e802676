"""Height edits on a finished material set (wang2003 §3.3): a synthesized texture's relief
corrected by hand, as the web app's relief editor and ``barkgen generate --edits`` do."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.material.editor import HeightEdit, HeightEditor
from barkgen.material.materialset import AO_RADIUS, MaterialSet, derived_maps


def edit_material(
    material: MaterialSet,
    edits: Iterable[HeightEdit],
    *,
    texture: np.ndarray,
    label_map: np.ndarray | None = None,
    ao_radius: int = AO_RADIUS,
) -> MaterialSet:
    """The material set with height edits replayed on it.

    Each edit raises or lowers the height at its pixel and at every self-similar pixel of the
    same label (:class:`~barkgen.material.HeightEditor`, neighbourhoods compared on
    ``texture``); the normals and the height's AO are made again from the edited height
    (wrapping as the set does), the AO's photo cavities, the albedo and the roughness stay.

    Parameters
    ----------
    material : MaterialSet
        The set, its height estimated (not a scanned set's own).
    edits : iterable of HeightEdit
        In the set's pixels, in order.
    texture : ndarray, shape (h, w, 3)
        The image the edits were made on (the synthesized texture): where neighbourhoods look
        alike, an edit spreads.
    label_map : ndarray, shape (h, w), optional
        Its labels: an edit spreads within its pixel's label only.
    ao_radius : int, default AO_RADIUS
        Reach of the occlusion made again, in px.

    Returns
    -------
    MaterialSet
        A new set (``material`` is not changed); ``material`` itself when there are no edits.

    Raises
    ------
    InvalidInputError
        A scanned set's height (its relief is measured, not estimated), an edit outside the
        set, or a texture or label map of another size.

    References
    ----------
    .. [1] wang2003, §3.3 (height field assignment by similarity-based editing).
    """
    edits = list(edits)
    if not edits:
        return material
    if "height" in material.scanned or "normals" in material.scanned:
        raise InvalidInputError("height edits apply to an estimated relief; this set's relief is a scan's own")
    if np.shape(texture)[:2] != material.shape:
        raise InvalidInputError("the texture the edits were made on and the material set differ in size")
    editor = HeightEditor(texture, material.height, label_map, tile=material.wraps)
    height = editor.apply(edits)
    normals, ao = derived_maps(height, tile=material.wraps, ao_radius=ao_radius)
    if material.ao_cavities is not None:
        ao = np.clip(ao + material.ao_cavities, 0.0, 1.0)
    return dataclasses.replace(material, height=height, normals=normals, ao=ao.astype(np.float32))
