"""The one-click pipeline: photo -> new bark (laitoch2018 §1, Figure 1.2).

1. input label map of the photo (:mod:`barkgen.labels`, §3.5),
2. output label map of the requested size (:mod:`barkgen.shapes`, §3.6; by default the joint
   strategy, which matches the photo's colours along the labels),
3. texture-by-numbers of the photo from the input onto the output label map, with any extra maps
   synthesized along (:func:`barkgen.synth.texture_by_numbers`, §3.3–3.4), started from the
   output label map's own references into the photo when it has them (engine strategies): at
   the finest level for the joint strategy, whose references already fit together in colour,
   two levels above for the label-only engine.

Arrays in, arrays out; :mod:`barkgen.pipeline.files` encodes the files, the front ends write them.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.synth.edges import resolve_exemplar_wrap
from barkgen._shared.arrays import ProgressCallback
from barkgen._shared.checks import parse_output_shape

if TYPE_CHECKING:
    from barkgen.material import Light, MaterialSet
    from barkgen.synth import AnalysisCache

LABEL_METHODS = ("color", "texton")

#: the pyramid level texture-by-numbers takes up each strategy's label-map references at
#: (measured on the ten bark photos: joint at level 0/1/2 gave oak coherence 1.21/1.28/1.35x
#: plain synthesis; the label-only engine's references need two levels to fit in colour)
_INIT_LEVELS = {"joint": 0, "engine": 2}

#: share of the progress bar of each stage
_STAGES = {"analysis": (0.0, 0.5), "label_map": (0.5, 0.65), "texture": (0.65, 1.0)}


@dataclass(frozen=True)
class GenerateOptions:
    """Parameters of :func:`generate`, validated once here.

    ``size``: output ``(height, width)``; ``k``: labels of the input label map; ``method``:
    ``color`` or ``texton`` label maps; ``strategy``: ``joint`` (default), ``engine`` or
    ``layered`` output label maps (:mod:`barkgen.shapes`); ``rotations``: boundary-patch
    rotations of the layered strategy; ``tile``: tileable output; ``seed``: the one seed;
    ``label_weight`` / ``feature_weight``: texture-by-numbers weights; ``threads`` /
    ``max_memory``: solver limits; ``material``: also make the material set
    (:mod:`barkgen.material`) of the output, ``light`` the photo's
    :class:`~barkgen.material.Light` for its shading removal (``None``: estimated), ``relief``
    the height's strength (1 = as fitted); ``exemplar_wrap``: ``auto`` (the photo is used as a
    torus along each axis it tiles along, :func:`barkgen.synth.exemplar_wraps`), ``yes`` or
    ``no``.
    """

    size: tuple[int, int] = (1024, 1024)
    k: int = 3
    method: str = "color"
    strategy: str = "joint"
    rotations: str = "vertical"
    tile: bool = False
    seed: int = 0
    label_weight: float = 20.0
    feature_weight: float = 8.0
    threads: int | None = None
    max_memory: int = 8 * 1024**3
    material: bool = False
    light: Light | None = None
    relief: float = 1.0
    exemplar_wrap: str = "auto"

    def __post_init__(self) -> None:
        from barkgen._shared.checks import check_k, check_seed
        from barkgen.shapes import STRATEGIES, check_rotations
        from barkgen.synth.edges import check_wrap_mode

        check_wrap_mode(self.exemplar_wrap)
        object.__setattr__(self, "size", parse_output_shape(self.size))
        check_k(self.k)
        check_seed(self.seed)
        check_rotations(self.rotations)
        if self.method not in LABEL_METHODS:
            raise InvalidInputError(f"method must be one of {', '.join(LABEL_METHODS)}, not {self.method!r}")
        if self.strategy not in STRATEGIES:
            raise InvalidInputError(f"strategy must be one of {', '.join(STRATEGIES)}, not {self.strategy!r}")
        if self.label_weight < 0 or self.feature_weight < 0:
            raise InvalidInputError("label and feature weights must be >= 0")
        if not (np.isfinite(self.relief) and 0 < self.relief <= 100):
            raise InvalidInputError(f"relief must be in (0, 100], not {self.relief:g}")
        if self.light is not None:
            from barkgen.material import Light

            if not isinstance(self.light, Light):
                raise InvalidInputError("light must be a barkgen.material.Light (or None: estimated)")


@dataclass
class GenerateResult:
    """What :func:`generate` makes: the texture, both label maps, the reference map (output ->
    photo ``(y, x)``), the extra maps, every level of the output label map (finest first), a
    JSON-ready report of parameters, label areas and timings, and (``options.material``) the
    output's :class:`~barkgen.material.MaterialSet`."""

    texture: np.ndarray
    labels_in: np.ndarray
    labels_out: np.ndarray
    references: np.ndarray
    extras: dict
    label_levels: list
    report: dict = field(default_factory=dict)
    material: MaterialSet | None = None


def _stage_progress(progress: ProgressCallback | None, stage: str) -> ProgressCallback | None:
    if progress is None:
        return None
    lo, hi = _STAGES[stage]

    def update(done: int, total: int) -> None:
        progress(int(1000 * (lo + (hi - lo) * done / max(total, 1))), 1000)

    return update


def _fractions(label_map: np.ndarray, values: np.ndarray) -> dict[str, float]:
    return {str(int(v)): round(float(np.mean(label_map == v)), 4) for v in values}


#: seed of the photo's own analysis (the k-means of its label map): the photo's labels belong to
#: the photo, not to a variant, so every seed's output of one photo shares one analysis
ANALYSIS_SEED = 0


@dataclass
class PhotoAnalysis:
    """What :func:`generate` needs from a photo whatever the seed (laitoch2018 Figure 1.2's
    per-photo steps): the input label map, the k-coherence analyses of the label-map and
    texture solvers (mazzolini2012 §4.1.2, in an :class:`~barkgen.synth.AnalysisCache`), and
    with ``material`` the photo's own :class:`~barkgen.material.MaterialSet`. Made once by
    :func:`analyze_photo`, it serves any number of seeds (:mod:`barkgen.batch` ships it to its
    workers); ``seconds`` is what it cost."""

    labels_in: np.ndarray
    cache: AnalysisCache
    material: MaterialSet | None = None
    options: GenerateOptions | None = None
    seconds: float = 0.0


def _analysis_key(options: GenerateOptions) -> tuple:
    """The options a :class:`PhotoAnalysis` depends on."""
    light = None if options.light is None else (options.light.azimuth, options.light.elevation)
    return (options.k, options.method, options.material, light, options.relief,
            options.exemplar_wrap)


def analyze_photo(
    photo: np.ndarray,
    options: GenerateOptions | None = None,
    *,
    extra: Mapping[str, np.ndarray] | None = None,
    labels_in: np.ndarray | None = None,
    progress: ProgressCallback | None = None,
) -> PhotoAnalysis:
    """The per-photo part of :func:`generate`: the input label map (``options.k`` labels by
    ``options.method``, laitoch2018 §3.5, unless ``labels_in`` is given), the exemplar analyses
    of the output-label-map and texture-by-numbers solvers for outputs of ``options.size``, and
    with ``options.material`` the photo's material set (wang2003 §3.3-3.4). The seed plays no
    part: give the result to :func:`generate` for every seed."""
    from barkgen.labels import color_regions, texton_regions
    from barkgen.shapes import analyse_label_map
    from barkgen.synth import AnalysisCache, analyse_texture_by_numbers
    from barkgen.synth.tbn import TBN_CONFIG

    options = options or GenerateOptions()
    t0 = time.perf_counter()
    if labels_in is None:
        regions = color_regions if options.method == "color" else texton_regions
        labels_in = regions(photo, options.k, seed=ANALYSIS_SEED)
    labels_in = np.asarray(labels_in)
    if labels_in.shape[:2] != np.asarray(photo).shape[:2]:
        raise InvalidInputError(
            f"the label map is {labels_in.shape[1]}x{labels_in.shape[0]} px but the photo is "
            f"{photo.shape[1]}x{photo.shape[0]} px; they must match")
    if progress:
        progress(1, 4)
    wrap = resolve_exemplar_wrap(options.exemplar_wrap, photo)
    cache = AnalysisCache()
    if options.strategy in _INIT_LEVELS:
        analyse_label_map(labels_in, options.size, cache,
                          photo=photo if options.strategy == "joint" else None, exemplar_wrap=wrap)
    if progress:
        progress(2, 4)
    analyse_texture_by_numbers(photo, labels_in, options.size, cache,
                               feature_weight=options.feature_weight, extra=extra,
                               config=dataclasses.replace(TBN_CONFIG, threads=options.threads),
                               exemplar_wrap=wrap)
    if progress:
        progress(3, 4)
    material = _photo_material(photo, labels_in, options) if options.material else None
    if progress:
        progress(4, 4)
    return PhotoAnalysis(labels_in=labels_in, cache=cache, material=material, options=options,
                         seconds=time.perf_counter() - t0)


def generate(
    photo: np.ndarray,
    options: GenerateOptions | None = None,
    *,
    extra: Mapping[str, np.ndarray] | None = None,
    labels_in: np.ndarray | None = None,
    resume: np.ndarray | tuple[int, np.ndarray] | None = None,
    progress: ProgressCallback | None = None,
    analysis: PhotoAnalysis | None = None,
) -> GenerateResult:
    """Turn a bark photo into new bark of ``options.size`` (laitoch2018 Figure 1.2).

    Args:
        photo: ``(h, w, 3)`` or ``(h, w)`` bark photo (uint8, uint16 or float).
        options: :class:`GenerateOptions` (defaults: 1024x1024, k = 3, colour labels, joint
            label maps, not tileable, seed 0).
        extra: maps aligned with the photo (height, ...), synthesized along.
        labels_in: the photo's label map, when the user has one (then ``k`` and ``method`` are
            not used).
        resume: an edited level of the output label map to continue from
            (:func:`barkgen.shapes.synthesize_label_map`).
        progress: optional ``progress(done, total)`` callback over the whole run.
        analysis: the photo's :class:`PhotoAnalysis` from :func:`analyze_photo` with the same
            photo, extras and options (the seed aside), to skip the per-photo work; the result
            is the same bytes as without it.
    """
    from barkgen.shapes import synthesize_label_map
    from barkgen.synth import texture_by_numbers
    from barkgen.synth.tbn import TBN_CONFIG

    options = options or GenerateOptions()
    timings: dict[str, float] = {}
    if analysis is None:
        analysis = analyze_photo(photo, options, extra=extra, labels_in=labels_in,
                                 progress=_stage_progress(progress, "analysis"))
    else:
        if labels_in is not None:
            raise InvalidInputError("give the label map to analyze_photo, not with an analysis")
        if analysis.options is not None and _analysis_key(analysis.options) != _analysis_key(options):
            raise InvalidInputError("the photo analysis was made with other options (k, method, "
                                    "material, light, relief); analyse the photo again")
        if analysis.labels_in.shape[:2] != np.asarray(photo).shape[:2]:
            raise InvalidInputError("the photo analysis belongs to a photo of another size")
    labels_in = analysis.labels_in
    t1 = time.perf_counter()
    timings["analysis"] = analysis.seconds
    wrap = resolve_exemplar_wrap(options.exemplar_wrap, photo)

    label_result = synthesize_label_map(
        labels_in, options.size, strategy=options.strategy, tile=options.tile, seed=options.seed,
        rotations=options.rotations, resume=resume, progress=_stage_progress(progress, "label_map"),
        cache=analysis.cache, photo=photo, exemplar_wrap=wrap)
    t2 = time.perf_counter()
    timings["labels_out"] = t2 - t1

    config = dataclasses.replace(TBN_CONFIG, threads=options.threads, max_memory=options.max_memory)
    # the engines' label maps copy exemplar label pieces: the same pieces of the photo are a
    # label-exact, coherent start for texture-by-numbers (else its smart initialisation)
    init = label_result.references if label_result.references is not None else "smart"
    result = texture_by_numbers(
        photo, labels_in, label_result.label_map, label_weight=options.label_weight,
        feature_weight=options.feature_weight, init=init,
        init_level=_INIT_LEVELS.get(options.strategy, 0), tile=options.tile, seed=options.seed,
        extra=extra, config=config, progress=_stage_progress(progress, "texture"),
        cache=analysis.cache, exemplar_wrap=wrap)
    t3 = time.perf_counter()
    timings["texture"] = t3 - t2
    material = None
    if options.material:
        from barkgen.material import transfer_material

        source = analysis.material
        if source is None:
            source = _photo_material(photo, labels_in, options)
        material = transfer_material(source, result.references, tile=options.tile,
                                     exemplar_wrap=wrap)
        timings["material"] = time.perf_counter() - t3
    # the analysis' own cost counts whether it ran here or was shared
    timings["total"] = analysis.seconds + time.perf_counter() - t1

    values = np.unique(labels_in)
    report = {
        "size": [options.size[1], options.size[0]],
        "photo_size": [int(np.asarray(photo).shape[1]), int(np.asarray(photo).shape[0])],
        "k": int(values.size),
        "method": options.method,
        "strategy": options.strategy,
        "rotations": options.rotations,
        "layer_order": label_result.layer_order,
        "tile": bool(options.tile),
        "exemplar_wrap_mode": options.exemplar_wrap,
        "exemplar_wrap": [bool(wrap[0]), bool(wrap[1])],
        "seed": int(options.seed),
        "label_weight": options.label_weight,
        "feature_weight": options.feature_weight,
        "texture_init": "label map references" if label_result.references is not None else "smart",
        "extras": sorted(result.extras),
        "resumed_from_level": label_result.resumed_level,
        "label_fractions_in": _fractions(labels_in, values),
        "label_fractions_out": _fractions(label_result.label_map, values),
        "material": bool(options.material),
        "relief": options.relief if options.material else None,
        "light": None if material is None or material.light is None else [material.light.azimuth,
                                                                        material.light.elevation],
        "timings_s": {name: round(value, 3) for name, value in timings.items()},
    }
    return GenerateResult(texture=result.image, labels_in=labels_in,
                          labels_out=label_result.label_map, references=result.references,
                          extras=result.extras, label_levels=label_result.levels, report=report,
                          material=material)


def _photo_material(photo: np.ndarray, labels_in: np.ndarray, options: GenerateOptions):
    """The photo's own material set, its label map as the height's structure cue."""
    from barkgen.labels.regions import to_codes
    from barkgen.material import MaterialOptions, make_material

    return make_material(photo, MaterialOptions(k=options.k, light=options.light, seed=ANALYSIS_SEED,
                                                relief=options.relief),
                         label_map=to_codes(labels_in)[0])


def preview_sheet(photo: np.ndarray, result: GenerateResult, tile_size: int = 320) -> np.ndarray:
    """The contact sheet of a run: photo, input labels, output labels, result."""
    from barkgen.labels import contact_sheet, label_colour_map
    from barkgen._shared.arrays import as_uint8

    values = np.unique(result.labels_in)
    tiles = [as_uint8(photo), label_colour_map(result.labels_in, values),
             label_colour_map(result.labels_out, values), as_uint8(result.texture)]
    return contact_sheet(tiles, ["photo", "labels in", "labels out", "result"], columns=4,
                         tile_size=tile_size)
