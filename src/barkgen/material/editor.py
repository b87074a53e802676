"""Self-similarity-propagated height editing (wang2003 §3.3, after Brooks & Dodgson 2002).

An edit changes the height at one pixel ``p0`` by ``delta``; every other pixel ``p`` of the
same texton channel (label) changes by ``delta * M(p)``, where the weight mask ``M`` compares
the circular neighbourhood of ``p`` (diameter ``2 radius + 1``) with that of ``p0`` by the L2
norm: 1 at identical neighbourhoods, falling linearly to 0 at ``threshold``. Large
neighbourhoods are compared at a coarser level of the image pyramid (multi-scale
neighbourhoods, for speed) and the mask is brought back to full size.

Edits replay from JSON: ``{"version": 1, "edits": [{"x": 10, "y": 20, "delta": 1.5,
"radius": 4}, ...]}`` (pixels of the photo; ``delta`` in pixels of height; optional
``"threshold"`` per edit), and optionally the depth multiplier and the photo light to give the
set after them (``"relief": 1.5, "light_equalization": 0.5``, :class:`EditList`: the web app's
sliders).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen.errors import InvalidInputError
from barkgen.material.height import luminance
from barkgen.material.illumination import check_strength

#: the largest neighbourhood radius compared at full resolution; larger ones use a coarser level
MAX_LEVEL_RADIUS = 4
#: default threshold of the neighbourhood distance, in units of the luminance's std
DEFAULT_THRESHOLD = 0.6
EDITS_VERSION = 1


@dataclass(frozen=True)
class HeightEdit:
    """One height edit (wang2003 §3.3).

    Raise (``delta`` > 0) or lower the height at pixel ``(x, y)`` and at every self-similar pixel
    of its channel, comparing neighbourhoods of ``radius`` px.

    Parameters
    ----------
    x, y : int
        The pixel edited.
    delta : float
        Change of the height there, in pixels of height.
    radius : int, default 4
        Radius of the circular neighbourhoods compared, 1-64 px.
    threshold : float, default DEFAULT_THRESHOLD
        Neighbourhood distance (luminance std units) at which the weight falls to 0.

    Raises
    ------
    InvalidInputError
        A non-finite ``delta``, a radius out of range or a threshold <= 0.
    """

    x: int
    y: int
    delta: float
    radius: int = 4
    threshold: float = DEFAULT_THRESHOLD

    def __post_init__(self) -> None:
        if not np.isfinite(self.delta):
            raise InvalidInputError("an edit's delta must be a finite number")
        if self.radius < 1 or self.radius > 64:
            raise InvalidInputError(f"an edit's radius must be 1..64 px, not {self.radius}")
        if not self.threshold > 0:
            raise InvalidInputError("an edit's threshold must be > 0")


#: the most edits an edit list may hold (each is replayed over its neighbourhood)
MAX_EDITS = 10_000


#: the largest depth multiplier an edit list may hold (:func:`barkgen.material.adjust_material`)
MAX_RELIEF = 100.0


@dataclass(frozen=True)
class EditList:
    """An edit list as its JSON holds it: the height edits, then the depth and the photo light
    the web app's sliders chose (:func:`barkgen.material.adjust_material`, after the edits).

    Parameters
    ----------
    edits : tuple of HeightEdit
        In the set's pixels, in order (may be empty when ``relief`` or ``light_equalization``
        says something).
    relief : float, default 1.0
        Multiplies the edited height, in (0, :data:`MAX_RELIEF`].
    light_equalization : float, optional
        How much of the photo's broad light is taken out of the colour, 0 to 1 (``None``: as
        the run made it).
    """

    edits: tuple[HeightEdit, ...] = ()
    relief: float = 1.0
    light_equalization: float | None = None

    @property
    def adjusts(self) -> bool:
        """The list changes the depth or the light (not only the height)."""
        return self.relief != 1.0 or self.light_equalization is not None


def parse_edit_list(document: object) -> EditList:
    """An edit list's JSON, validated: its edits, and the depth and light it chose.

    Parameters
    ----------
    document : object
        The parsed JSON: ``{"version": 1, "edits": [{"x": 120, "y": 340, "delta": 2.0,
        "radius": 4}, ...], "relief": 1.5, "light_equalization": 0.5}`` (each edit's
        ``radius`` and ``threshold`` optional; ``relief`` and ``light_equalization`` optional,
        and with either of them ``edits`` may be empty).

    Returns
    -------
    EditList

    Raises
    ------
    InvalidInputError
        A wrong version, unknown keys, nothing to do, a bad edit, a relief outside
        (0, :data:`MAX_RELIEF`] or a light outside [0, 1] (one line naming it).

    Examples
    --------
    >>> parse_edit_list({"version": 1, "edits": [], "relief": 2}).relief
    2.0
    """
    version = document.get("version") if isinstance(document, Mapping) else None
    if type(version) is not int or version != EDITS_VERSION:
        raise InvalidInputError(f'an edit list must be a JSON object with "version": {EDITS_VERSION}')
    assert isinstance(document, Mapping)  # else its version is None: refused above
    unknown = set(document) - {"version", "edits", "relief", "light_equalization"}
    if unknown:
        raise InvalidInputError(f"unknown key(s) in the edit list: {', '.join(sorted(unknown))}")
    relief = document.get("relief", 1.0)
    if isinstance(relief, bool) or not isinstance(relief, (int, float)) or not 0 < relief <= MAX_RELIEF:
        raise InvalidInputError(f'the edit list\'s "relief" must be a number in (0, {MAX_RELIEF:g}], not {relief!r}')
    light = document.get("light_equalization")
    if light is not None:
        light = check_strength(light)
    items = document.get("edits")
    adjusts = relief != 1.0 or light is not None
    if not isinstance(items, list) or not (items or adjusts):
        raise InvalidInputError('the edit list is empty: "edits" must list at least one edit')
    return EditList(tuple(_parsed_items(items)), float(relief), light)


def parse_edits(document: object) -> list[HeightEdit]:
    """The edits of a JSON edit list, validated (one that also sets the depth or the light is
    read by :func:`parse_edit_list`).

    Parameters
    ----------
    document : object
        The parsed JSON: ``{"version": 1, "edits": [{"x": 120, "y": 340, "delta": 2.0,
        "radius": 4}, ...]}`` (``radius`` and ``threshold`` optional).

    Returns
    -------
    list of HeightEdit
        The edits, in order.

    Raises
    ------
    InvalidInputError
        A wrong version, unknown keys, an empty list or a bad edit (one line naming it).

    Examples
    --------
    >>> parse_edits({"version": 1, "edits": [{"x": 3, "y": 4, "delta": 2.0}]})[0].radius
    4
    """
    parsed = parse_edit_list(document)
    if parsed.adjusts:
        raise InvalidInputError("this edit list also sets the depth or the light: read it with parse_edit_list")
    return list(parsed.edits)


def _parsed_items(items: list) -> list[HeightEdit]:
    """The edits of an edit list's ``"edits"`` items (one line naming a bad one)."""
    if len(items) > MAX_EDITS:
        raise InvalidInputError(
            f"the edit list has {len(items)} edits; at most {MAX_EDITS} (an artist's session is a few hundred)"
        )
    edits = []
    for i, item in enumerate(items):
        if not isinstance(item, Mapping) or not {"x", "y", "delta"} <= set(item):
            raise InvalidInputError(f'edit {i}: needs "x", "y" and "delta"')
        extra = set(item) - {"x", "y", "delta", "radius", "threshold"}
        if extra:
            raise InvalidInputError(f"edit {i}: unknown key(s) {', '.join(sorted(extra))}")
        ints = [item[k] for k in ("x", "y", "radius") if k in item]
        numbers = [item[k] for k in ("delta", "threshold") if k in item]
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in ints) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in numbers
        ):
            raise InvalidInputError(f"edit {i}: x, y, radius must be integers and delta, threshold numbers")
        if max(abs(v) for v in ints) > 2**31:
            raise InvalidInputError(f"edit {i}: coordinates out of range")
        try:
            edits.append(
                HeightEdit(
                    item["x"],
                    item["y"],
                    float(item["delta"]),
                    item.get("radius", 4),
                    float(item.get("threshold", DEFAULT_THRESHOLD)),
                )
            )
        except InvalidInputError as exc:
            raise InvalidInputError(f"edit {i}: {exc}") from None
    return edits


def edits_document(
    edits: Iterable[HeightEdit], *, relief: float = 1.0, light_equalization: float | None = None
) -> dict:
    """The JSON document of a list of edits (what :func:`parse_edit_list` reads).

    Parameters
    ----------
    edits : iterable of HeightEdit
        The edits.
    relief : float, default 1.0
        The depth multiplier after the edits (written only when it is not 1).
    light_equalization : float, optional
        The photo light chosen (written only when given).

    Returns
    -------
    dict
        ``{"version": 1, "edits": [...]}``, every field of every edit written out, then
        ``relief`` and ``light_equalization`` where they say something.
    """
    document: dict = {
        "version": EDITS_VERSION,
        "edits": [{"x": e.x, "y": e.y, "delta": e.delta, "radius": e.radius, "threshold": e.threshold} for e in edits],
    }
    if relief != 1.0:
        document["relief"] = float(relief)
    if light_equalization is not None:
        document["light_equalization"] = float(light_equalization)
    return document


def _disc_offsets(radius: int) -> np.ndarray:
    r = np.arange(-radius, radius + 1)
    yy, xx = np.meshgrid(r, r, indexing="ij")
    inside = yy**2 + xx**2 <= radius * radius + radius  # the usual discrete circle
    return np.stack([yy[inside], xx[inside]], axis=1)


class HeightEditor:
    """Interactive height editing by self-similarity (wang2003 §3.3).

    ``HeightEditor(photo, height, label_map)`` keeps a copy of ``height`` (pixels);
    :meth:`edit` changes it and records the edit, :attr:`edits` replays anywhere
    (:func:`edits_document`). An edit's weight mask is 1 for neighbourhoods identical to the
    edited pixel's, falling linearly to 0 at the threshold, and 0 outside its label.

    Parameters
    ----------
    photo : ndarray, shape (h, w) or (h, w, 3)
        The photo (float in [0, 1]); its luminance is compared.
    height : ndarray, shape (h, w)
        The height to edit, in pixels (copied).
    label_map : ndarray, shape (h, w), optional
        Label codes: an edit spreads only within the edited pixel's label.
    boundary : Boundary, optional
        Where the photo wraps (both axes, or ``(rows, columns)``), so do the neighbourhoods
        (default: nowhere).

    Attributes
    ----------
    height : ndarray of float32
        The edited height.
    edits : list of HeightEdit
        The edits made, in order.

    Raises
    ------
    InvalidInputError
        The height or label map and the photo differ in size.

    References
    ----------
    .. [1] wang2003, §3.3 (height field assignment by similarity-based editing).
    .. [2] brooks2002 (self-similarity based texture editing).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> editor = HeightEditor(rng.random((32, 32)), np.zeros((32, 32)))
    >>> float(editor.edit(5, 6, 2.0)[6, 5])
    2.0
    """

    def __init__(
        self,
        photo: np.ndarray,
        height: np.ndarray,
        label_map: np.ndarray | None = None,
        *,
        boundary: Boundary | None = None,
    ):
        lum = luminance(photo).astype(np.float32)
        if lum.shape != np.asarray(height).shape:
            raise InvalidInputError("the height map and the photo sizes differ")
        if label_map is not None and np.asarray(label_map).shape != lum.shape:
            raise InvalidInputError("the label map and the photo sizes differ")
        std = float(lum.std()) or 1.0
        self._lum = (lum - lum.mean()) / std
        self.height = np.array(height, np.float32, copy=True)
        self.label_map = None if label_map is None else np.asarray(label_map)
        self.boundary = boundary or Boundary()
        self.edits: list[HeightEdit] = []

    @property
    def shape(self) -> tuple[int, int]:
        return self._lum.shape

    def mask(self, x: int, y: int, radius: int = 4, threshold: float = DEFAULT_THRESHOLD) -> np.ndarray:
        """The weight mask ``M`` of pixel ``(x, y)`` ``(h, w)`` float32 in [0, 1]."""
        h, w = self.shape
        if not (0 <= x < w and 0 <= y < h):
            raise InvalidInputError(f"edit at ({x}, {y}) is outside the {w}x{h} image")
        factor = 1
        while radius // factor > MAX_LEVEL_RADIUS and min(h, w) // (factor * 2) >= 16:
            factor *= 2
        lum = self._lum
        import cv2  # (here: the CLI's start-up imports this module, and a refusal needs no OpenCV)

        if factor > 1:
            lum = cv2.resize(lum, (w // factor, h // factor), interpolation=cv2.INTER_AREA)
        offsets = _disc_offsets(max(1, radius // factor))
        ly, lx = min(y // factor, lum.shape[0] - 1), min(x // factor, lum.shape[1] - 1)
        pad = int(np.abs(offsets).max())
        padded = self.boundary.pad(lum, pad)
        ref = np.ascontiguousarray(padded[ly + pad + offsets[:, 0], lx + pad + offsets[:, 1]], np.float32)
        from barkgen.material._kernels import neighbourhood_distance  # (numba loads with the first edit)

        dist = neighbourhood_distance(np.ascontiguousarray(padded, np.float32), ref, offsets.astype(np.int64), pad)
        weight: np.ndarray = np.clip(1.0 - dist / threshold, 0.0, 1.0)
        if factor > 1:
            weight = cv2.resize(weight, (w, h), interpolation=cv2.INTER_LINEAR)
        weight[y, x] = 1.0
        if self.label_map is not None:
            weight = weight * (self.label_map == self.label_map[y, x])
        return weight.astype(np.float32)

    def edit(self, x: int, y: int, delta: float, radius: int = 4, threshold: float = DEFAULT_THRESHOLD) -> np.ndarray:
        """Change the height by ``delta`` at ``(x, y)`` and, weighted by :meth:`mask`, at every
        self-similar pixel of its channel; returns the edited height."""
        edit = HeightEdit(int(x), int(y), float(delta), int(radius), float(threshold))
        self.height += edit.delta * self.mask(edit.x, edit.y, edit.radius, edit.threshold)
        self.edits.append(edit)
        return self.height

    def apply(self, edits: Iterable[HeightEdit]) -> np.ndarray:
        """Replay a list of edits."""
        for e in edits:
            self.edit(e.x, e.y, e.delta, e.radius, e.threshold)
        return self.height
