"""The last pass of a large output, window by window (issue 69, "bark at any size"): the texture's
colour, its extra maps and its material set resolved from the reference map one window at a
time, so no map of the output's size is ever held.

Every map of that pass is local (laitoch2018 §3.3.1: each output pixel's value comes from its
exemplar reference and its neighbours'): the colour's seam blend (:func:`barkgen.synth.blend_seams`)
reaches :data:`COLOUR_HALO` px from a seam; the gradient-domain maps
(:func:`barkgen.synth.resolve_continuous`, perez2003) are screened Poisson solves whose
response to a change decays as ``exp(-r * sqrt(SCREENING))`` (31.6 px at ``1e-3``), and the
normals and AO recomputed from the carried height read ``AO_RADIUS + 1`` px further. So each
window's core is resolved on the core and a halo of :data:`MATERIAL_HALO` px (read round the
torus when the output tiles, clipped at the output's edges otherwise), on a window that does
not tile, and only its core is kept: it matches the whole solve's maps to a fraction of their
files' last bit (see ``tests/pipeline/test_windowed_material.py``).

Only the displacement's normalisation is global: its 16-bit file holds the height rescaled
from the output's lowest to its highest point (:meth:`barkgen.material.MaterialSet.displacement`,
with its ``depth`` and ``midlevel`` in the set's JSON). The windows give each core's range
(:class:`HeightRange`); the displacement is encoded once the whole range is known
(:func:`encoded_window`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from barkgen._shared.canvas import Canvas
from barkgen._shared.windows import ResolveWindow as ResolveWindow
from barkgen._shared.windows import resolve_windows as resolve_windows
from barkgen.errors import InvalidInputError
from barkgen.material.maps import AO_RADIUS
from barkgen.synth import BLEND_HALO

if TYPE_CHECKING:
    from barkgen.material import MaterialSet

#: px of halo round a window's core for the material set: the screened Poisson solves
#: (``SCREENING`` = 1e-3 decays as exp(-r / 31.6): 384 px leave less than 1 / 65535), the
#: recomputed AO's reach (``AO_RADIUS``) and the normals' one pixel
MATERIAL_HALO = 416
#: px of halo round a core for the colour's seam blend (:data:`barkgen.synth.seams.gradient.BLEND_HALO`)
COLOUR_HALO = BLEND_HALO
#: default side (px) of a window's core
WINDOW = 1024
#: the arrays of a :class:`~barkgen.material.MaterialSet` of the output's size, cropped to a core
_SET_MAPS = ("color", "height", "normals", "ao", "roughness", "ao_cavities", "metalness", "opacity", "illumination")

#: a reference map to read rectangles of: an ``(H, W, 2)`` array (or a memory map), or a
#: function ``(rows, cols) -> (len(rows), len(cols), 2)`` int array of those output rows and
#: columns (both int arrays, taken round the torus already), e.g. one reading a file on disk
References = np.ndarray | Callable[[np.ndarray, np.ndarray], np.ndarray]


def read_references(references: References, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The ``(len(rows), len(cols), 2)`` int32 references at the output ``rows`` and ``cols``:
    the one place the resolve pass reads the reference map (an array, a memory map, or a
    function that reads the rectangle itself, :data:`References`)."""
    if callable(references):
        block = np.asarray(references(rows, cols))
    else:
        block = np.asarray(references)[np.ix_(rows, cols)]
    if block.shape != (rows.size, cols.size, 2):
        raise InvalidInputError(
            f"the reference map gave a {block.shape} block for {rows.size}x{cols.size} pixels, not (h, w, 2)"
        )
    return np.ascontiguousarray(block, dtype=np.int32)


@dataclass
class WindowMaps:
    """The maps of one core (:func:`material_in_windows`).

    Attributes
    ----------
    target : (slice, slice)
        The core's rows and columns in the output.
    texture : ndarray or None
        The texture's colour there (the :class:`~barkgen.synth.SynthesisResult`'s ``image``:
        the exemplar through the references, seams blended as ``blend`` says); None without a
        ``texture_source``.
    extras : dict of str to ndarray
        The extra maps there, resolved in the gradient domain as the synthesis resolves them.
    material : MaterialSet or None
        The material set's maps there (every array cropped to the core; ``tile`` the output's);
        None without a ``source``. Its :meth:`~barkgen.material.MaterialSet.displacement`,
        ``depth`` and ``midlevel`` are the core's own: encode with :func:`encoded_window`.
    """

    target: tuple[slice, slice]
    texture: np.ndarray | None = None
    extras: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    material: MaterialSet | None = None


def material_in_windows(
    source: MaterialSet | None,
    references: References,
    canvas: Canvas,
    *,
    window: int = WINDOW,
    halo: int = MATERIAL_HALO,
    blend: str = "gradient",
    texture_source: np.ndarray | None = None,
    extras: Mapping[str, np.ndarray] | None = None,
    ao_radius: int = AO_RADIUS,
) -> Iterator[WindowMaps]:
    """The texture's colour, extra maps and material set, one window core at a time.

    Each window's references (:func:`read_references`, core and ``halo``, round the torus when
    ``canvas.tile``) are resolved on a canvas of the window's shape that does not tile, exactly
    as the whole output's are (:func:`barkgen.material.transfer_material` for the material set,
    laitoch2018 §3.3.1; :func:`barkgen.synth.blend_seams` for the colour, perez2003), and the
    core is cropped. The colour (the texture's and the set's albedo) reads only
    :data:`COLOUR_HALO` px of the halo.

    Parameters
    ----------
    source : MaterialSet or None
        The photo's set (:func:`barkgen.material.make_material`), as ``generate`` carries it;
        None: no material set.
    references : ndarray or callable
        The output's reference map, exemplar ``(y, x)`` per pixel (:data:`References`).
    canvas : Canvas
        The output's: ``shape``, ``tile`` and the resolved ``exemplar_wrap`` (no flow fields or
        linked pixels).
    window : int, default WINDOW
        Side of a core in px.
    halo : int, default MATERIAL_HALO
        Px resolved round a core (less than :data:`MATERIAL_HALO` leaves differences from the
        whole solve where a core meets the next).
    blend : {"gradient", "none"}, default "gradient"
        How the colour is carried (``GenerateOptions.blend``).
    texture_source : ndarray, optional
        The image the texture stage copied (the exemplar, ``(h, w, C)``): its colour per core.
    extras : mapping of str to ndarray, optional
        Maps aligned with ``texture_source`` (``generate``'s ``extra``), each resolved as the
        synthesis resolves it (wrapping where the exemplar and the map's own edges do).
    ao_radius : int, default AO_RADIUS
        Reach of the recomputed occlusion in px.

    Yields
    ------
    WindowMaps
        Core by core, in raster order.
    """
    from barkgen.synth import check_blend

    check_blend(blend)
    if canvas.along or canvas.links is not None:
        raise InvalidInputError("the windowed resolve pass takes no flow fields or linked pixels")
    if not isinstance(canvas.exemplar_wrap, tuple):
        raise InvalidInputError(
            f"the canvas's exemplar wrap must be resolved to (rows, columns), not {canvas.exemplar_wrap!r}"
        )
    extra_wraps = _extra_wraps(extras or {}, canvas.exemplar_wrap)
    for win in resolve_windows(canvas.shape, window, halo, canvas.tile):
        refs = read_references(references, win.rows, win.cols)
        local = Canvas(win.shape, tile=False, exemplar_wrap=canvas.exemplar_wrap)
        maps = WindowMaps(win.target)
        colour = win.inner(COLOUR_HALO)  # the seam blend reaches less far than the Poisson solves
        colour_core = tuple(slice(c.start - o.start, c.stop - o.start) for c, o in zip(win.core, colour, strict=True))
        colour_canvas = Canvas(refs[colour].shape[:2], tile=False, exemplar_wrap=canvas.exemplar_wrap)
        if texture_source is not None:
            maps.texture = _colour(texture_source, refs[colour], colour_canvas, blend)[colour_core]
        for name, (image, wrap) in extra_wraps.items():
            maps.extras[name] = _resolved_extra(image, refs, local.replace(exemplar_wrap=wrap))[win.core]
        if source is not None:
            maps.material = _material_core(source, refs, local, win, ao_radius, canvas.tile)
            if blend == "gradient":  # the albedo blended on the colour's own, smaller window
                albedo = _colour(source.color, refs[colour], colour_canvas, blend)[colour_core]
                maps.material = dataclasses.replace(maps.material, color=albedo)
        yield maps


def _colour(image: np.ndarray, refs: np.ndarray, canvas: Canvas, blend: str) -> np.ndarray:
    """A local map through ``refs``, its seams blended or not (``blend``), as the synthesis'
    result and :func:`barkgen.material.transfer_material` carry the colour."""
    from barkgen.synth import apply_references, blend_seams

    return blend_seams(image, refs, canvas) if blend == "gradient" else apply_references(refs, image)


def _extra_wraps(extras: Mapping[str, np.ndarray], wrap: tuple[bool, bool]) -> dict[str, tuple[np.ndarray, tuple]]:
    """Each extra map as ``(h, w, C)`` and the axes it wraps along: the exemplar's where the
    map's own edges meet (as the synthesis takes them)."""
    from barkgen.synth import exemplar_wraps

    out = {}
    for name, image in extras.items():
        arr = np.asarray(image)
        arr = arr[:, :, None] if arr.ndim == 2 else arr
        own = exemplar_wraps(arr)
        out[name] = (arr, (bool(wrap[0] and own[0]), bool(wrap[1] and own[1])))
    return out


def _resolved_extra(image: np.ndarray, refs: np.ndarray, canvas: Canvas) -> np.ndarray:
    from barkgen.synth import resolve_continuous

    return resolve_continuous(image, refs, canvas)


def _material_core(
    source: MaterialSet, refs: np.ndarray, canvas: Canvas, win: ResolveWindow, ao_radius: int, tile: bool
) -> MaterialSet:
    """The material set of one window (:func:`barkgen.material.transfer_material`, its colour
    copied: the caller blends it on a smaller window), every map cropped to the core, ``tile``
    the output's."""
    from barkgen.material import transfer_material

    made = transfer_material(source, refs, canvas, ao_radius=ao_radius, blend="none")
    cropped: dict[str, Any] = {
        kind: None if getattr(made, kind) is None else np.ascontiguousarray(getattr(made, kind)[win.core])
        for kind in _SET_MAPS
    }
    return dataclasses.replace(made, tile=bool(tile), **cropped)


@dataclass(frozen=True)
class HeightRange:
    """The output height's lowest and highest point (px): what the displacement is normalised
    by (:meth:`barkgen.material.MaterialSet.displacement`), gathered core by core.

    Attributes
    ----------
    low, high : float
        The range; ``HeightRange()`` is empty (``low`` > ``high``).
    """

    low: float = float("inf")
    high: float = float("-inf")

    def add(self, height: np.ndarray) -> HeightRange:
        """The range with a core's ``height`` in it too."""
        return HeightRange(min(self.low, float(np.min(height))), max(self.high, float(np.max(height))))

    @property
    def depth(self) -> float:
        """As :attr:`barkgen.material.MaterialSet.depth`: the range in px."""
        return float(self.high - self.low)

    @property
    def midlevel(self) -> float:
        """As :attr:`barkgen.material.MaterialSet.midlevel`: where height 0 lies in the
        displacement."""
        return float(-self.low / self.depth) if self.depth > 0 else 0.5

    def displacement(self, height: np.ndarray) -> np.ndarray:
        """``height`` normalised by the range to [0, 1], float64 (0.5 for a flat output)."""
        h = np.asarray(height, np.float64)
        return (h - self.low) / self.depth if self.depth > 0 else np.full(h.shape, 0.5)


def encoded_window(material, height_range: HeightRange) -> dict[str, np.ndarray]:
    """A core's material maps as file pixels (:func:`barkgen.material.presets.encoded_maps`),
    its 16-bit displacement normalised by the whole output's ``height_range``."""
    from barkgen.material.presets import encoded_maps

    maps = encoded_maps(material)
    maps["displacement"] = np.round(height_range.displacement(material.height) * 65535).astype(np.uint16)
    return maps
