"""What turns the solver into texture-by-numbers (laitoch2018 §3.3, image analogies): the
guide the solver is given (:class:`Guidance`), what one level's kernels take from it
(:class:`LevelGuidance`, :func:`level_guidance`) and the label clean-up after the finest level
(:func:`enforce_labels`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from barkgen._shared.canvas import Canvas
from barkgen.nnf import neighbourhood_pca, project_neighbourhoods
from barkgen.synth._analysis import schedule_sizes
from barkgen.synth._config import SynthesisConfig


@dataclass
class Guidance:
    """What turns the solver into texture-by-numbers (laitoch2018 §3.3, image analogies).

    ``exemplar_guides[l]`` ``(h_l, w_l, G)`` and ``target_guides[l]`` ``(H_l, W_l, G)`` are the
    guide channels (soft labels) of the exemplar (``A``) and of the output (``B``) at level
    ``l`` (a target level may be a :class:`~barkgen.synth.guides.target.TargetGuideLevel`, made
    where it is read); their neighbourhoods are compared in an appearance space of their own with
    ``components`` dimensions. ``levels`` are the label tables; ``initial_references(a, b, rng)``
    makes the coarsest level's reference map from its exemplar and target labels.

    ``random_candidates``: M-step candidates drawn per pixel from the wanted label's exemplar
    pixels (plus one aligned on the nearest other label). ``vote_discount``: weight of E-step
    votes whose label is wrong (0: used only when no vote has the right label).
    ``cleanup_passes``: label clean-up passes after the finest level (:func:`enforce_labels`).
    """

    levels: list  # list[LevelGuide], finest first
    exemplar_guides: list  # list[np.ndarray], finest first
    target_guides: list  # list[np.ndarray], finest first
    initial_references: Callable[[np.ndarray, np.ndarray, np.random.Generator], np.ndarray]
    components: int = 4
    random_candidates: int = 1
    vote_discount: float = 0.0
    cleanup_passes: int = 3


@dataclass
class LevelGuidance:
    """The texture-by-numbers inputs of one level's kernels (empty arrays when unguided)."""

    ex_labels: np.ndarray
    target: np.ndarray
    pool: np.ndarray
    pool_start: np.ndarray
    expected: np.ndarray | None
    n_random: int
    discount: float
    guide_ex: dict
    guide_out: dict
    guided: bool
    #: a level solved window by window (:mod:`barkgen.synth._windows`) keeps its target's guide
    #: image (``target_guide``, whether it ``tile``\ s) and each neighbourhood size's projection
    #: ``(weights, mean)`` instead of ``guide_out``: each window's are projected on the window
    #: (:func:`guide_out_at`), never the whole level's at once
    projections: dict = field(default_factory=dict)
    target_guide: np.ndarray | None = None
    tile: bool = False


NO_LABELS = np.zeros(1, np.int32)
NO_TARGET = np.zeros((1, 1), np.int32)
NO_POOL_START = np.zeros(2, np.int32)
NO_GUIDE_EX = np.zeros((1, 0), np.float32)
NO_GUIDE_OUT = np.zeros((1, 1, 0), np.float32)


def level_guidance(
    guidance: Guidance | None,
    lvl: int,
    n_levels: int,
    config: SynthesisConfig,
    canvas: Canvas,
    by_window: bool = False,
) -> LevelGuidance:
    """The label tables of level ``lvl`` and the appearance-space label neighbourhoods of the
    exemplar and of the target for each neighbourhood size of the level's schedule
    (laitoch2018 §3.3, eq. 3.2). ``canvas``: the level's (its shape, whether it tiles, the
    exemplar level's resolved wrap). ``by_window``: the target's are left to each window
    (:func:`guide_out_at`; issue 69, the level's memory a window's)."""
    shape, tile, wrap = canvas.shape, canvas.tile, canvas.exemplar_wrap or (False, False)
    if guidance is None:
        return LevelGuidance(NO_LABELS, NO_TARGET, NO_LABELS, NO_POOL_START, None, 0, 1.0, {}, {}, False)
    lg = guidance.levels[lvl]
    guide_ex, guide_out = {}, {}
    projections = {}
    for nb_size in schedule_sizes(config, lvl, n_levels):
        gp = neighbourhood_pca(guidance.exemplar_guides[lvl], nb_size, guidance.components, wrap=wrap)
        guide_ex[nb_size] = gp.features
        if by_window:
            projections[nb_size] = (gp.weights, gp.mean)
        else:
            guide_out[nb_size] = project_neighbourhoods(
                np.asarray(guidance.target_guides[lvl]), gp.weights, gp.mean, wrap=tile
            ).reshape(shape + (-1,))
    return LevelGuidance(
        lg.exemplar_labels,
        lg.target_labels,
        lg.pool,
        lg.pool_start,
        lg.expected_use,
        guidance.random_candidates,
        guidance.vote_discount,
        guide_ex,
        guide_out,
        True,
        projections,
        guidance.target_guides[lvl] if by_window else None,
        bool(tile),
    )


def guide_out_at(guide: LevelGuidance, rows: np.ndarray, cols: np.ndarray) -> dict:
    """A level's target guide neighbourhoods (``guide_out``) at the level's ``rows`` and
    ``cols`` (a window, its halo included; taken round the torus when the level tiles), projected
    from ``guide.target_guide`` read with a margin of each neighbourhood's radius: what the whole
    level's projection gives there (borders reflected where the window meets an edge of a level
    that does not tile)."""
    assert guide.target_guide is not None  # (a level guided by window)
    image = guide.target_guide
    out = {}
    for nb_size, (weights, mean) in guide.projections.items():
        r = nb_size // 2
        ext_rows, top = _with_margin(rows, r, image.shape[0], guide.tile)
        ext_cols, left = _with_margin(cols, r, image.shape[1], guide.tile)
        block = image[np.ix_(ext_rows, ext_cols)]
        features = project_neighbourhoods(block, weights, mean).reshape(block.shape[:2] + (-1,))
        out[nb_size] = np.ascontiguousarray(features[top : top + rows.size, left : left + cols.size])
    return out


def _with_margin(positions: np.ndarray, r: int, n: int, wrap: bool) -> tuple[np.ndarray, int]:
    """``positions`` (consecutive along the axis, round it when ``wrap``) with up to ``r`` more
    either side: round the axis when it wraps, up to its ends otherwise; and how many came before."""
    first, last = int(positions[0]), int(positions[-1])
    if wrap:
        return np.concatenate([np.arange(first - r, first) % n, positions, np.arange(last + 1, last + 1 + r) % n]), r
    before = np.arange(max(first - r, 0), first)
    return np.concatenate([before, positions, np.arange(last + 1, min(last + 1 + r, n))]), before.size


def enforce_labels(refs: np.ndarray, ctx, passes: int) -> np.ndarray:
    r"""Texture-by-numbers' label clean-up after the finest level
    (``guides._kernels.enforce_labels``), at most ``passes`` passes; ``ctx``: the solver's level
    (:class:`barkgen.synth._level.LevelContext`: its exemplar ``analysis.grid``, its ``guide``
    and whether it ``tile``\ s)."""
    import barkgen.synth.guides._kernels as K

    grid, guide, tile = ctx.analysis.grid, ctx.guide, ctx.tile
    new = np.empty(refs.shape, np.int32)
    for _ in range(passes):
        if K.enforce_labels((refs, tile), grid, guide.ex_labels, guide.target, new) == 0:
            break
        refs, new = new, refs
    return refs
