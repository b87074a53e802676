"""Example-based texture synthesis with the k-coherence discrete solver.

Implements the texture-optimization solver of Han et al. 2006 as described in mazzolini2012 §4.1
(k-coherence analysis and synthesis phases, multi-resolution) and laitoch2018 §3.3 (image of
references, forward-shifted neighbourhoods, exact reference up-sampling, M-step on a sparse subset,
E-step, extra channels), with these additions:

* appearance space (Lefebvre & Hoppe 2006): neighbourhoods are compared as PCA vectors;
* several neighbourhood sizes per level, largest first (Kwatra et al. 2005);
* an occurrence penalty (Kaspar et al. 2015) so every exemplar region is used about equally,
  which answers the "same patterns repeated" defect of laitoch2018 §4.1;
* a coherence bias (Ashikhmin 2001) that keeps exemplar patches whole;
* toroidal neighbourhoods at every level for tileable output;
* an exemplar that tiles itself is a torus too (:mod:`barkgen.synth._edges`); along an edge
  that does not wrap, the seams where pieces end are cut like the others, so they do not
  follow the edge's line;
* seam optimisation: local moves and graph cuts of straight seams (Kwatra et al. 2003,
  :mod:`barkgen.synth.seams.cuts`), so the borders between pieces follow low-error paths;
* the output is an image of references, resolved to exemplar pixels only at the end, so nothing
  is ever averaged: the result is exactly as sharp as the exemplar (laitoch2018 §4.2's blur).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from barkgen._shared.arrays import as_uint8
from barkgen._shared.bands import NUMPY_STEP, row_bands
from barkgen._shared.canvas import Budget, Canvas
from barkgen._shared.threads import thread_budget
from barkgen.errors import InvalidInputError
from barkgen.pyramid import level_shape
from barkgen.synth._analysis import AnalysisCache, LevelAnalysis
from barkgen.synth._config import SynthesisConfig
from barkgen.synth._edges import map_wraps
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
from barkgen.synth.seams.gradient import blend_seams, resolve_continuous
from barkgen.synth.seams.pieces import cut_seams, limit_copies, roll_state, unstick_border_seams


@dataclass
class SynthesisResult:
    """What :func:`synthesize` returns.

    Attributes
    ----------
    image
        the synthesized texture, same dtype and channel count as the exemplar.
    references
        ``(H, W, 2)`` int32, the exemplar (row, col) each output pixel copies.
    extras
        each extra map of the exemplar through the same references, in the gradient
        domain (:func:`barkgen.synth.resolve_continuous`: no cliffs where copied
        pieces meet; :func:`apply_references` gives the exact copy).
    exemplar_shape
        ``(h, w)`` of the exemplar the references point into.
    exemplar_wrap
        ``(rows, columns)``: the exemplar was used as a torus along that axis
        (a reference may step from its last row to its first inside one piece).
    extra_wraps
        ``(rows, columns)`` of each extra map: the axes along which it was carried as a torus
        (:func:`barkgen.synth._edges.map_wraps`: where the exemplar wraps and the map's own
        edges meet).
    blend
        how the image was made from the references: ``"gradient"`` (its seams blended,
        :func:`barkgen.synth.blend_seams`) or ``"none"`` (the exact copy,
        :func:`apply_references`).
    seed, tile
        as requested.
    timings
        seconds spent in ``analysis`` and ``synthesis``.
    orientation
        along a flow field, the atlas of the exemplar's turned and scaled copies the references
        point into (:class:`barkgen.synth.OrientedExemplar`; ``exemplar_shape`` is its shape);
        else None.
    """

    image: np.ndarray
    references: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    exemplar_shape: tuple[int, int] = (0, 0)
    exemplar_wrap: tuple[bool, bool] = (False, False)
    seed: int = 0
    tile: bool = False
    timings: dict[str, float] = field(default_factory=dict)
    extra_wraps: dict[str, tuple[bool, bool]] = field(default_factory=dict)
    blend: str = "none"
    orientation: Any = None


#: debug(name, image): receives intermediate images (uint8 RGB) when given
DebugCallback = Callable[[str, np.ndarray], None]


def level_image(ex: np.ndarray, refs: np.ndarray, level: int) -> np.ndarray:
    """A level's reference map shown with the full-resolution exemplar's colours (debug)."""
    h, w = ex.shape[:2]
    lw = level_shape((h, w), level)[1]
    ry, rx = np.divmod(refs, lw)
    img = ex[np.minimum(ry << level, h - 1), np.minimum(rx << level, w - 1)]
    return as_uint8(img)


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

    def relink(self, refs: np.ndarray) -> np.ndarray:
        """``refs`` with every linked pixel given its source's reference (in place)."""
        if self.links is not None:
            self.links.apply(refs, self.level, self.analysis.grid)
        return refs


def _level_context(
    la: LevelAnalysis,
    lvl: int,
    inputs: SolverInputs,
    canvas: Canvas,
    rng: np.random.Generator,
    guidance: Guidance | None,
) -> LevelContext:
    """The :class:`LevelContext` of level ``lvl``: its guide (:func:`level_guidance`) and its
    seam image made."""
    shape = level_shape(canvas.shape, lvl)
    guide = level_guidance(
        guidance, lvl, inputs.n_levels, inputs.config, canvas.replace(shape=shape, exemplar_wrap=la.wrap)
    )
    seam_image = np.ascontiguousarray(la.features[:, : inputs.seam_channels]).reshape(
        la.height, la.width, -1
    )  # what the seam costs compare, as an image
    return LevelContext(
        la, lvl, inputs.n_levels, shape, inputs.config, rng, canvas.tile, guide, seam_image, canvas.links
    )


def _initial_state(ctx: LevelContext, guidance: Guidance | None) -> np.ndarray:
    """The coarsest level's reference map: random, or made from the labels with a guide."""
    la = ctx.analysis
    if guidance is None:
        return ctx.rng.integers(0, la.height * la.width, size=ctx.shape, dtype=np.int32)
    lg = guidance.levels[ctx.level]
    return np.ascontiguousarray(
        guidance.initial_references(lg.exemplar_labels.reshape(la.height, la.width), lg.target_labels, ctx.rng),
        dtype=np.int32,
    )


def _upsampled_state(
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


def _move_seams(ctx: LevelContext, refs: np.ndarray, forbid: np.ndarray) -> np.ndarray:
    """The level's seams moved onto low-error paths: local sweeps, at the finest level the
    pieces' expansion moves (:mod:`barkgen.synth.seams.expansion`), and at the finest levels the
    graph cuts of the straight stretches left (:mod:`barkgen.synth.seams.cuts`)."""
    la, lvl, config, guide, tile = ctx.analysis, ctx.level, ctx.config, ctx.guide, ctx.tile
    refs = _refine_seams(ctx, refs, forbid)
    if config.seam_expansion_band and lvl == 0:
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
        refs = cut_seams(refs, ctx, config.seam_cut_run)
    return refs


def _solve_level(
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
        cost = occurrence_penalty(refs, la, config.occurrence_weight, 3, ctx.guide.expected)
        if balance is not None:
            cost += balance.penalty(refs, lvl, la.scale)
        return cost

    schedule = [size for size, iters in config.schedule_for(lvl, ctx.n_levels) for _ in range(iters)]
    refs = _iterate(ctx, refs, forbid, schedule, occurrence, tick)
    refs = _move_seams(ctx, refs, forbid)
    if lvl == 0 and config.seam_cut_run and not all(la.wrap):
        # the last iteration's stuck border seams have no iteration after it to be handed to
        for _ in range(STUCK_RETRIES):
            if unstick_border_seams(refs, ctx, forbid, max(4, config.seam_cut_run)) == 0:
                break
            refs = _iterate(ctx, refs, forbid, schedule[-1:], occurrence, lambda: None)
            refs = _move_seams(ctx, refs, forbid)
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


def solve(
    inputs: SolverInputs,
    canvas: Canvas,
    budget: Budget,
    *,
    guidance: Guidance | None = None,
    start: tuple[int, np.ndarray] | None = None,
    balance: LabelBalance | None = None,
    stop_level: int = 0,
) -> SynthesisResult:
    """The coarse-to-fine discrete solver shared by :func:`synthesize` and texture-by-numbers
    (mazzolini2012 §4.1, laitoch2018 §3.3).

    ``inputs``: what is copied and matched (:class:`SolverInputs`, validated). ``canvas``: the
    output's shape and tiling, the exemplar's resolved ``exemplar_wrap`` (a torus along the axes
    it tiles along; along an edge that does not wrap pieces may run up to it,
    :mod:`barkgen.synth._edges`, and a straight seam stuck there is handed back to the solver
    after each iteration, :func:`unstick_border_seams`) and its ``links`` (output pixels given
    the references of others after every iteration: an atlas's gutters, :class:`OutputLinks`).
    ``budget``: the seed, ``progress``, ``debug`` and ``cache`` (an :class:`AnalysisCache` that
    supplies, or keeps, the exemplar's analysis). ``start``: ``(level, references)`` resumes at
    that level from a reference map (flat indices into the level's exemplar). ``balance`` adds
    :class:`LabelBalance`'s label-area term to the occurrence cost. ``stop_level`` > 0 stops
    after that level: the result's ``references`` and ``exemplar_shape`` are that level's, its
    ``image`` the level in the exemplar's colours, and it has no extras. After each level's
    iterations, ``config.seam_sweeps`` sweeps of seam optimisation and, at the finest levels,
    graph cuts of the straight seams (:mod:`barkgen.synth.seams.cuts`) move the borders between
    pieces onto low-error paths, comparing the first ``inputs.seam_channels`` feature channels.
    """
    ex, config, n_levels, debug = inputs.exemplar, inputs.config, inputs.n_levels, budget.debug
    if not 0 <= stop_level < n_levels:
        raise InvalidInputError(f"stop_level must be in 0..{n_levels - 1}")
    with thread_budget(config.threads):  # every pool sized, BLAS at one thread
        rng = np.random.default_rng(int(budget.seed))
        total = (
            n_levels
            - stop_level
            + sum(it for lvl in range(stop_level, n_levels) for _, it in config.schedule_for(lvl, n_levels))
        )
        done = 0

        def tick() -> None:
            nonlocal done
            done += 1
            if budget.progress:
                budget.progress(done, total)

        t0 = time.perf_counter()
        cache = budget.cache if budget.cache is not None else AnalysisCache()
        wrap = (bool(canvas.exemplar_wrap[0]), bool(canvas.exemplar_wrap[1]))
        canvas = canvas.replace(exemplar_wrap=wrap)
        levels = cache.analyse(inputs.features, n_levels, config, progress=tick, wrap=wrap, finest=stop_level)
        t1 = time.perf_counter()

        refs = forbid = None
        for lvl in reversed(range(stop_level, n_levels)):
            la = levels[lvl]
            shape = level_shape(canvas.shape, lvl)
            if start is not None and lvl > start[0]:  # levels above the resumed one are not run
                for _ in range(sum(it for _, it in config.schedule_for(lvl, n_levels))):
                    tick()
                continue
            assert la is not None  # the cache analysed every level from stop_level up
            if debug is not None:
                debug(
                    f"level{lvl}_exemplar",
                    level_image(ex, np.arange(la.height * la.width).reshape(la.height, la.width), lvl),
                )
            ctx = _level_context(la, lvl, inputs, canvas, rng, guidance)
            if start is not None and lvl == start[0]:
                refs = np.ascontiguousarray(start[1], dtype=np.int32)
                forbid = np.full(shape, -1, np.int64)
            elif refs is None:
                refs = _initial_state(ctx, guidance)
                if debug is not None and guidance is not None:
                    debug("initialization", level_image(ex, refs, lvl))
                forbid = np.full(shape, -1, np.int64)
            else:
                coarser = levels[lvl + 1]
                assert forbid is not None and coarser is not None  # set with refs, on the level above
                refs, forbid = _upsampled_state(ctx, refs, forbid, coarser)
            refs = _solve_level(
                ctx, ctx.relink(refs), forbid, balance, guidance.cleanup_passes if guidance is not None else 0, tick
            )
            if debug is not None:
                debug(f"level{lvl}_result", level_image(ex, refs, lvl))
        timings = {"analysis": t1 - t0, "synthesis": time.perf_counter() - t1}
        assert refs is not None  # the finest level ran
        return _result(inputs, canvas, budget, refs, levels, stop_level, timings)


def _result(
    inputs: SolverInputs,
    canvas: Canvas,
    budget: Budget,
    refs: np.ndarray,
    levels: list,
    stop_level: int,
    timings: dict[str, float],
) -> SynthesisResult:
    """The :class:`SynthesisResult` of the last level solved (see :func:`solve`)."""
    ex, extras, blend = inputs.exemplar, inputs.extras, inputs.config.blend
    tile, wrap, out_shape, seed = canvas.tile, canvas.exemplar_wrap, canvas.shape, budget.seed
    if stop_level > 0:
        la = levels[stop_level]
        references = np.stack([la.coords_y[refs], la.coords_x[refs]], axis=-1).astype(np.int32)
        return SynthesisResult(
            image=level_image(ex, refs, stop_level),
            references=references,
            exemplar_shape=(la.height, la.width),
            exemplar_wrap=wrap,
            seed=int(seed),
            tile=bool(tile),
            timings=timings,
        )
    h, w = ex.shape[:2]
    ry, rx = levels[0].coords_y[refs], levels[0].coords_x[refs]
    references = np.stack([ry, rx], axis=-1).astype(np.int32)
    t0 = time.perf_counter()
    if blend == "gradient":  # the colour's seams blended in the gradient domain
        image = blend_seams(ex, references, canvas)
    else:
        image = ex.reshape(h * w, ex.shape[2])[refs].reshape(out_shape + (ex.shape[2],))
    # extra maps are continuous (height, normals, roughness): resolved in the gradient domain,
    # so the borders of the copied pieces leave no cliffs in them; each wraps only where its
    # own edges meet
    extra_wraps = {name: map_wraps(e, wrap) for name, e in extras.items()}
    out_extras = {
        name: resolve_continuous(e, references, canvas.replace(exemplar_wrap=extra_wraps[name]))
        for name, e in extras.items()
    }
    timings["synthesis"] += time.perf_counter() - t0
    return SynthesisResult(
        image=image,
        references=references,
        extras=out_extras,
        exemplar_shape=(h, w),
        exemplar_wrap=wrap,
        seed=int(seed),
        tile=bool(tile),
        timings=timings,
        extra_wraps=extra_wraps,
        blend=blend,
    )
