"""A whole material set from a photo (:func:`transfer_material` carries it to a texture synthesized
from the photo, :mod:`.transfer`).

Photo (:func:`make_material`): the photo's broad light taken out (:mod:`.illumination`) ->
label map -> estimated height (:mod:`.height`) -> light fitted
jointly with it and the photo's shape from shading joined to the height, as far as the two
agree (:mod:`.shading`) -> replayed edits (:mod:`.editor`) -> normals, AO (the height's, plus
the photo's cavities), roughness (:mod:`.maps`) -> albedo ``I / max(N·L, floor) ** g``
relative to its geometric mean, ``g`` fitted (:mod:`.shading`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen._shared.memory import BASE_BYTES, check_budget_value, check_memory_budget, parse_memory
from barkgen._shared.options import check_options, option
from barkgen.errors import InvalidInputError
from barkgen.material.editor import HeightEdit, HeightEditor
from barkgen.material.height import HeightConfig, estimate_height, luminance
from barkgen.material.illumination import check_strength, equalize_light, relit
from barkgen.material.maps import (
    AO_RADIUS,
    CAVITY_WEIGHT,
    ambient_occlusion,
    encode_normals,
    flip_green,
    normal_map,
    photo_cavities,
    roughness_map,
)
from barkgen.material.realsize import ASSUMED_PHOTO_WIDTH_M, check_width_m, physical_size
from barkgen.material.shading import (
    Light,
    estimate_light,
    parse_light,
    remove_shading,
    shading_confidence,
    with_shading_height,
)


def _light_text(light: Light) -> str:
    return f"{light.azimuth:g},{light.elevation:g}"


#: the help of the light equalisation, an option of the material set and of generate
EQUALIZE_LIGHT_HELP = (
    "How much of the photo's broad light (a trunk's curvature falloff, a light gradient, "
    "dappled light) is taken out before anything learns from it: 1 all of it, 0 none (the "
    "photo's light kept). Patches of another hue (moss, lichen) stay."
)


@dataclass(frozen=True)
class MaterialOptions:
    """Parameters of :func:`make_material`, validated once here.

    Parameters
    ----------
    k : int, default 3
        Labels of the colour label map used as the height's structure cue.
    light : Light, optional
        The photo's light (``None``: estimated, :func:`~barkgen.material.estimate_light`).
    height : HeightConfig, optional
        The height's cues (:class:`~barkgen.material.height.HeightConfig`).
    relief : float, default 1.0
        Multiplies the height's strength (2 = twice as deep), in (0, 100].
    ao_radius : int, default AO_RADIUS
        Reach of the occlusion in px, 1-256.
    cavities : float, default CAVITY_WEIGHT
        Weight of the photo's own cavities in the AO
        (:func:`~barkgen.material.maps.photo_cavities`; 0: the height's AO alone).
    exemplar_wrap : {"auto", "yes", "no"}, bool or (bool, bool), default "auto"
        Along which axes the photo wraps, so its maps (every blur, gradient, AO ray and edit
        neighbourhood) wrap there too and tile where the photo tiles: ``auto`` asks the photo
        (:func:`barkgen.synth.exemplar_wraps`), ``yes``/``True`` both axes (a tileable texture),
        ``no``/``False`` neither, or ``(rows, columns)``.
    seed : int, default 0
        Seeds the label map's k-means.
    equalize_light : float, default 1.0
        How much of the photo's broad light (:func:`~barkgen.material.illumination.equalize_light`)
        is taken out before anything else: 1 all of it, 0 none (the photo's light kept).
    width_m : float, optional
        The photo's real-world width in metres: the set's pixels are ``width_m / w`` metres
        wide, and its displacement's depth is stated in metres (``None``: the photo is
        assumed :data:`ASSUMED_PHOTO_WIDTH_M` wide, and ``NAME.json`` says so).
    max_memory : int, optional
        Refuse a photo whose material set is estimated (:func:`estimate_material_memory`) to
        need more than this many bytes, before any work (None: what the machine has free).

    Raises
    ------
    InvalidInputError
        Any value out of range.
    """

    k: int = option(3, "Labels of the structure cue (1-16).", kind=int, minimum=1, maximum=16)
    light: Light | None = option(
        None,
        "The photo's light AZ,EL in degrees (azimuth counter-clockwise from the "
        "right, elevation above the surface) for shading removal. Default: estimated.",
        parse=parse_light,
        text=_light_text,
    )
    height: HeightConfig = option(
        help="The height's cues (barkgen.material.height.HeightConfig).", default_factory=HeightConfig, fronts=()
    )
    relief: float = option(
        1.0,
        "Relief strength of the estimated height (1 = as fitted on scanned bark; "
        "2 doubles its depth and its slopes; normals and AO follow).",
        kind=float,
        minimum=0,
        maximum=100,
    )
    ao_radius: int = option(AO_RADIUS, "Reach of the occlusion in px.", kind=int, minimum=1, maximum=256, fronts=())
    cavities: float = option(
        CAVITY_WEIGHT,
        "Weight of the photo's own cavities in the AO (0: the height's AO alone).",
        kind=float,
        minimum=0,
        maximum=100,
        fronts=(),
    )
    exemplar_wrap: str | bool | tuple[bool, bool] = option(
        "auto",
        "auto: the photo is used as a torus along each axis along which it "
        "tiles itself (its last row continues into its first), so pieces run on across its edge; "
        "yes / no: force it.",
        flag="--exemplar-wraps",
        choices=("auto", "yes", "no"),
    )
    seed: int = option(0, "Random seed (same seed, same bytes).", kind=int, minimum=0)
    equalize_light: float = option(
        1.0,
        EQUALIZE_LIGHT_HELP,
        kind=float,
        minimum=0,
        maximum=1,
    )
    width_m: float | None = option(
        None,
        "The set's real-world width in metres: its displacement's depth is given in metres "
        "(NAME.json, NAME.mtlx, the Blender set-up). Default: the photo is assumed 0.5 m wide.",
        kind=float,
        minimum=0.001,
        maximum=1000,
    )
    max_memory: int | None = option(
        None,
        "Refuse jobs estimated to need more memory than this, e.g. 8G (default: what the machine has free).",
        parse=parse_memory,
    )

    def __post_init__(self) -> None:
        from barkgen._shared.checks import check_k, check_seed
        from barkgen.synth import check_wrap_mode

        check_wrap_mode(self.exemplar_wrap)
        check_k(self.k)
        check_seed(self.seed)
        check_budget_value(self.max_memory)
        check_width_m(self.width_m)
        check_strength(self.equalize_light)
        if not (np.isfinite(self.relief) and 0 < self.relief <= 100):
            raise InvalidInputError(f"relief must be in (0, 100], not {self.relief:g}")
        if not 1 <= self.ao_radius <= 256:
            raise InvalidInputError(f"AO radius must be 1..256 px, not {self.ao_radius}")
        if not (np.isfinite(self.cavities) and 0 <= self.cavities <= 100):
            raise InvalidInputError(f"the AO's cavity weight must be in [0, 100], not {self.cavities:g}")
        check_options(self)


@dataclass
class MaterialSet:
    """The aligned maps of one bark material, all of one size.

    Attributes
    ----------
    color : ndarray of float32, shape (h, w, 3)
        Albedo, sRGB in [0, 1].
    height : ndarray of float32, shape (h, w)
        Height in pixels.
    normals : ndarray of float32, shape (h, w, 3)
        Unit normals, OpenGL convention.
    ao, roughness : ndarray of float32, shape (h, w)
        Ambient occlusion and roughness in [0, 1].
    tile : bool
        The maps tile (along both axes).
    light : Light or None
        The light whose shading was removed from the colour
        (:func:`~barkgen.material.shading.remove_shading`).
    shading_strength : float or None
        The strength of that removal.
    ao_cavities : ndarray or None
        The photo's cavity term in ``ao`` (:func:`~barkgen.material.maps.photo_cavities`),
        carried with the height by :func:`transfer_material` (``None``: the AO is the height's
        alone).
    wrap : (bool, bool) or None
        ``(rows, columns)``: the axes along which the maps wrap (a photo that tiles along one
        axis only); ``None``: as ``tile`` says, both or neither.
    metalness, opacity : ndarray of float32, shape (h, w), or None
        A scanned set's metalness and opacity in [0, 1] (``None``: the set has none).
    scanned : tuple of str
        The maps (of ``normals, height, ao, roughness, metalness, opacity``) that are a scanned
        set's own (:func:`~barkgen.material.scanned_material`): :func:`transfer_material`
        carries them as they are instead of recomputing them.
    bits : dict of str to int
        Bits per channel of a map's file (``color``, ``normals``, ``roughness``, ``ao``,
        ``metalness``, ``opacity``) where it is 16: a 16-bit scan's maps stay 16-bit. The
        displacement is always 16-bit.
    pixel_size_m : float or None
        The real-world size of a pixel in metres (``None``: unknown), which gives the set's
        width and its displacement's depth in metres.
    size_given : bool
        ``pixel_size_m`` is the user's (a width in metres was given), not assumed.
    illumination : ndarray of float32, shape (h, w), or None
        The photo's broad light ``L`` (:func:`~barkgen.material.illumination.estimate_illumination`),
        carried with the maps: :meth:`relit_color` puts it back.
    map_wraps : dict of str to (bool, bool)
        A scanned set's maps (``height``, ``normals``, ``ao``, ...) that tile along fewer axes
        than ``wrap``: the axes each wraps along (:func:`transfer_material` carries it so).
    scan_info : dict
        How a scanned set was read (resampled sizes, the normals' convention, where the
        roughness came from): the metadata's ``scanned_info``.
    equalization : float
        How much of ``illumination`` was taken out of ``color`` (0 to 1).
    shape : tuple of int
        ``(h, w)``.
    depth : float
        Displacement depth scale: the height range in pixels.
    midlevel : float
        Where height 0 lies in the normalised displacement.

    References
    ----------
    .. [1] wang2003, §3.3-3.4 (height field and texture correction).
    .. [2] laitoch2018, §3.3.1 (extra maps resolved through the reference map).
    """

    color: np.ndarray
    height: np.ndarray
    normals: np.ndarray
    ao: np.ndarray
    roughness: np.ndarray
    tile: bool = False
    light: Light | None = None
    shading_strength: float | None = None
    ao_cavities: np.ndarray | None = None
    wrap: tuple[bool, bool] | None = None
    metalness: np.ndarray | None = None
    opacity: np.ndarray | None = None
    scanned: tuple[str, ...] = ()
    bits: dict[str, int] = field(default_factory=dict)
    pixel_size_m: float | None = None
    size_given: bool = False
    illumination: np.ndarray | None = None
    equalization: float = 0.0
    map_wraps: dict[str, tuple[bool, bool]] = field(default_factory=dict)
    scan_info: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int]:
        return self.height.shape

    @property
    def depth(self) -> float:
        """Displacement depth scale: the height range in pixels (0 -> 1 in the 16-bit map)."""
        return float(self.height.max() - self.height.min())

    @property
    def midlevel(self) -> float:
        """Where height 0 lies in the normalised displacement (0 = deepest, 1 = highest)."""
        return float(-self.height.min() / self.depth) if self.depth > 0 else 0.5

    def displacement(self) -> np.ndarray:
        """Height normalised to [0, 1] (0 = deepest), float64."""
        h = self.height.astype(np.float64)
        return (h - h.min()) / self.depth if self.depth > 0 else np.full(h.shape, 0.5)

    def images(self, name: str) -> dict[str, np.ndarray]:
        """The files of the set, ambientCG names (``NAME_Color.png`` ...) -> pixel arrays:
        sRGB colour, OpenGL and DirectX normals (differing only in green), 16-bit displacement,
        linear roughness and AO, and a scanned set's metalness and opacity where it has them;
        8-bit unless :attr:`bits` says 16."""
        gl = encode_normals(self.normals, self.bits.get("normals", 8))
        images = {
            f"{name}_Color.png": self._pixels("color", self.color),
            f"{name}_NormalGL.png": gl,
            f"{name}_NormalDX.png": flip_green(gl),
            f"{name}_Displacement.png": np.round(self.displacement() * 65535).astype(np.uint16),
            f"{name}_Roughness.png": self._pixels("roughness", self.roughness),
            f"{name}_AmbientOcclusion.png": self._pixels("ao", self.ao),
        }
        for kind, suffix in (("metalness", "Metalness"), ("opacity", "Opacity")):
            values = getattr(self, kind)
            if values is not None:
                images[f"{name}_{suffix}.png"] = self._pixels(kind, values)
        return images

    def _pixels(self, kind: str, values: np.ndarray) -> np.ndarray:
        """A map in [0, 1] as its file's pixels: 16-bit where :attr:`bits` says so, else 8."""
        from barkgen.material.presets import encode_unit

        return encode_unit(values, self.bits.get(kind, 8))

    def resampled(self, shape: tuple[int, int]) -> MaterialSet:
        """The same set at another size ``(h, w)``, resampled, not re-made: values averaged over
        each new pixel's area when shrinking (cv2's INTER_AREA), linear between pixel centres
        when enlarging (on the torus along the axes it wraps); normals averaged and
        renormalised; the height in the new pixels (times the scale, so the slopes and the
        displacement's depth as a fraction of the width stay)."""
        import cv2
        from scipy import ndimage

        h, w = int(shape[0]), int(shape[1])
        if (h, w) == self.shape:
            return self
        wraps = self.wraps
        scale_y, scale_x = h / self.shape[0], w / self.shape[1]

        def resize(values: np.ndarray) -> np.ndarray:
            arr = np.asarray(values, np.float32)
            if scale_y <= 1 and scale_x <= 1:
                return cv2.resize(arr, (w, h), interpolation=cv2.INTER_AREA).reshape((h, w) + arr.shape[2:])
            out = arr
            for axis, (size, wrap) in enumerate(((h, wraps[0]), (w, wraps[1]))):
                zoom = [1.0] * arr.ndim
                zoom[axis] = size / arr.shape[axis]
                out = ndimage.zoom(out, zoom, order=1, mode="grid-wrap" if wrap else "nearest", grid_mode=True)
            return out.astype(np.float32)

        normals = resize(self.normals)
        normals /= np.maximum(np.linalg.norm(normals, axis=2, keepdims=True), 1e-6)
        return dataclasses.replace(
            self,
            pixel_size_m=None if self.pixel_size_m is None else self.pixel_size_m / float(np.sqrt(scale_y * scale_x)),
            color=resize(self.color),
            height=resize(self.height) * float(np.sqrt(scale_y * scale_x)),
            normals=normals,
            ao=resize(self.ao),
            roughness=resize(self.roughness),
            illumination=None if self.illumination is None else resize(self.illumination),
            ao_cavities=None if self.ao_cavities is None else resize(self.ao_cavities),
            metalness=None if self.metalness is None else resize(self.metalness),
            opacity=None if self.opacity is None else resize(self.opacity),
        )

    def oriented(self, oriented) -> MaterialSet:
        """The set as the atlas of an exemplar's turned and scaled copies
        (:class:`barkgen.synth.OrientedExemplar`, a synthesis along a flow field): every map cut
        as the colour is, the normals turned with their copy, the height times its copy's scale
        (so the slopes, and the normals, stay); the atlas does not wrap."""
        scale = np.repeat(np.asarray(oriented.scales, np.float32), oriented.pitch)[:, None]

        def atlas(values):
            return None if values is None else oriented.atlas(np.asarray(values, np.float32))

        return dataclasses.replace(
            self,
            color=atlas(self.color),
            height=atlas(self.height) * scale,
            normals=oriented.atlas(np.asarray(self.normals, np.float32), kind="normals"),
            ao=atlas(self.ao),
            roughness=atlas(self.roughness),
            illumination=atlas(self.illumination),
            ao_cavities=atlas(self.ao_cavities),
            metalness=atlas(self.metalness),
            opacity=atlas(self.opacity),
            wrap=(False, False),
        )

    def relit_color(self, equalization: float) -> np.ndarray:
        """The colour as if ``equalization`` (0 to 1) of the photo's broad light had been taken
        out instead of :attr:`equalization` (the colour itself without an illumination)."""
        if self.illumination is None or equalization == self.equalization:
            return self.color
        return relit(self.color, self.illumination, self.equalization - check_strength(equalization))

    def with_width_m(self, width_m: float | None) -> MaterialSet:
        """The set said to be ``width_m`` metres wide (its pixels that size / its width); ``None``:
        the set as it is."""
        checked = check_width_m(width_m)
        if checked is None:
            return self
        return dataclasses.replace(self, pixel_size_m=checked / self.shape[1], size_given=True)

    def physical_size(self) -> dict:
        """The set's real-world size and its displacement's depth in metres (``{}`` when the
        pixel size is unknown): ``width_m``, ``height_m``, ``real_size`` (``given`` or
        ``assumed``), ``displacement_depth_m`` (highest minus deepest point)."""
        if self.pixel_size_m is None:
            return {}
        return physical_size(self.shape, self.depth, self.pixel_size_m, self.size_given)

    @property
    def wraps(self) -> tuple[bool, bool]:
        """``(rows, columns)``: the axes along which the maps wrap."""
        return self.wrap if self.wrap is not None else (bool(self.tile), bool(self.tile))

    @property
    def boundary(self) -> Boundary:
        """How the maps' filters read them at their edges (round the torus where they wrap)."""
        return Boundary(self.wraps)

    def metadata(self, **extra) -> dict:
        """The ``NAME.json`` record (size, tileable, depth scale, light; plus ``extra``)."""
        from barkgen._version import __version__

        meta = {
            "size": [int(self.shape[1]), int(self.shape[0])],
            "tileable": bool(self.tile),
            "wraps": list(self.wraps),
            "displacement_depth_px": round(self.depth, 6),
            "displacement_depth": round(self.depth / self.shape[1], 6),
            "displacement_midlevel": round(self.midlevel, 8),
            "normal_convention": {"NormalGL": "OpenGL (+Y up, glTF)", "NormalDX": "DirectX (+Y down)"},
            "light": None
            if self.light is None
            else {
                "azimuth": self.light.azimuth,
                "elevation": self.light.elevation,
                "correlation": None if self.light.correlation is None else round(self.light.correlation, 4),
                "shading_strength": None if self.shading_strength is None else round(self.shading_strength, 4),
            },
            "barkgen_version": __version__,
        }
        meta["light_equalization"] = round(float(self.equalization), 4)
        if self.pixel_size_m is not None:  # the real-world size, and the depth in metres
            meta.update(self.physical_size())
        if self.scanned:  # a scanned set's: which maps are the scan's own, carried, not estimated
            meta["scanned_maps"] = list(self.scanned)
            if self.scan_info:
                meta["scanned_info"] = self.scan_info
        meta.update(extra)
        return meta


def derived_maps(height: np.ndarray, boundary: Boundary, ao_radius: int = AO_RADIUS) -> tuple[np.ndarray, np.ndarray]:
    """Normals (OpenGL) and ambient occlusion of a height field.

    Parameters
    ----------
    height : ndarray, shape (h, w)
        Height in pixels.
    boundary : Boundary
        Where the height wraps (both axes, or ``(rows, columns)``; a set's own:
        :attr:`MaterialSet.boundary`).
    ao_radius : int, default AO_RADIUS
        Reach of the occlusion in px.

    Returns
    -------
    normals : ndarray of float32, shape (h, w, 3)
    ao : ndarray of float32, shape (h, w)
    """
    return normal_map(height, boundary=boundary), ambient_occlusion(height, radius=ao_radius, boundary=boundary)


#: bytes per photo pixel of :func:`make_material`: the label map's denoised copy and k-means,
#: the height's cue stack and blurs, the gradient-domain solves, the maps (measured peaks
#: 0.41 GiB for a 1024x1024 photo, 0.81 GiB for 2048x2048: 139 bytes a pixel)
MATERIAL_PHOTO_BYTES_PER_PIXEL = 160


def estimate_material_memory(photo_shape: tuple[int, int]) -> int:
    """Estimated peak memory (bytes) of :func:`make_material` for a photo of ``(h, w)``."""
    return BASE_BYTES + MATERIAL_PHOTO_BYTES_PER_PIXEL * photo_shape[0] * photo_shape[1]


def make_material(
    photo: np.ndarray,
    options: MaterialOptions | None = None,
    *,
    label_map: np.ndarray | None = None,
    edits: Iterable[HeightEdit] = (),
    illumination: np.ndarray | None = None,
) -> MaterialSet:
    """The material set of a bark photo, from the photo alone (see the module docstring).

    Parameters
    ----------
    photo : ndarray, shape (h, w) or (h, w, C)
        The photo: uint8, uint16 or float in [0, 1].
    options : MaterialOptions, optional
        Labels, light, relief, AO, tiling, seed.
    label_map : ndarray, shape (h, w), optional
        The photo's label codes (darkest label 0); else a colour label map is made.
    edits : iterable of HeightEdit, default ()
        Height edits to replay (:class:`~barkgen.material.editor.HeightEdit`).
    illumination : ndarray, shape (h, w), optional
        The photo's broad light when the caller has estimated it already
        (:func:`~barkgen.material.equalize_light`), and ``photo`` is equalised by
        ``options.equalize_light`` already: it is not estimated or taken out again.

    Returns
    -------
    MaterialSet
        Albedo, height, normals, AO and roughness of the photo.

    Raises
    ------
    MemoryBudgetError
        The photo's set would not fit ``options.max_memory`` (checked before any work).

    References
    ----------
    .. [1] wang2003, §3.3-3.4 (height field assignment, texture correction).

    Examples
    --------
    >>> import barkgen
    >>> photo = barkgen.read_image(barkgen.sample_exemplar_path())[:64, :64]
    >>> make_material(photo).shape
    (64, 64)
    """
    from barkgen._shared.checks import check_image
    from barkgen.labels import color_regions
    from barkgen.labels.regions import to_codes
    from barkgen.synth import resolve_exemplar_wrap

    options = options or MaterialOptions()
    h, w = np.shape(photo)[:2]
    check_memory_budget(estimate_material_memory((h, w)), options.max_memory, f"the material set of a {w}x{h} photo")
    rgb = check_image(photo)
    # every filter of the run reads the photo round its edges as it wraps
    boundary = Boundary(resolve_exemplar_wrap(options.exemplar_wrap, photo))
    wrap = boundary.wrap
    if illumination is None:
        rgb, illumination = equalize_light(rgb, options.equalize_light, boundary=boundary)
    if label_map is None:
        label_map, _ = to_codes(color_regions(rgb, options.k, seed=options.seed, wrap=wrap))
    config = dataclasses.replace(options.height, strength=options.height.strength * options.relief)
    height = estimate_height(rgb, label_map, config=config, boundary=boundary)
    light = options.light or estimate_light(
        rgb, normal_map(height, boundary=boundary), height=height, boundary=boundary
    )
    confidence = shading_confidence(light, given=options.light is not None)
    height = with_shading_height(rgb, height, light, weight=config.shading_weight * confidence, boundary=boundary)
    edits = list(edits)
    if edits:
        editor = HeightEditor(rgb, height, label_map, boundary=boundary)
        height = editor.apply(edits)
    normals, ao = derived_maps(height, boundary, ao_radius=options.ao_radius)
    cavities = photo_cavities(ao, luminance(rgb), weight=options.cavities, boundary=boundary)
    ao = np.clip(ao + cavities, 0.0, 1.0)
    albedo, strength = remove_shading(rgb, normals, light)
    return MaterialSet(
        color=albedo,
        height=height,
        normals=normals,
        ao=ao,
        roughness=roughness_map(height, ao),
        tile=all(wrap),
        light=light,
        shading_strength=strength,
        ao_cavities=cavities,
        wrap=wrap,
        pixel_size_m=(options.width_m or ASSUMED_PHOTO_WIDTH_M) / w,
        size_given=options.width_m is not None,
        illumination=illumination,
        equalization=options.equalize_light,
    )
