"""One pyramid level of the k-coherence discrete solver (mazzolini2012 §4.1, laitoch2018 §3.3):
what the solver copies and matches (:class:`SolverInputs`), the level as its steps see it
(:class:`LevelContext`), its starting state (random or label-made at the coarsest level, the
coarser level's up-sampled exactly below it, laitoch2018 §3.3.4) and its solve: M-step / E-step
iterations with the copy-size control, then the seams moved onto low-error paths
(:mod:`barkgen.synth.seams`) and, guided, the label clean-up. :mod:`barkgen.synth._solver` runs
the levels coarse to fine."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from barkgen._shared.bands import NUMPY_STEP, row_bands
from barkgen._shared.canvas import Canvas
from barkgen.pyramid import level_shape
from barkgen.synth._analysis import LevelAnalysis
from barkgen.synth._config import SynthesisConfig
from barkgen.synth._links import OutputLinks
from barkgen.synth._occurrence import LabelBalance, jitter_references, occurrence_penalty
from barkgen.synth.guides.guidance import (
    NO_GUIDE_EX,
    NO_GUIDE_OUT,
    Guidance,
    LevelGuidance,
    enforce_labels,
    level_guidance,
)
from barkgen.synth.seams.expansion import expand_pieces
from barkgen.synth.seams.pieces import cut_seams, limit_copies, roll_state, unstick_border_seams


def _stride_for(size: int) -> int:
    return 1 if size <= 3 else 2


#: at the finest level, how many more iterations a straight seam stuck at the exemplar's
#: border (:func:`~barkgen.synth.seams.pieces.unstick_border_seams`) is given to be replaced
STUCK_RETRIES = 2


@dataclass(frozen=True)
class LevelContext:
    """One pyramid level as the solver's steps see it (laitoch2018 §3.3): the level's exemplar
    analysis and what is made from it for the level, its place in the pyramid, and what the
    whole solve shares (the config, the one random generator, tiling).

    Attributes
    ----------
    analysis
        the level's k-coherence analysis (:class:`LevelAnalysis`).
    level, n_levels
        the level (0 = finest) and the pyramid's depth.
    shape
        ``(H_l, W_l)`` of the output at this level.
    config
        the solver's parameters.
    rng
        the generator behind every random choice of the solve (drawn from in the solver's order).
    tile
        the output wraps.
    guide
        texture-by-numbers' inputs of the level's kernels (:class:`LevelGuidance`; unguided:
        empty arrays).
    seam_image
        ``(h_l, w_l, S)``: what the seam costs compare, as an image (the first ``seam_channels``
        feature channels).
    links
        output pixels that take the references of others (a texture atlas's gutters,
        :class:`~barkgen.synth._links.OutputLinks`), or None.
    frozen
        ``(mask, references)``: pixels that keep those references whatever the steps do (a
        window's halo, :mod:`barkgen.synth._windows`), or None.
    outside
        for a window of a level, how often the rest of the level references each exemplar
        pixel and the level's pixel count (the occurrence cost's,
        :func:`~barkgen.synth._occurrence.occurrence_penalty`), or None.
    """

    analysis: LevelAnalysis
    level: int
    n_levels: int
    shape: tuple[int, int]
    config: SynthesisConfig
    rng: np.random.Generator
    tile: bool
    guide: LevelGuidance
    seam_image: np.ndarray
    links: OutputLinks | None = None
    frozen: tuple[np.ndarray, np.ndarray] | None = None
    outside: tuple[np.ndarray, int] | None = None

    def relink(self, refs: np.ndarray) -> np.ndarray:
        """``refs`` with every linked pixel given its source's reference and every frozen pixel
        its own (in place)."""
        if self.links is not None:
            self.links.apply(refs, self.level, self.analysis.grid)
        return self.hold(refs)

    def hold(self, refs: np.ndarray) -> np.ndarray:
        """``refs`` with every frozen pixel given its own reference back (in place)."""
        if self.frozen is not None:
            np.copyto(refs, self.frozen[1], where=self.frozen[0])
        return refs


def level_context(
    la: LevelAnalysis,
    lvl: int,
    inputs: SolverInputs,
    canvas: Canvas,
    rng: np.random.Generator,
    guidance: Guidance | None,
    by_window: bool = False,
) -> LevelContext:
    """The :class:`LevelContext` of level ``lvl``: its guide (:func:`level_guidance`; the
    target's neighbourhoods left to each window ``by_window``) and its seam image made."""
    shape = level_shape(canvas.shape, lvl)
    level_canvas = canvas.replace(shape=shape, exemplar_wrap=la.wrap)
    guide = level_guidance(guidance, lvl, inputs.n_levels, inputs.config, level_canvas, by_window)
    seam_image = np.ascontiguousarray(la.features[:, : inputs.seam_channels]).reshape(
        la.height, la.width, -1
    )  # what the seam costs compare, as an image
    return LevelContext(
        la, lvl, inputs.n_levels, shape, inputs.config, rng, canvas.tile, guide, seam_image, canvas.links
    )


def initial_state(ctx: LevelContext, guidance: Guidance | None) -> np.ndarray:
    """The coarsest level's reference map: random, or made from the labels with a guide."""
    la = ctx.analysis
    if guidance is None:
        return ctx.rng.integers(0, la.height * la.width, size=ctx.shape, dtype=np.int32)
    lg = guidance.levels[ctx.level]
    return np.ascontiguousarray(
        guidance.initial_references(lg.exemplar_labels.reshape(la.height, la.width), lg.target_labels, ctx.rng),
        dtype=np.int32,
    )


def upsampled_state(
    ctx: LevelContext, refs: np.ndarray, forbid: np.ndarray, coarse: LevelAnalysis
) -> tuple[np.ndarray, np.ndarray]:
    """The coarser level's state up-sampled exactly (laitoch2018 §3.3.4), shifted and jittered."""
    import barkgen.synth._kernels as K

    la, shape, lvl, rng = ctx.analysis, ctx.shape, ctx.level, ctx.rng
    fine_refs = np.empty(shape, np.int32)
    fine_forbid = np.empty(shape, np.int64)
    K.upsample_state(
        refs,
        forbid,
        coarse.coords_y,
        coarse.coords_x,
        la.height,
        la.width,
        la.wrap[0],
        la.wrap[1],
        fine_refs,
        fine_forbid,
    )
    refs, forbid = fine_refs, fine_forbid
    if ctx.tile and lvl > 0 and not ctx.guide.guided:
        # seams formed at coarse levels lie on the block grid of the upsampling; a random
        # toroidal shift per level keeps that grid from lining up with the tile border.
        # (None at the finest level: shifts stay even there, so exemplar pieces keep the
        # pixel parity of the exemplar and survive 2x downsampling intact. None either
        # with a guide: the output must stay aligned with its target label map.)
        shift = (int(rng.integers(0, shape[0])), int(rng.integers(0, shape[1])))
        refs, forbid = roll_state(refs, forbid, shift)
    if lvl >= 2:
        refs = jitter_references(refs, la, int(round(ctx.config.jitter * 2)), rng)
    return refs, forbid


def upsample_references(
    references: np.ndarray,
    out_shape: tuple[int, int],
    exemplar_shape: tuple[int, int],
    exemplar_wrap: tuple[bool, bool] = (False, False),
) -> np.ndarray:
    """A level's reference map brought exactly to the next finer level (laitoch2018 §3.3.2,
    as the solver does between levels): output pixel ``(y, x)`` of ``out_shape`` takes the
    child ``(2v + y % 2, 2u + x % 2)`` of its parent's exemplar position ``(v, u)``; on an
    exemplar of odd side (``exemplar_shape``, the finer level's), a child past its edge is its
    first row or column when it wraps, else its last. ``(h, w, 2)`` in, ``out_shape + (2,)``
    int32 out."""
    refs = np.asarray(references)
    eh, ew = exemplar_shape
    out = np.empty((*out_shape, 2), np.int32)
    xs = np.arange(out_shape[1])[None, :]
    # a band of rows at a time (Ctrl-C is heard between bands: a 4096² level in one go held
    # the interpreter for 1.2 s); about ten numpy operations per pixel
    for start, stop in row_bands(out_shape[0], out_shape[1] * 10 * NUMPY_STEP):
        ys = np.arange(start, stop)[:, None]
        parent = refs[ys // 2, xs // 2]
        fy = 2 * parent[..., 0] + (ys & 1)
        fx = 2 * parent[..., 1] + (xs & 1)
        out[start:stop, :, 0] = np.where(fy >= eh, 0 if exemplar_wrap[0] else eh - 1, fy)
        out[start:stop, :, 1] = np.where(fx >= ew, 0 if exemplar_wrap[1] else ew - 1, fx)
    return out


def _iterate(
    ctx: LevelContext,
    refs: np.ndarray,
    forbid: np.ndarray,
    schedule: list[int],
    occurrence: Callable[[np.ndarray], np.ndarray],
    tick: Callable[[], None],
) -> np.ndarray:
    """One level's M-step / E-step iterations (laitoch2018 eqs. 3.4-3.5), each followed by the
    copy-size control and the border-seam hand-back; returns the level's reference map."""
    import barkgen.synth._kernels as K

    la, lvl, config, rng, guide, tile = (ctx.analysis, ctx.level, ctx.config, ctx.rng, ctx.guide, ctx.tile)
    shape = refs.shape
    wrap = la.wrap
    match = np.empty(shape, np.int32)
    new = np.empty(shape, np.int32)
    penalty = occurrence(refs)
    for step, nb_size in enumerate(schedule):
        proj = la.projections[nb_size]
        stride = _stride_for(nb_size)
        oy, ox = (int(v) for v in rng.integers(0, stride, size=2))
        key = np.uint64(rng.integers(0, 2**63)) if guide.guided else np.uint64(0)
        match.fill(-1)
        kernel_guide = (
            guide.guide_ex.get(nb_size, NO_GUIDE_EX),
            guide.guide_out.get(nb_size, NO_GUIDE_OUT),
            guide.ex_labels,
            guide.target,
            guide.pool,
            guide.pool_start,
            guide.n_random,
            key,
        )
        K.m_step(
            (refs, tile),
            la.grid,
            la.features,
            (la.kernel_weights[nb_size], proj.mean, proj.features),
            la.ksets,
            (penalty, np.float32(config.kset_cost * la.scale), forbid),
            (stride, oy, ox),
            kernel_guide,
            match,
        )
        votes = (min(nb_size // 2, config.vote_radius), stride, oy, ox, np.float32(max(nb_size / 3.0, 1.0)))
        K.e_step(
            match,
            (refs, tile),
            la.grid,
            la.features,
            votes,
            forbid,
            (guide.ex_labels, guide.target, np.float32(guide.discount)),
            new,
        )
        refs, new = new, refs
        ctx.relink(refs)
        if config.max_copy < 1.0 and (lvl > 0 or step < len(schedule) - 1):
            # (cuts act through the following iterations, none after the very last one)
            limit_copies(refs, ctx, forbid)
        if config.seam_cut_run and not all(wrap):
            unstick_border_seams(refs, ctx, forbid, max(4, config.seam_cut_run >> lvl))
        penalty = occurrence(refs)
        tick()
    return refs


def _refine_seams(ctx: LevelContext, refs: np.ndarray, forbid: np.ndarray) -> np.ndarray:
    """``config.seam_sweeps`` sweeps of seam optimisation (``seams._kernels.refine_seams``): the
    first looks at every pixel, later half-sweeps only beside the pixels the previous one moved."""
    import barkgen.synth.seams._kernels as K

    guide, tile = ctx.guide, ctx.tile
    shape = refs.shape
    new = np.empty(shape, np.int32)
    moved_map, after = np.empty(shape, np.uint8), np.zeros(shape, np.uint8)
    every = np.zeros((1, 1), np.uint8)
    for sweep in range(ctx.config.seam_sweeps):
        moved = 0
        for parity in (0, 1):
            moved += K.refine_seams(
                (refs, tile),
                ctx.seam_image,
                ctx.analysis.grid,
                parity,
                forbid,
                (guide.ex_labels, guide.target),
                every if sweep == 0 else after,
                moved_map,
                new,
            )
            refs, new = new, refs
            moved_map, after = after, moved_map
        if moved == 0:
            break
    return refs


def move_seams(ctx: LevelContext, refs: np.ndarray, forbid: np.ndarray, *, expansion: bool = True) -> np.ndarray:
    """The level's seams moved onto low-error paths: local sweeps, at the finest level the
    pieces' expansion moves (:mod:`barkgen.synth.seams.expansion`; not without ``expansion``),
    and at the finest levels the graph cuts of the straight stretches left
    (:mod:`barkgen.synth.seams.cuts`)."""
    la, lvl, config, guide, tile = ctx.analysis, ctx.level, ctx.config, ctx.guide, ctx.tile
    refs = ctx.hold(_refine_seams(ctx, refs, forbid))
    if config.seam_expansion_band and lvl == 0 and expansion:
        refs = expand_pieces(
            refs,
            la.grid,
            ctx.seam_image,
            Canvas(ctx.shape, tile),
            forbid,
            (guide.ex_labels, guide.target),
            band=config.seam_expansion_band,
            rounds=config.seam_expansion_rounds,
        )
    if config.seam_cut_run and lvl <= config.seam_cut_levels - 1:
        refs = cut_seams(ctx.hold(refs), ctx, config.seam_cut_run)
    return ctx.hold(refs)


def solve_level(
    ctx: LevelContext,
    refs: np.ndarray,
    forbid: np.ndarray,
    balance: LabelBalance | None,
    cleanup_passes: int,
    tick: Callable[[], None],
) -> np.ndarray:
    """The level of ``ctx`` from its starting state: iterations, seam sweeps, straight-seam
    cuts and (finest level, guided) ``cleanup_passes`` passes of the label clean-up."""
    la, lvl, config = ctx.analysis, ctx.level, ctx.config

    def occurrence(refs: np.ndarray) -> np.ndarray:
        cost = occurrence_penalty(refs, la, config.occurrence_weight, 3, ctx.guide.expected, ctx.outside)
        if balance is not None:
            cost += balance.penalty(refs, lvl, la.scale)
        return cost

    schedule = [size for size, iters in config.schedule_for(lvl, ctx.n_levels) for _ in range(iters)]
    refs = _iterate(ctx, refs, forbid, schedule, occurrence, tick)
    refs = move_seams(ctx, refs, forbid)
    if lvl == 0 and config.seam_cut_run and not all(la.wrap):
        # the last iteration's stuck border seams have no iteration after it to be handed to
        for _ in range(STUCK_RETRIES):
            if unstick_border_seams(refs, ctx, forbid, max(4, config.seam_cut_run)) == 0:
                break
            refs = _iterate(ctx, refs, forbid, schedule[-1:], occurrence, lambda: None)
            refs = move_seams(ctx, refs, forbid)
    if ctx.guide.guided and lvl == 0:
        refs = enforce_labels(refs, ctx, cleanup_passes)
    return ctx.relink(refs)


@dataclass(frozen=True)
class SolverInputs:
    """What the solver copies and matches, validated (by the fronts' set-up,
    :func:`barkgen.synth._setup.set_up`, or by the package that drives the solver itself):
    the ``(h, w, C)`` ``exemplar`` and the ``extras`` aligned with it, both resolved through the
    final references; the ``(h, w, F)`` float32 ``features`` matched; the pyramid's depth
    ``n_levels``; the solver's ``config``; ``seam_channels``: the seam costs compare the first
    that many feature channels (the colour; None: all).
    """

    exemplar: np.ndarray
    features: np.ndarray
    n_levels: int
    config: SynthesisConfig
    extras: Mapping[str, np.ndarray] = field(default_factory=dict)
    seam_channels: int | None = None
