"""The label-map synthesis API: strategies, resumable pyramid levels and the shared analysis
(see :mod:`barkgen.shapes` for the strategies)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from barkgen._shared.canvas import Budget, Canvas
from barkgen._shared.checks import check_seed, parse_output_shape
from barkgen._shared.memory import BASE_BYTES, check_budget_value, check_memory_budget
from barkgen.errors import InvalidInputError
from barkgen.labels.regions import to_codes
from barkgen.pyramid import count_levels, level_shape
from barkgen.shapes.binary import ShapeConfig
from barkgen.shapes.layered import automatic_layer_order
from barkgen.shapes.patches import check_rotations
from barkgen.synth import AnalysisCache, label_pyramid

#: the label-map strategies (see :mod:`barkgen.shapes`)
STRATEGIES = ("engine", "joint", "layered")
#: bytes per exemplar and per output pixel of the layered strategy (its per-layer masks, ranks
#: and boundary weights; measured peaks from the 1024x1024 sample's label map: 1024x1024 out
#: 0.29 GiB, 2048x2048 0.34 GiB, i.e. 17 bytes per output pixel over the interpreter's base)
LAYERED_BYTES_PER_PIXEL = 48


def estimate_label_map_memory(
    exemplar_shape: tuple[int, int], out_shape: tuple[int, int], strategy: str, n_labels: int
) -> int:
    """Estimated peak memory (bytes) of :func:`synthesize_label_map`, from the sizes alone."""
    if strategy in ("engine", "joint"):
        from barkgen.shapes.engine import estimate_engine_memory

        return estimate_engine_memory(exemplar_shape, out_shape, n_labels, joint=strategy == "joint")
    n_ex, n_out = exemplar_shape[0] * exemplar_shape[1], out_shape[0] * out_shape[1]
    return BASE_BYTES + LAYERED_BYTES_PER_PIXEL * (n_ex + n_out)


@dataclass
class LabelMapResult:
    """A synthesized label map and what came with it.

    Attributes
    ----------
    label_map : ndarray of uint8, shape (H, W)
        Grey values of the exemplar's palette.
    levels : list of ndarray or None
        Every pyramid level's map (``levels[l]`` for level ``l``, 0 = finest; levels above a
        resumed one are None).
    strategy : str
        The strategy used.
    layer_order : list of int or None
        Layered strategy: the layer order, bottom label value first.
    references : ndarray of int32, shape (H, W, 2), or None
        Engine and joint strategies: the exemplar label pixels the map copies.
    resumed_level : int or None
        The level resumed from.
    synthesis : SynthesisResult or None
        Along a flow field with the joint strategy: the photo synthesized with its labels, the
        run whose references the label map follows (its image is a texture that fits the map).
    timings : dict
        Seconds.
    """

    label_map: np.ndarray
    levels: list
    strategy: str
    layer_order: list[int] | None = None
    references: np.ndarray | None = None
    resumed_level: int | None = None
    timings: dict = field(default_factory=dict)
    synthesis: Any = None


def label_map_levels(
    exemplar_shape: tuple[int, int], size, strategy: str = "engine", config: ShapeConfig | None = None
) -> list[tuple[int, int]]:
    """The ``(height, width)`` of every pyramid level of an output label map, finest first.

    Parameters
    ----------
    exemplar_shape : (int, int)
        ``(h, w)`` of the exemplar's label map.
    size : int or (int, int)
        Output ``(height, width)``.
    strategy : {"engine", "joint", "layered"}, default "engine"
        The strategy (their pyramids differ).
    config : ShapeConfig, optional
        The layered strategy's parameters.

    Returns
    -------
    list of (int, int)
        Level 0 (the output size) first; an edited level for ``resume=`` must have one of these
        sizes.

    Examples
    --------
    >>> label_map_levels((128, 128), 256, "layered")
    [(256, 256), (128, 128), (64, 64)]
    """
    out_shape = parse_output_shape(size)
    if strategy in ("engine", "joint"):
        from barkgen.shapes.engine import engine_levels

        n = engine_levels(exemplar_shape, out_shape, joint=strategy == "joint")
    else:
        n = count_levels(exemplar_shape, out_shape, (config or ShapeConfig()).coarsest_exemplar)
    return [level_shape(out_shape, lvl) for lvl in range(n)]


def _resume_codes(resume, palette: np.ndarray, shapes: list[tuple[int, int]]) -> tuple[int, np.ndarray]:
    if isinstance(resume, tuple):
        level, edited = resume
    else:  # the level is the one of the edited map's size
        edited = resume
        level = next((i for i, s in enumerate(shapes) if s == np.asarray(edited).shape[:2]), -1)
    codes, values = to_codes(edited)
    if not 0 <= int(level) < len(shapes) or codes.shape != shapes[int(level)]:
        sizes = ", ".join(f"level {i}: {w}x{h}" for i, (h, w) in enumerate(shapes))
        raise InvalidInputError(
            f"the edited level is {codes.shape[1]}x{codes.shape[0]} px, which is not "
            f"{'a level' if level < 0 else f'level {int(level)}'} of this output ({sizes})"
        )
    unknown = np.setdiff1d(values, palette)
    if unknown.size:
        shown = ", ".join(str(int(v)) for v in unknown[:8])
        raise InvalidInputError(
            f"the edited level uses grey value(s) {shown} that are not labels of the exemplar "
            f"label map ({', '.join(str(int(v)) for v in palette)})"
        )
    return int(level), np.searchsorted(palette, values)[codes].astype(np.int32)


def _layer_order_codes(layer_order, palette: np.ndarray) -> list[int]:
    """A user's layer order (grey values, bottom first) as label codes; every label once."""
    values = ", ".join(str(int(v)) for v in palette)
    order = [int(v) for v in layer_order]
    unknown = [v for v in order if v not in set(int(p) for p in palette)]
    if unknown:
        raise InvalidInputError(f"layer order value(s) {unknown} are not labels of the label map ({values})")
    if sorted(order) != sorted(int(v) for v in palette):
        raise InvalidInputError(f"the layer order must list each label ({values}) once, not {order}")
    return [int(np.searchsorted(palette, v)) for v in order]


def synthesize_label_map(
    label_map: np.ndarray,
    size=None,
    *,
    strategy: str = "engine",
    photo: np.ndarray | None = None,
    canvas: Canvas | None = None,
    budget: Budget | None = None,
    rotations: str = "vertical",
    layer_order: list[int] | None = None,
    resume: tuple[int, np.ndarray] | np.ndarray | None = None,
    config: ShapeConfig | None = None,
    window: int = 0,
) -> LabelMapResult:
    """Synthesize a new label map of ``size`` from the exemplar's ``label_map`` (laitoch2018 §3.6).

    Parameters
    ----------
    label_map : ndarray, shape (h, w)
        Grey label map (every distinct value is a label, at most 64).
    size : int or (int, int), optional
        Output ``(height, width)`` (default: ``canvas.shape``).
    strategy : {"engine", "joint", "layered"}, default "engine"
        The core engine on one-hot label channels; the engine matching ``photo``'s colours too;
        or Rosenberger et al.'s layered shape synthesis.
    photo : ndarray, optional
        The photo ``label_map`` labels (same height and width); the joint strategy needs it.
    canvas : Canvas, optional
        What the output is (default: a plain ``size`` canvas): ``tile`` (the label map wraps
        around, so its texture can tile); ``exemplar_wrap`` (the exemplar used as a torus
        along each axis; None: ``"auto"``, the photo or else the label map decides,
        :func:`barkgen.synth.exemplar_wraps`); the engine and joint strategies' ``flow`` and
        ``flow_scale`` fields (as :func:`barkgen.synthesize`'s: the references then point into
        the atlas of the exemplar's turned copies, and there are no coarser levels) and
        ``links`` (along them, output pixels that take others' references).
    budget : Budget, optional
        ``seed`` (every random choice), ``progress`` (``progress(done, total)``), ``cache``
        (the engine strategies' exemplar analysis, :func:`analyse_label_map`) and
        ``max_memory`` (refuse the job, before any work, when its estimated peak memory,
        :func:`estimate_label_map_memory`, exceeds it; None: what the machine has free).
    rotations : {"none", "vertical", "all"}, default "vertical"
        Boundary patches may match turned 180° or four ways (layered strategy, eq. 3.7).
    layer_order : list of int, optional
        Label values, bottom layer first (layered strategy; automatic when None).
    resume : (int, ndarray) or ndarray, optional
        An edited pyramid level to continue from: ``(level, label_map)`` or just the map (its
        size tells the level, :func:`label_map_levels`), in the exemplar's grey values.
    config : ShapeConfig, optional
        Parameters of the layered strategy.
    window : int, default 0
        Engine and joint strategies: side (px) of the windows that their large finest levels
        are solved and their seams moved in, each with a halo from its neighbours, so that
        their working memory is a window's, not the output's (issue 69; as
        :class:`~barkgen.synth.SynthesisConfig`'s ``window``); 0: whole.

    Returns
    -------
    LabelMapResult

    Raises
    ------
    InvalidInputError
        A bad strategy, rotations, seed, size, layer order, edited level or photo.
    MemoryBudgetError
        The job would not fit ``budget.max_memory``.

    References
    ----------
    .. [1] laitoch2018, §3.6 and Figure 1.2's "output label map"; rosenberger2009 (layered).
    .. [2] kopf2007 (the label-area histogram matching of the joint strategy).

    """
    if strategy not in STRATEGIES:
        raise InvalidInputError(f"strategy must be one of {', '.join(STRATEGIES)}, not {strategy!r}")
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 0:
        raise InvalidInputError(f"window must be a side in px (0: none), not {window!r}")
    turns = check_rotations(rotations)
    budget = budget or Budget()
    check_seed(budget.seed)
    check_budget_value(budget.max_memory)
    canvas = _output_canvas(size, canvas)
    codes, palette = to_codes(label_map)
    photo = _check_photo(photo, codes.shape, strategy)
    _check_memory(codes.shape, canvas.shape, strategy, palette.size, budget.max_memory)
    config = config or ShapeConfig()
    shapes = label_map_levels(codes.shape, canvas.shape, strategy, config)
    start = _resume_codes(resume, palette, shapes) if resume is not None else None
    levels: list = [None] * len(shapes)

    def on_level(level: int, level_codes: np.ndarray) -> None:
        levels[level] = palette[level_codes]

    if start is not None:
        on_level(*start)
    t0 = time.perf_counter()
    order_values = references = synthesis = None
    _check_along(canvas, strategy, start)
    if canvas.along:
        from barkgen.shapes.flow import codes_along_flow

        canvas = canvas.replace(exemplar_wrap=_wrap(canvas.exemplar_wrap, codes, photo))
        out, references, synthesis = codes_along_flow(codes, palette.size, canvas, budget, photo)
    elif strategy in ("engine", "joint"):
        from barkgen.shapes.engine import synthesize_codes

        canvas = canvas.replace(exemplar_wrap=_wrap(canvas.exemplar_wrap, codes, photo))
        out, references = synthesize_codes(
            codes, palette.size, canvas, budget, start=start, on_level=on_level, photo=photo, window=int(window)
        )
    else:
        layers = _LayeredRequest(palette, shapes, layer_order, turns, config)
        out, order_values = _layered_codes(codes, layers, canvas, budget, start, on_level)
    label_out = palette[out]
    levels[0] = label_out
    return LabelMapResult(
        label_map=label_out,
        levels=levels,
        strategy=strategy,
        layer_order=order_values,
        references=references,
        resumed_level=None if start is None else start[0],
        timings={"label_map": time.perf_counter() - t0},
        synthesis=synthesis if photo is not None else None,
    )


def _check_memory(exemplar_shape, out_shape, strategy: str, n_labels: int, max_memory: int | None) -> None:
    """Refuse, before any work, a label map whose estimated peak memory exceeds ``max_memory``."""
    check_memory_budget(
        estimate_label_map_memory(exemplar_shape, out_shape, strategy, n_labels),
        max_memory,
        f"label map {out_shape[1]}x{out_shape[0]}",
    )


def _check_along(canvas: Canvas, strategy: str, start) -> None:
    """Along a flow field: the engine and joint strategies only, and no resumed edit yet."""
    if canvas.along and strategy == "layered":
        raise InvalidInputError("the layered strategy does not follow a flow field; use the engine or joint strategy")
    if canvas.along and start is not None:
        raise InvalidInputError("a label map along a flow field cannot be resumed from an edited level yet")


def _output_canvas(size, canvas: Canvas | None) -> Canvas:
    """The output's canvas: ``canvas`` (or a plain one) of ``size``, checked."""
    if size is None and canvas is None:
        raise InvalidInputError("give the output size (size=) or a canvas (canvas=)")
    out_shape = parse_output_shape(size if size is not None else canvas.shape)  # type: ignore[union-attr]
    if canvas is None:
        return Canvas(out_shape)
    if size is not None and tuple(canvas.shape) != out_shape:
        raise InvalidInputError(
            f"the size ({out_shape[1]}x{out_shape[0]}) and the canvas "
            f"({canvas.shape[1]}x{canvas.shape[0]}) differ: give one of them"
        )
    return canvas.replace(shape=out_shape)


@dataclass(frozen=True)
class _LayeredRequest:
    """What the layered strategy is asked: the exemplar's palette, the pyramid's level shapes,
    the user's layer order (grey values or None), the boundary patches' quarter turns and the
    shape optimisation's parameters."""

    palette: np.ndarray
    shapes: list
    layer_order: list[int] | None
    turns: Any
    config: ShapeConfig


def _layered_codes(
    codes: np.ndarray,
    request: _LayeredRequest,
    canvas: Canvas,
    budget: Budget,
    start,
    on_level,
) -> tuple[np.ndarray, list[int]]:
    """The layered strategy (rosenberger2009, laitoch2018 §3.6): the output codes and the layer
    order used, as grey values bottom layer first."""
    from barkgen.shapes.layered import synthesize_layers

    palette = request.palette
    if request.layer_order is None:
        order = automatic_layer_order(codes, palette.size)
    else:
        order = _layer_order_codes(request.layer_order, palette)
    ex_levels = label_pyramid(codes, palette.size, len(request.shapes))
    n_ticks = len(request.shapes) * max(palette.size - 1, 1)
    done = [0]
    progress = budget.progress

    def tick() -> None:
        done[0] += 1
        if progress:
            progress(done[0], n_ticks)

    rng = np.random.default_rng(int(budget.seed))
    out = synthesize_layers(
        ex_levels,
        canvas,
        order,
        quarter_turns=request.turns,
        config=request.config,
        rng=rng,
        start=start,
        on_level=on_level,
        tick=tick,
    )
    return out, [int(palette[i]) for i in order]


def _check_photo(photo: np.ndarray | None, shape: tuple[int, int], strategy: str) -> np.ndarray | None:
    """The joint strategy's photo (None for the others), checked against the label map."""
    if strategy != "joint":
        return None
    if photo is None:
        raise InvalidInputError(
            "the joint strategy matches the photo's colours too: give the photo the label map belongs to"
        )
    photo = np.asarray(photo)
    if photo.ndim not in (2, 3) or photo.shape[:2] != tuple(shape):
        raise InvalidInputError(
            f"the photo ({'x'.join(str(v) for v in photo.shape[1::-1])} px) and "
            f"the label map ({shape[1]}x{shape[0]} px) must have the same size"
        )
    return photo


def _wrap(mode, codes: np.ndarray, photo: np.ndarray | None) -> tuple[bool, bool]:
    """The exemplar's wrap: decided on the photo when there is one, else on the label map
    (``mode`` None is ``"auto"``)."""
    from barkgen.synth import resolve_exemplar_wrap

    return resolve_exemplar_wrap("auto" if mode is None else mode, codes if photo is None else photo)


def analyse_label_map(
    label_map: np.ndarray,
    size,
    cache: AnalysisCache,
    *,
    photo: np.ndarray | None = None,
    exemplar_wrap: str | bool | tuple[bool, bool] = "auto",
) -> AnalysisCache:
    """Run the engine strategy's exemplar analysis for outputs of ``size`` into ``cache``.

    With ``photo``, the joint strategy's. Every :func:`synthesize_label_map` of this label map
    and size (any seed) then skips it.

    Parameters
    ----------
    label_map : ndarray, shape (h, w)
        The exemplar's grey label map.
    size : int or (int, int)
        Output ``(height, width)``.
    cache : AnalysisCache
        Receives the analysis.
    photo : ndarray, optional
        The photo, for the joint strategy.
    exemplar_wrap : {"auto", "yes", "no"} or (bool, bool), default "auto"
        As for :func:`synthesize_label_map`.

    Returns
    -------
    AnalysisCache
        ``cache``.

    References
    ----------
    .. [1] mazzolini2012, §4.1.2 (the k-coherence analysis phase, once per exemplar).
    """
    from barkgen.shapes.engine import analyse_codes

    codes, palette = to_codes(label_map)
    photo = None if photo is None else _check_photo(photo, codes.shape, "joint")
    return analyse_codes(
        codes,
        palette.size,
        parse_output_shape(size),
        cache,
        photo=photo,
        exemplar_wrap=_wrap(exemplar_wrap, codes, photo),
    )
