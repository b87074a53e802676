"""Texture-by-numbers: label-guided synthesis (laitoch2018 §3.1–3.4, after Fan et al. 2012).

Image analogies ``A : A' :: B : B'`` with discrete label maps: the exemplar ``A'`` comes with its
label map ``A``; the output ``B'`` is synthesized to follow the target label map ``B``. It runs
the same k-coherence discrete solver as :func:`barkgen.synth.synthesize` (same reference maps,
same extra channels), with

* the label term of eq. 3.2 in every M-step (a candidate pays for each neighbourhood pixel whose
  exemplar label differs from the wanted one), and candidates drawn from the wanted label's
  exemplar pixels, so a label can appear where the current content has none;
* the feature-distance map (Lefebvre & Hoppe 2006), the distance to the nearest label boundary,
  as a weighted extra matching channel (eq. 3.3);
* label-aware votes in the E-step and per-label occurrence costs (each label's exemplar pixels are
  used evenly for that label's output area);
* the "smart" initialisation of §3.4.2 (seeded region growing under eq. 3.6) or the random one of
  §3.4.1 at the coarsest level.

Nothing is averaged: outputs are resolved from references, so they are as sharp as the exemplar
(the blur of laitoch2018 §4.2–4.3 cannot occur).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from barkgen._shared.arrays import as_uint8
from barkgen._shared.canvas import Budget, Canvas
from barkgen.errors import InvalidInputError
from barkgen.pyramid import count_levels, gaussian_pyramid, level_shape
from barkgen.synth._analysis import AnalysisCache, matching_features
from barkgen.synth._config import TBN_CONFIG, SynthesisConfig
from barkgen.synth._edges import resolve_exemplar_wrap
from barkgen.synth._setup import Front, SolveSetup, extra_inputs, set_up, validate_inputs
from barkgen.synth._solver import DebugCallback, SynthesisResult
from barkgen.synth._windows import WINDOWED_LEVELS
from barkgen.synth.guides.channels import (
    THIN_LABEL_WEIGHT,
    LabelMaps,
    boundary_distance,
    encode_label_maps,
    label_pyramid,
    level_guide,
    soft_labels,
    thin_codes,
    thin_label_channels,
)
from barkgen.synth.guides.guidance import Guidance
from barkgen.synth.guides.initialization import random_initialization, smart_initialization
from barkgen.synth.guides.target import target_guide_pyramid

INITIALIZATIONS = ("smart", "random")

#: a reference map given as ``init`` is taken up at this pyramid level (0 = finest) unless a pair
#: ``(references, level)`` says otherwise: its coarser structure is kept, the solver refines the
#: finer levels
REFERENCE_START_LEVEL = 2

#: the feature-distance channel measures up to this many (full-resolution) pixels from an edge
FEATURE_DISTANCE_CLIP = 16.0


def feature_distance_channel(
    exemplar_labels: np.ndarray, colour_variance: float, feature_weight: float, wrap: tuple[bool, bool] = (False, False)
) -> np.ndarray:
    """The feature-distance map as a matching channel (laitoch2018 eq. 3.3): distance to the
    nearest label boundary (across the photo's edge where it wraps, ``wrap``), capped at
    :data:`FEATURE_DISTANCE_CLIP` px and scaled so a difference of the full cap costs
    ``feature_weight`` times the exemplar's colour variance."""
    dist = boundary_distance(exemplar_labels, FEATURE_DISTANCE_CLIP, wrap=wrap)
    scale = np.sqrt(max(feature_weight, 0.0) * colour_variance) / FEATURE_DISTANCE_CLIP
    return (dist * np.float32(scale))[:, :, None]


def _label_colours(n_labels: int) -> np.ndarray:
    """Distinct uint8 RGB colours for debug images of label maps (hues a golden angle apart)."""
    import cv2

    hue = (np.arange(n_labels) * 0.618034 % 1.0 * 180).astype(np.uint8)
    hsv = np.stack([hue, np.full(n_labels, 200, np.uint8), np.full(n_labels, 230, np.uint8)], -1)
    return cv2.cvtColor(hsv[None], cv2.COLOR_HSV2RGB)[0]


def _level_references(
    references, out_shape: tuple[int, int], exemplar_shape: tuple[int, int], level: int
) -> np.ndarray:
    """A full-resolution reference map brought to pyramid ``level``: every ``2**level``-th
    output pixel's exemplar position, scaled down, as flat indices into the level's exemplar."""
    refs = np.asarray(references)
    if refs.shape != out_shape + (2,) or not np.issubdtype(refs.dtype, np.integer):
        raise InvalidInputError(
            f"an initial reference map must be an integer array of shape {out_shape + (2,)}, not "
            f"{refs.dtype} {refs.shape}"
        )
    if refs.min() < 0 or (refs[..., 0] >= exemplar_shape[0]).any() or (refs[..., 1] >= exemplar_shape[1]).any():
        raise InvalidInputError("the initial reference map points outside the exemplar")
    lh, lw = level_shape(exemplar_shape, level)
    f = 1 << level
    ry = np.minimum(refs[::f, ::f, 0] >> level, lh - 1)
    rx = np.minimum(refs[::f, ::f, 1] >> level, lw - 1)
    return np.ascontiguousarray(ry * lw + rx, dtype=np.int32)


def texture_by_numbers(
    exemplar: np.ndarray,
    exemplar_labels: np.ndarray,
    target_labels: np.ndarray,
    *,
    label_weight: float = 20.0,
    feature_weight: float = 8.0,
    init: str | np.ndarray | tuple[np.ndarray, int] = "smart",
    thin_labels: Sequence = (),
    extra: Mapping[str, np.ndarray] | None = None,
    config: SynthesisConfig | None = None,
    canvas: Canvas | None = None,
    budget: Budget | None = None,
) -> SynthesisResult:
    """Synthesize a texture that follows ``target_labels`` from ``exemplar`` and its labels.

    Texture-by-numbers (A : A' :: B : B'): the discrete solver guided by both label maps,
    started by region growing (laitoch2018 §3.4.2), with a feature-distance channel (eq. 3.3).

    Parameters
    ----------
    exemplar : ndarray
        ``(h, w)`` or ``(h, w, C)`` array (uint8, uint16 or float), C = 1 or 3.
    exemplar_labels : ndarray
        Label map of the exemplar, same ``(h, w)``; each distinct grey value or colour is a
        label (at most 64).
    target_labels : ndarray
        Label map of the wanted output; its size is the output size and every label in it
        must occur in ``exemplar_labels``.
    label_weight : float, optional
        ``w`` of laitoch2018 eq. 3.1: cost of one mismatching label pixel, in units of the
        exemplar's colour variance.
    feature_weight : float, optional
        ``z`` of eq. 3.3: weight of the feature-distance channel, same units.
    init : {"smart", "random"}, ndarray or (ndarray, int), optional
        ``"smart"`` (§3.4.2, region growing), ``"random"`` (§3.4.1), an ``(H, W, 2)``
        reference map to start from, e.g. a :class:`barkgen.shapes.LabelMapResult`'s, taken up
        at pyramid level :data:`REFERENCE_START_LEVEL`, or a pair ``(references, level)`` that
        says the level (0 = finest; the coarsest when the pyramid is shorter): the solver
        refines it there and below.
    thin_labels : sequence of label values, optional
        Labels drawn as thin lines, 1-3 px wide (a crack network's raster): each pyramid level
        also matches their proximity and direction
        (:func:`~barkgen.synth.guides.channels.thin_label_channels`, weighted
        :data:`~barkgen.synth.guides.channels.THIN_LABEL_WEIGHT` of a label mismatch), which
        survive the down-sampling that loses the lines themselves. Not along a flow field.
    extra : mapping of str to ndarray, optional
        Named maps aligned with the exemplar (height, ...), synthesized along.
    config : SynthesisConfig, optional
        Solver parameters; default :data:`TBN_CONFIG`.
    canvas : Canvas, optional
        The output (:class:`barkgen.Canvas`): ``shape`` (the target label map's), ``tile``
        (the target is then read as a torus too), the exemplar's wrap (default ``"auto"``: a
        torus along the axes it tiles along, :func:`barkgen.synth.exemplar_wraps`), and
        ``flow``, ``flow_scale`` (an ``(H, W)`` orientation field, degrees counter-clockwise on
        screen: the exemplar's turn at each output pixel, and a scale field, 1 = the
        exemplar's: the texture is synthesized in that local frame, :mod:`barkgen.synth._flow`;
        the labels then are the pairs (label, turned copy), so the fields' turns and scales
        times the labels must stay under 64) and ``links`` (output pixels that take the
        references of others while the solver runs: a texture atlas's gutters,
        :class:`barkgen.synth.OutputLinks`). Default: the target's shape, not tiled.
    budget : Budget, optional
        ``seed``, ``progress(done, total)``, ``debug(name, image)`` (intermediate images,
        uint8) and ``cache`` (holds or keeps the exemplar's k-coherence analysis, e.g. from
        :func:`analyse_texture_by_numbers`) (:class:`barkgen.Budget`; default seed 0).

    Returns
    -------
    SynthesisResult
        Image, references and extras; along a flow field, the references point into the atlas
        of turned copies (``result.orientation``).

    Raises
    ------
    InvalidInputError, MemoryBudgetError
        As :func:`barkgen.synthesize`; also label maps that do not fit (size, label set).

    References
    ----------
    .. [1] laitoch2018, §3.3-3.4 (texture-by-numbers, eqs. 3.1-3.6).
    .. [2] bonneel2010 (the region-growing first pass of the smart initialisation).

    Examples
    --------
    See ``examples/03_texture_by_numbers.py``.

    """
    target = _check_arguments(target_labels, init, label_weight, feature_weight)
    canvas = _target_canvas(canvas, target)
    budget = budget or Budget()
    thin_labels = tuple(thin_labels)
    if canvas.along and thin_labels:
        raise InvalidInputError("thin_labels are not matched along a flow field; leave them out there")
    if canvas.along:
        return along_flow(
            exemplar,
            (exemplar_labels, target_labels),
            extra,
            canvas,
            budget,
            label_weight=label_weight,
            feature_weight=feature_weight,
            init=init,
            config=config,
        )
    config = config or TBN_CONFIG
    front = _LabelFront(exemplar_labels, target, feature_weight)
    setup = set_up(exemplar, extra, config, canvas, budget, front=front)
    guidance, start = _guidance(front, setup, label_weight, init, thin_labels)
    # (a reference map handed over is not held through the solve: its start is made)
    del init
    return setup.solve(guidance=guidance, start=start)


def _guidance(
    front: _LabelFront, setup: SolveSetup, label_weight: float, init, thin_labels: tuple = ()
) -> tuple[Guidance, Any]:
    """The solver's guide from both label maps (laitoch2018 eq. 3.2's label channels and their
    pyramids, and the ``thin_labels``' proximity and direction) and the start a given ``init``
    makes (else None; §3.4)."""
    labels, colour_variance = front.labels, front.colour_variance
    assert labels is not None  # set_up checked the exemplar: front.check encoded the maps
    wrap, n_levels, tile, debug = setup.wrap, setup.inputs.n_levels, setup.canvas.tile, setup.budget.debug
    # a pixel whose soft label differs completely costs label_weight x the colour variance
    scale = np.sqrt(label_weight * colour_variance / 2.0)
    recipe, guide_a = soft_labels(labels.exemplar, labels.n_labels, scale, exemplar_wrap=wrap)
    if thin_labels:
        thin, weight = thin_codes(labels.palette, thin_labels), np.float32(THIN_LABEL_WEIGHT * scale)
        guide_b = recipe(labels.target, tile)
        guide_a = np.concatenate([guide_a, thin_label_channels(labels.exemplar, thin, wrap=wrap) * weight], axis=2)
        guide_b = np.concatenate([guide_b, thin_label_channels(labels.target, thin, wrap=tile) * weight], axis=2)
        target_guides = gaussian_pyramid(guide_b, n_levels, (tile, tile))
    else:
        # a windowed solve reads its finest levels' target guide a window at a time: made there
        # from the labels (issue 69: 4 B a pixel a label less), the same values
        windowed = WINDOWED_LEVELS if setup.inputs.config.window else 0
        target_guides = target_guide_pyramid(labels.target, recipe, n_levels, tile, windowed)
    pyr_a = label_pyramid(labels.exemplar, labels.n_labels, n_levels)
    pyr_b = label_pyramid(labels.target, labels.n_labels, n_levels)
    guides = [level_guide(a, b, labels.n_labels) for a, b in zip(pyr_a, pyr_b)]
    if debug is not None:
        _show_labels(debug, labels, pyr_a, pyr_b, wrap)
    start, initial = _start(init, n_levels, setup.exemplar.shape[:2], setup.canvas)
    guidance = Guidance(
        levels=guides,
        exemplar_guides=gaussian_pyramid(guide_a, n_levels, wrap),
        target_guides=target_guides,
        initial_references=initial,
    )
    return guidance, start


def _target_canvas(canvas: Canvas | None, target: np.ndarray) -> Canvas:
    """The canvas of a target label map: the given one, which must be of its size, or its own
    (not tiled, the exemplar's wrap ``"auto"``)."""
    shape = tuple(target.shape[:2])
    if canvas is None:
        return Canvas(shape)
    if canvas.shape != shape:
        raise InvalidInputError(
            f"the canvas is {canvas.shape[1]}x{canvas.shape[0]} px but the target label map is "
            f"{shape[1]}x{shape[0]} px; they must match"
        )
    return canvas


def along_flow(
    exemplar: np.ndarray,
    labels: tuple[np.ndarray, np.ndarray] | None,
    extra: Mapping[str, np.ndarray] | None,
    canvas: Canvas,
    budget: Budget,
    **options,
) -> SynthesisResult:
    """:func:`texture_by_numbers` (or, without ``labels``, plain synthesis) along the fields
    ``canvas.flow`` and ``canvas.flow_scale``: on the atlas of the exemplar's turned and scaled
    copies, each output pixel wanting the copy of its turn and scale
    (:func:`barkgen.synth._flow.oriented_inputs`; ``canvas.oriented``: a given atlas of
    copies); ``options``: texture-by-numbers' own."""
    from barkgen.synth._flow import check_flow, oriented_inputs

    ex, out_shape, extras = validate_inputs(exemplar, canvas.shape, budget, extra)
    fields = check_flow(canvas.flow, canvas.flow_scale, out_shape)
    wrap = resolve_exemplar_wrap(canvas.wrap_mode, ex)
    inputs = oriented_inputs(ex, *fields, wrap=wrap, extra=extras, labels=labels, oriented=canvas.oriented)
    links = canvas.links
    atlas_canvas = Canvas(
        out_shape,
        tile=canvas.tile,
        exemplar_wrap=(False, False),
        links=None if links is None else links.oriented_by(inputs.oriented, inputs.copies),
    )
    result = texture_by_numbers(
        inputs.exemplar,
        inputs.exemplar_labels,
        inputs.target_labels,
        extra=inputs.extras,
        canvas=atlas_canvas,
        budget=budget,
        **options,
    )
    result.orientation = inputs.oriented
    if np.ndim(exemplar) == 2:  # as flat as the exemplar was given
        result.image = result.image[..., 0]
    return result


class _LabelFront(Front):
    """Texture-by-numbers' part of the set-up (:func:`barkgen.synth._setup.set_up`): the label
    maps checked against the validated exemplar and encoded over one palette, and the
    feature-distance channel (laitoch2018 eq. 3.3) matched along with the colour; keeps the
    encoded maps (``labels``) and the exemplar's colour variance for the guide channels."""

    added_channels = 1
    guided = True

    def __init__(self, exemplar_labels: np.ndarray, target: np.ndarray, feature_weight: float) -> None:
        self.exemplar_labels = exemplar_labels
        self.target = target
        self.feature_weight = feature_weight
        self.labels: LabelMaps | None = None
        self.colour_variance = 0.0

    def check(self, ex: np.ndarray) -> None:
        self.labels = encode_label_maps(self.exemplar_labels, self.target, ex.shape[:2])

    def features(
        self,
        ex: np.ndarray,
        extras: Mapping[str, np.ndarray],
        wrap: tuple[bool, bool],
        config: SynthesisConfig,
        cache: AnalysisCache | None = None,
    ) -> np.ndarray:
        labels = self.labels
        assert labels is not None  # check runs first

        def make() -> tuple[np.ndarray, float]:
            return _matching_features(ex, extras, labels.exemplar, self.feature_weight, config, wrap)

        if cache is None:
            feats, self.colour_variance = make()
        else:
            inputs = (ex, labels.exemplar, self.feature_weight, config.extra_weight, wrap, *extra_inputs(extras))
            feats, self.colour_variance = cache.features("labelled", inputs, make)
        return feats


def _start(init, n_levels: int, exemplar_shape: tuple[int, int], canvas: Canvas):
    """``(start, initial)``: the level and reference map a given ``init`` starts from (else
    None), and the initialisation of the coarsest level otherwise (laitoch2018 §3.4); ``canvas``
    with the exemplar's resolved wrap."""
    if not isinstance(init, str):
        references, init_level = init if isinstance(init, tuple) else (init, REFERENCE_START_LEVEL)
        level = min(int(init_level), n_levels - 1)
        # (the initialisation is not used: the solver starts from the given level)
        return (level, _level_references(references, canvas.shape, exemplar_shape, level)), random_initialization
    if init == "smart":

        def initial(a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> np.ndarray:
            return smart_initialization(a, b, rng, canvas)

        return None, initial
    return None, random_initialization


def _check_arguments(target_labels, init, label_weight: float, feature_weight: float) -> np.ndarray:
    """:func:`texture_by_numbers`' own arguments checked; the target label map as an array."""
    if isinstance(init, tuple):
        if len(init) != 2:
            raise InvalidInputError("init as a pair must be (reference map, pyramid level)")
        init_level = init[1]
        if not isinstance(init_level, (int, np.integer)) or init_level < 0:
            raise InvalidInputError(f"init_level must be a pyramid level >= 0, not {init_level!r}")
    if isinstance(init, str) and init not in INITIALIZATIONS:
        raise InvalidInputError(f"init must be one of {', '.join(INITIALIZATIONS)} or a reference map, not {init!r}")
    for name, value in (("label_weight", label_weight), ("feature_weight", feature_weight)):
        if not isinstance(value, (int, float, np.number)) or not np.isfinite(value) or value < 0:
            raise InvalidInputError(f"{name} must be a non-negative number, not {value!r}")
    target = np.asarray(target_labels)
    if target.ndim not in (2, 3):
        raise InvalidInputError(f"target label map must be an (H, W) or (H, W, C) image, not shape {target.shape}")
    return target


def _show_labels(debug: DebugCallback, labels, pyr_a: list, pyr_b: list, wrap: tuple[bool, bool]) -> None:
    """The label pyramids and the feature-distance map, to the ``debug`` callback."""
    colours = _label_colours(labels.n_labels)
    for lvl, (a, b) in enumerate(zip(pyr_a, pyr_b)):
        debug(f"level{lvl}_exemplar_labels", colours[a])
        debug(f"level{lvl}_target_labels", colours[b])
    debug(
        "feature_distance",
        as_uint8(boundary_distance(labels.exemplar, FEATURE_DISTANCE_CLIP, wrap=wrap) / FEATURE_DISTANCE_CLIP),
    )


def _matching_features(
    ex: np.ndarray,
    extras: Mapping[str, np.ndarray],
    exemplar_codes: np.ndarray,
    feature_weight: float,
    config: SynthesisConfig,
    wrap: tuple[bool, bool],
) -> tuple[np.ndarray, float]:
    """What texture-by-numbers matches in the exemplar: colour (+ extras) and the
    feature-distance channel (round the exemplar's ``wrap``); returns them and the exemplar's
    colour variance."""
    feats = matching_features(ex, extras, config.extra_weight)
    n_colour = 3 if ex.shape[2] == 3 else 1
    colour_variance = float(feats[:, :, :n_colour].reshape(-1, n_colour).var(axis=0).sum())
    fdm = feature_distance_channel(exemplar_codes, colour_variance, feature_weight, wrap)
    return np.ascontiguousarray(np.concatenate([feats, fdm], axis=2), dtype=np.float32), colour_variance


def analyse_texture_by_numbers(
    exemplar: np.ndarray,
    exemplar_labels: np.ndarray,
    size,
    cache: AnalysisCache,
    *,
    feature_weight: float = 8.0,
    extra: Mapping[str, np.ndarray] | None = None,
    config: SynthesisConfig | None = None,
    exemplar_wrap: str | bool | tuple[bool, bool] = "auto",
) -> AnalysisCache:
    """Run the analysis phase :func:`texture_by_numbers` needs for outputs of ``size``.

    The k-coherence analysis (mazzolini2012 §4.1.2) goes into ``cache``, ahead of any
    synthesis. Every later call with the same exemplar, labels, extras, ``feature_weight``,
    config and output pyramid depth then skips it, whatever its seed or target label map.

    Parameters
    ----------
    exemplar, exemplar_labels : ndarray
        As for :func:`texture_by_numbers`.
    size : int or tuple of int
        The output ``(height, width)`` the analysis is for (it sets the pyramid depth).
    cache : AnalysisCache
        Receives the analysis.
    feature_weight, extra, config, exemplar_wrap
        As for :func:`texture_by_numbers`.

    Returns
    -------
    AnalysisCache
        ``cache``, now holding the analysis.

    References
    ----------
    .. [1] mazzolini2012, §4.1.2 (the analysis phase of k-coherence search).
    """
    config = config or TBN_CONFIG
    ex, out_shape, extras = validate_inputs(exemplar, size, Budget(), extra)
    labels = encode_label_maps(exemplar_labels, exemplar_labels, ex.shape[:2])
    wrap = resolve_exemplar_wrap(exemplar_wrap, ex)
    feats, _ = _matching_features(ex, extras, labels.exemplar, feature_weight, config, wrap)
    cache.analyse(feats, count_levels(ex.shape[:2], out_shape, config.coarsest_exemplar), config, wrap=wrap)
    return cache
