"""The options of :func:`barkgen.pipeline.generate`, one source for every front end: each
field's default, range, help and front ends (:func:`barkgen._shared.options.option`), the
cross-field rules, and the key of what a photo's analysis depends on."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from barkgen._shared.checks import parse_output_shape, parse_size
from barkgen._shared.memory import check_budget_value, parse_memory
from barkgen._shared.options import check_options, option
from barkgen.errors import InvalidInputError
from barkgen.material.materialset import EQUALIZE_LIGHT_HELP
from barkgen.pipeline.rules import analysis_key as analysis_key
from barkgen.pipeline.rules import check_combinations

if TYPE_CHECKING:
    from barkgen.material import Light

LABEL_METHODS = ("color", "texton")
#: what the output's label map is: the photo's labels in new shapes, or a crack network grown
#: from the photo's (sibbing2010)
STRUCTURES = ("labels", "cracks")
#: what the output's pixels are: pieces of the photo, or a bi-layer texture (guingo2017): pieces
#: of the photo's structure layer plus new spatially varying noise
MODELS = ("patches", "bilayer")
#: the options the web app does not offer: its label maps are made across the photo's wrap as
#: generate's default makes them
_NOT_WEB = ("cli", "batch")


def _size_text(size: tuple[int, int]) -> str:
    return f"{size[1]}x{size[0]}"


def _parse_light(text: str) -> Light:
    from barkgen.material import parse_light

    return parse_light(text)


def _light_text(light: Light) -> str:
    return f"{light.azimuth:g},{light.elevation:g}"


@dataclass(frozen=True)
class GenerateOptions:
    """Parameters of :func:`generate`, validated once here.

    Parameters
    ----------
    size : (int, int), default (1024, 1024)
        Output ``(height, width)`` (or anything :func:`parse_output_shape` reads).
    k : int, default 3
        Labels of the input label map.
    method : {"color", "texton"}, default "color"
        How the input label map is made (:mod:`barkgen.labels`).
    strategy : {"joint", "engine", "layered"}, default "joint"
        How the output label map is made (:mod:`barkgen.shapes`).
    rotations : {"none", "vertical", "all"}, default "vertical"
        Boundary-patch rotations of the layered strategy.
    tile : bool, default False
        Tileable output.
    seed : int, default 0
        The one seed behind every random choice of a variant.
    label_weight, feature_weight : float, default 20.0, 8.0
        Texture-by-numbers weights (laitoch2018 eq. 3.1, 3.3).
    threads : int, optional
        Solver threads (None: all cores).
    max_memory : int, optional
        Refuse jobs whose estimated memory exceeds this many bytes (None: what the machine
        has free when the run starts).
    material : bool, default False
        Also make the output's material set (:mod:`barkgen.material`).
    light : Light, optional
        The photo's :class:`~barkgen.material.Light` for its shading removal (``None``:
        estimated).
    relief : float, default 1.0
        The height's strength (1 = as fitted).
    equalize_light : float, default 1.0
        How much of the photo's broad light (a trunk's curvature falloff, a gradient, dappled
        light) is taken out before the label map, the synthesis and the material maps
        (:func:`barkgen.material.equalize_light`): 1 all, 0 none (the photo's light kept).
    width_m : float, optional
        The material set's real-world width in metres, which gives its displacement's depth
        in metres (``None``: the photo is assumed
        :data:`~barkgen.material.realsize.ASSUMED_PHOTO_WIDTH_M` wide).
    windowed : {"auto", "yes", "no"}, default "auto"
        ``yes``: the output made window by window (issue 69): its finest levels solved with a
        frozen halo (``SynthesisConfig.window``, :mod:`barkgen.synth._windows`), its colour
        blended per window (:func:`barkgen.synth.blend_seams_in_windows`), and :func:`generate`'s
        ``material`` a :class:`~barkgen.pipeline.WindowedMaterial`, written window by window
        (:func:`barkgen.pipeline.write_windowed_material`). ``auto``: so for outputs of more than
        :data:`~barkgen.pipeline.rules.WINDOWED_PIXELS` whose run needs nothing whole
        (height edits, a flow field, a bi-layer texture).
    exemplar_wrap : {"auto", "yes", "no"}, default "auto"
        ``auto``: the photo is used as a torus along each axis it tiles along
        (:func:`barkgen.synth.exemplar_wraps`).
    blend : {"gradient", "none"}, default "gradient"
        ``gradient``: the colour's seams between copied pieces (and the albedo's) blended in
        the gradient domain (:func:`barkgen.synth.blend_seams`); ``none``: every
        pixel an exact copy of its reference.
    structure : {"labels", "cracks"}, default "labels"
        ``cracks``: the photo's crack network is extracted and a new one grown at the output
        size (on the torus with ``tile``; sibbing2010 §3-4), and texture-by-numbers fills it
        (:mod:`barkgen.pipeline.variants`).
    model : {"patches", "bilayer"}, default "patches"
        ``bilayer``: the output is a bi-layer texture (guingo2017): the photo's structure layer
        synthesized by the engine, plus new noise of the photo's spectra under the synthesized
        masks; ``k`` is its number of noises (1-8).

    Raises
    ------
    InvalidInputError
        Any option out of range (one line).

    Examples
    --------
    >>> GenerateOptions(size=256, tile=True).size
    (256, 256)
    """

    size: tuple[int, int] = option(
        (1024, 1024), "Output size WIDTHxHEIGHT.", parse=parse_size, text=_size_text, analysis=True
    )
    k: int = option(
        3, "Number of labels of the photo's label map (1-16).", kind=int, minimum=1, maximum=16, analysis=True
    )
    method: str = option(
        "color",
        "Input label map: color (laitoch2018 §3.5) or texton (wang2003 §3.2).",
        choices=LABEL_METHODS,
        analysis=True,
        group="more",
    )
    edges: int = option(
        0,
        "Width in px of one more label for the region edges (laitoch2018 §3.5.5), added to the "
        "photo's and the new bark's label maps once both are made, before texture-by-numbers; "
        "0: none.",
        kind=int,
        minimum=0,
        maximum=32,
        analysis=True,
        fronts=_NOT_WEB,
        group="advanced",
    )
    strategy: str = option(
        "joint",
        "Output label maps: joint (the core engine on one-hot label channels and the "
        "photo's colours), engine (label channels alone) or layered (Rosenberger et al.'s layered "
        "shape synthesis, laitoch2018 §3.6).",
        choices=("joint", "engine", "layered"),
        analysis=True,
        group="more",
    )
    rotations: str = option(
        "vertical",
        "Layered strategy: boundary patches may turn none, vertical (180°) or all (90° steps).",
        choices=("none", "vertical", "all"),
        group="advanced",
    )
    tile: bool = option(False, "Make the output tile seamlessly.", kind=bool)
    seed: int = option(
        0, "Random seed (same seed, same bytes).", kind=int, minimum=0, fronts=("cli", "web")
    )  # a batch spec's seeds are its entries' own
    label_weight: float = option(
        20.0, "Texture-by-numbers' label weight (laitoch2018 eq. 3.1).", kind=float, minimum=0, group="advanced"
    )
    feature_weight: float = option(
        8.0,
        "Texture-by-numbers' feature-distance weight (laitoch2018 eq. 3.3).",
        kind=float,
        minimum=0,
        analysis=True,
        group="advanced",
    )
    # the run's budget (threads, memory) moves no output: not in report.json, so a batch worker's
    # one thread writes the same files as a run on every core
    threads: int | None = option(
        None, "Worker threads (default: all cores).", kind=int, minimum=1, fronts=("cli",), report=""
    )
    max_memory: int | None = option(
        None,
        "Refuse jobs estimated to need more memory than this, e.g. 8G (default: what the machine has free).",
        parse=parse_memory,
        fronts=("cli",),
        report="",
    )
    material: bool = option(
        False,
        "Also make the material set of the new bark (NAME_Color, NormalGL/DX, Displacement "
        "16-bit, Roughness, AmbientOcclusion, NAME.json).",
        kind=bool,
        analysis=True,
    )
    light: Light | None = option(
        None,
        "The photo's light AZ,EL in degrees (azimuth counter-clockwise from the right, "
        "elevation above the surface) for shading removal; needs material. Default: estimated.",
        parse=_parse_light,
        text=_light_text,
        analysis=True,
        group="advanced",
        needs="material",
    )
    relief: float = option(
        1.0,
        "Relief strength of the estimated height (1 = as fitted on scanned bark; 2 doubles "
        "its depth and its slopes; normals and AO follow); needs material.",
        kind=float,
        minimum=0,
        maximum=100,
        analysis=True,
        group="more",
        needs="material",
    )
    equalize_light: float = option(
        1.0,
        EQUALIZE_LIGHT_HELP,
        kind=float,
        minimum=0,
        maximum=1,
        analysis=True,
        group="more",
        report="light_equalization",
    )
    width_m: float | None = option(
        None,
        "The material set's real-world width in metres: its displacement's depth is given in "
        "metres in NAME.json, NAME.mtlx and the Blender set-up (default: the photo is assumed "
        "0.5 m wide); needs material.",
        kind=float,
        minimum=0.001,
        maximum=1000,
        group="more",
        needs="material",
    )
    windowed: str = option(
        "auto",
        "Make the output window by window: its finest levels solved, its colour blended and its "
        "material set written as each window is finished, never whole in memory. auto: for "
        "outputs over 4096x4096 px (16.8 megapixels); yes / no: force it. Not with height "
        "edits, a flow field or a bi-layer texture.",
        choices=("auto", "yes", "no"),
        fronts=_NOT_WEB,
        group="advanced",
    )
    exemplar_wrap: str = option(
        "auto",
        "auto: the photo is used as a torus along each axis along which it tiles itself "
        "(its last row continues into its first), so pieces run on across its edge; yes / no: "
        "force it.",
        flag="--exemplar-wraps",
        choices=("auto", "yes", "no"),
        analysis=True,
        fronts=_NOT_WEB,
        group="advanced",
        report="exemplar_wrap_mode",
    )
    blend: str = option(
        "gradient",
        "gradient: the colour's seams between copied pieces blended in the gradient "
        "domain (Pérez et al. 2003); none: every pixel an exact copy of the photo's.",
        choices=("gradient", "none"),
        group="advanced",
    )

    structure: str = option(
        "labels",
        "Output label map: labels (the photo's labels in new shapes) or cracks (the photo's "
        "crack network, extracted, grown anew at the output size and filled with bark; sibbing2010).",
        choices=STRUCTURES,
        analysis=True,
        group="kind",
    )
    model: str = option(
        "patches",
        "Output pixels: patches (pieces of the photo) or bilayer (guingo2017: the photo's "
        "structure layer in pieces plus new noise of its spectra; k noises, 1-8).",
        choices=MODELS,
        analysis=True,
        group="kind",
    )

    def __post_init__(self) -> None:
        from barkgen._shared.checks import check_k, check_seed
        from barkgen.material.illumination import check_strength
        from barkgen.material.realsize import check_width_m
        from barkgen.shapes import STRATEGIES, check_rotations
        from barkgen.synth import check_blend, check_wrap_mode

        check_wrap_mode(self.exemplar_wrap)
        check_blend(self.blend)
        object.__setattr__(self, "size", parse_output_shape(self.size))
        check_k(self.k)
        check_seed(self.seed)
        check_rotations(self.rotations)
        check_budget_value(self.max_memory)
        if self.method not in LABEL_METHODS:
            raise InvalidInputError(f"method must be one of {', '.join(LABEL_METHODS)}, not {self.method!r}")
        if self.strategy not in STRATEGIES:
            raise InvalidInputError(f"strategy must be one of {', '.join(STRATEGIES)}, not {self.strategy!r}")
        if self.structure not in STRUCTURES:
            raise InvalidInputError(f"structure must be one of {', '.join(STRUCTURES)}, not {self.structure!r}")
        if self.model not in MODELS:
            raise InvalidInputError(f"model must be one of {', '.join(MODELS)}, not {self.model!r}")
        if isinstance(self.edges, bool) or not isinstance(self.edges, (int, np.integer)) or not 0 <= self.edges <= 32:
            raise InvalidInputError(f"edges must be a width of 0 to 32 px, not {self.edges!r}")
        if self.label_weight < 0 or self.feature_weight < 0:
            raise InvalidInputError("label and feature weights must be >= 0")
        if not (np.isfinite(self.relief) and 0 < self.relief <= 100):
            raise InvalidInputError(f"relief must be in (0, 100], not {self.relief:g}")
        check_width_m(self.width_m)
        check_strength(self.equalize_light)
        if self.light is not None:
            from barkgen.material import Light

            if not isinstance(self.light, Light):
                raise InvalidInputError("light must be a barkgen.material.Light (or None: estimated)")
        check_options(self)
        check_combinations(self)  # the options that go together, with the run's other rules
