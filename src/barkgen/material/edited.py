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
    editor = HeightEditor(texture, material.height, label_map, boundary=material.boundary)
    height = editor.apply(edits)
    normals, ao = derived_maps(height, material.boundary, ao_radius=ao_radius)
    if material.ao_cavities is not None:
        ao = np.clip(ao + material.ao_cavities, 0.0, 1.0)
    return dataclasses.replace(material, height=height, normals=normals, ao=ao.astype(np.float32))


def adjust_material(
    material: MaterialSet,
    *,
    relief: float = 1.0,
    equalization: float | None = None,
    ao_radius: int = AO_RADIUS,
) -> MaterialSet:
    """The set with its relief deepened or flattened and its colour relit, without making it
    again: what the web app's depth and light sliders show, and what its Save writes.

    Parameters
    ----------
    material : MaterialSet
        The set.
    relief : float, default 1.0
        Multiplies the height (2 = twice as deep, its slopes twice as steep); the normals and
        the height's AO are made again from it, the AO's photo cavities, roughness and albedo
        stay. In (0, 100].
    equalization : float, optional
        How much of the photo's broad light is out of the colour (0 to 1,
        :meth:`MaterialSet.relit_color`; ``None``: as it is).
    ao_radius : int, default AO_RADIUS
        Reach of the occlusion made again, in px.

    Returns
    -------
    MaterialSet
        A new set; ``material`` itself when nothing changes.

    Raises
    ------
    InvalidInputError
        A relief outside (0, 100], an equalisation outside [0, 1], or a colour to relight
        that carries no light (:attr:`MaterialSet.illumination` is ``None``).
    """
    if not (np.isfinite(relief) and 0 < relief <= 100):
        raise InvalidInputError(f"relief must be in (0, 100], not {relief:g}")
    changed = material
    if equalization is not None and equalization != material.equalization:
        if material.illumination is None:
            raise InvalidInputError("this set carries no photo light to put back or take out")
        changed = dataclasses.replace(
            changed, color=material.relit_color(equalization), equalization=float(equalization)
        )
    if relief != 1.0:
        height = (material.height * np.float32(relief)).astype(np.float32)
        normals, ao = derived_maps(height, material.boundary, ao_radius=ao_radius)
        if material.ao_cavities is not None:
            ao = np.clip(ao + material.ao_cavities, 0.0, 1.0)
        changed = dataclasses.replace(changed, height=height, normals=normals, ao=ao.astype(np.float32))
    return changed
