"""The one set-up path of the solver's fronts (:func:`synthesize`, texture-by-numbers): the
inputs checked, the memory budget checked before any work starts, the exemplar's wrap
resolved, its matching features made and the pyramid's depth chosen, then the discrete solver
run (mazzolini2012 §4.1, laitoch2018 §3.3) and its image given the exemplar's own shape.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from barkgen._shared.arrays import as_hw_c
from barkgen._shared.canvas import Budget, Canvas
from barkgen._shared.checks import parse_output_shape
from barkgen._shared.memory import check_memory_budget
from barkgen.errors import InvalidInputError
from barkgen.pyramid import count_levels
from barkgen.synth._analysis import AnalysisCache, matching_features
from barkgen.synth._config import SynthesisConfig
from barkgen.synth._edges import resolve_exemplar_wrap
from barkgen.synth._level import SolverInputs
from barkgen.synth._solver import SynthesisResult, solve

#: smallest exemplar side accepted
MIN_EXEMPLAR_SIDE = 16


def validate_inputs(
    exemplar: np.ndarray, size: int | tuple[int, int], budget: Budget, extra: Mapping[str, np.ndarray] | None
) -> tuple[np.ndarray, tuple[int, int], dict]:
    """Check the exemplar, output size, the budget's seed and extra maps; return them
    normalised."""
    seed = budget.seed
    ex = as_hw_c("exemplar", exemplar)
    if ex.shape[2] not in (1, 3):
        raise InvalidInputError(f"exemplar must have 1 or 3 channels, not {ex.shape[2]}")
    if min(ex.shape[:2]) < MIN_EXEMPLAR_SIDE:
        raise InvalidInputError(
            f"exemplar is {ex.shape[1]}x{ex.shape[0]} px; it must be at least {MIN_EXEMPLAR_SIDE} px on each side"
        )
    out_shape = parse_output_shape(size)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise InvalidInputError(f"seed must be a non-negative integer, not {seed!r}")
    extras = {}
    for name, arr in (extra or {}).items():
        e = as_hw_c(f"extra map {name!r}", arr)
        if e.shape[:2] != ex.shape[:2]:
            raise InvalidInputError(
                f"extra map {name!r} is {e.shape[1]}x{e.shape[0]} px but the exemplar is "
                f"{ex.shape[1]}x{ex.shape[0]} px; they must match"
            )
        extras[name] = e
    return ex, out_shape, extras


#: bytes per output pixel of a solve whose finest levels go window by window
#: (``config.window``), beside one window's working arrays: what its levels hold whole (the
#: reference maps, the result, the target's labels and guide channels; ``generate``'s texture
#: stage at 4096², windowed: 62 B a pixel over the analysis, the label stage's result included)
WINDOWED_SOLVE_BYTES_PER_PIXEL = 64


def check_memory(
    ex: np.ndarray,
    extras: Mapping[str, np.ndarray],
    out_shape: tuple[int, int],
    feature_channels: int,
    config: SynthesisConfig,
    guided: bool = False,
    links=None,
) -> None:
    """Raise :class:`MemoryBudgetError` before any work if the job would not fit the budget: the
    solver's arrays for the output, or, its finest levels solved window by window
    (:func:`~barkgen.synth._windows.windowed_level`), for one window and its halo, plus
    :data:`WINDOWED_SOLVE_BYTES_PER_PIXEL` of the output."""
    from barkgen.synth._windows import WINDOW_HALO, windowed_level

    solved = out_shape
    if windowed_level(config, 0, out_shape, links):
        side = config.window + 2 * WINDOW_HALO
        solved = (min(side, out_shape[0]), min(side, out_shape[1]))
    need = estimate_memory(
        ex.shape[:2],
        solved,
        ex.shape[2] + sum(e.shape[2] for e in extras.values()),
        max([ex.dtype.itemsize] + [e.dtype.itemsize for e in extras.values()]),
        feature_channels,
        config,
    )
    if guided:  # label pyramids and tables
        need += 24 * solved[0] * solved[1] + 24 * ex.shape[0] * ex.shape[1]
    if solved != out_shape:
        need += WINDOWED_SOLVE_BYTES_PER_PIXEL * out_shape[0] * out_shape[1]
    check_memory_budget(need, config.max_memory, f"output {out_shape[1]}x{out_shape[0]}")


def estimate_memory(
    exemplar_shape: tuple[int, int],
    output_shape: tuple[int, int],
    channels: int,
    bytes_per_channel: int,
    feature_channels: int,
    config: SynthesisConfig,
) -> int:
    """Estimated peak memory of a synthesis, in bytes (made before any work starts)."""
    n_ex = exemplar_shape[0] * exemplar_shape[1]
    n_out = output_shape[0] * output_shape[1]
    sizes = {
        s for sched in (config.schedule_coarsest, config.schedule_middle, config.schedule_finest) for s, _ in sched
    }
    per_ex = feature_channels * 4 * 3 + config.pca_components * 4 * len(sizes) * 1.4 + config.k * 4 * 1.4 + 8
    per_out = 100 + 3 * channels * bytes_per_channel
    if config.blend == "gradient":  # one channel's screened Poisson solve at a time (float64)
        per_out += 80
    search = min(n_ex, 262_144) * max(4 * config.k + 8, 32) * 12
    return int(200e6 + n_ex * per_ex + n_out * per_out + search)


def colour_channels(ex: np.ndarray) -> int:
    """The matching feature channels of an ``(h, w, C)`` exemplar's colour: CIELAB's 3 for an RGB
    exemplar, L alone for a grey one (:func:`matching_features`)."""
    return 3 if ex.shape[2] == 3 else 1


class Front:
    """What a front of the solver adds to the set-up (:func:`set_up`): its own checks of the
    validated exemplar, the matching features it makes and the feature channels they add to
    the colour's and the extras'. This plain front is :func:`synthesize`'s: no checks, the
    colour and the extra maps matched (laitoch2018 §3.3.1)."""

    #: feature channels beyond the colour's and the extras' (counted in the memory estimate)
    added_channels = 0
    #: the front guides the solver with label maps (their pyramids and tables are counted too)
    guided = False

    def check(self, ex: np.ndarray) -> None:
        """Raise :class:`InvalidInputError` if the front's own inputs do not fit ``ex``."""

    def features(
        self,
        ex: np.ndarray,
        extras: Mapping[str, np.ndarray],
        wrap: tuple[bool, bool],
        config: SynthesisConfig,
        cache: AnalysisCache | None = None,
    ) -> np.ndarray:
        """``(h, w, F)`` float32: what the solver matches (made once per exemplar and kept in
        ``cache`` when given: every seed matches the same features)."""
        if cache is None:
            return matching_features(ex, extras, config.extra_weight)
        inputs = (ex, config.extra_weight, *extra_inputs(extras))
        return cache.features("colour", inputs, lambda: matching_features(ex, extras, config.extra_weight))


def extra_inputs(extras: Mapping[str, np.ndarray]) -> tuple:
    """The extra maps as a flat tuple of names and arrays (:meth:`AnalysisCache.features`'
    inputs)."""
    return tuple(item for name in sorted(extras) for item in (name, extras[name]))


@dataclass(frozen=True)
class SolveSetup:
    """The checked inputs of one synthesis, ready for :func:`solve` (made by :func:`set_up`).

    ``inputs.exemplar`` is ``(h, w, C)`` (``flat``: it was given as ``(h, w)``, and the image
    is given back so); ``canvas`` the output's, its ``exemplar_wrap`` resolved against the
    exemplar; ``budget`` the run's; ``front`` the front that made the features.
    """

    inputs: SolverInputs
    canvas: Canvas
    budget: Budget
    flat: bool = False
    front: Front = field(default_factory=Front)

    @property
    def exemplar(self) -> np.ndarray:
        """The validated ``(h, w, C)`` exemplar."""
        return self.inputs.exemplar

    @property
    def wrap(self) -> tuple[bool, bool]:
        """The exemplar's resolved ``(rows, columns)`` wrap."""
        return self.canvas.exemplar_wrap

    def solve(self, **options) -> SynthesisResult:
        """:func:`solve` on these inputs (``options``: its other keywords: ``guidance``,
        ``start``, ``balance``, ``stop_level``), the colour compared by the seam costs; the
        image as flat as the exemplar was given."""
        result = solve(self.inputs, self.canvas, self.budget, **options)
        if self.flat:
            result.image = result.image[:, :, 0]
        return result


def set_up(
    exemplar: np.ndarray,
    extra: Mapping[str, np.ndarray] | None,
    config: SynthesisConfig,
    canvas: Canvas,
    budget: Budget,
    front: Front | None = None,
) -> SolveSetup:
    """Validate the inputs (and the ``front``'s own), check the memory budget, resolve the
    exemplar's wrap (``canvas.exemplar_wrap``), make the matching features and choose the
    pyramid's depth, in that order and before any solver work (see :class:`SolveSetup`)."""
    front = front if front is not None else Front()
    ex, out_shape, extras = validate_inputs(exemplar, canvas.shape, budget, extra)
    front.check(ex)
    n_feat = colour_channels(ex) + front.added_channels + sum(e.shape[2] for e in extras.values())
    check_memory(ex, extras, out_shape, n_feat, config, guided=front.guided, links=canvas.links)
    wrap = resolve_exemplar_wrap(canvas.wrap_mode, ex)
    feats = front.features(ex, extras, wrap, config, budget.cache)
    n_levels = count_levels(ex.shape[:2], out_shape, config.coarsest_exemplar)
    inputs = SolverInputs(ex, feats, n_levels, config, extras, seam_channels=colour_channels(ex))
    return SolveSetup(
        inputs,
        canvas.replace(exemplar_wrap=wrap),
        budget,
        flat=np.asarray(exemplar).ndim == 2,
        front=front,
    )
