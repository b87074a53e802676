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
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from barkgen._shared.arrays import as_uint8
from barkgen._shared.canvas import Budget, Canvas
from barkgen._shared.threads import thread_budget
from barkgen.errors import InvalidInputError
from barkgen.pyramid import level_shape
from barkgen.synth._analysis import AnalysisCache
from barkgen.synth._edges import map_wraps
from barkgen.synth._level import (
    LevelContext,
    SolverInputs,
    initial_state,
    level_context,
    solve_level,
    upsampled_state,
)
from barkgen.synth._occurrence import LabelBalance
from barkgen.synth._windows import solve_windowed_level, windowed_level
from barkgen.synth.guides.guidance import Guidance
from barkgen.synth.seams.gradient import BLEND_HALO, blend_seams, blend_seams_in_windows, resolve_continuous


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

        passes = guidance.cleanup_passes if guidance is not None else 0

        def solve_this(c: LevelContext, r: np.ndarray, f: np.ndarray, t: Callable[[], None]) -> np.ndarray:
            return solve_level(c, r, f, balance, passes, t)

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
            by_window = windowed_level(config, lvl, shape, canvas.links)
            ctx = level_context(la, lvl, inputs, canvas, rng, guidance, by_window)
            if start is not None and lvl == start[0]:
                refs = np.ascontiguousarray(start[1], dtype=np.int32)
                forbid = np.full(shape, -1, np.int64)
            elif refs is None:
                refs = initial_state(ctx, guidance)
                if debug is not None and guidance is not None:
                    debug("initialization", level_image(ex, refs, lvl))
                forbid = np.full(shape, -1, np.int64)
            else:
                coarser = levels[lvl + 1]
                assert forbid is not None and coarser is not None  # set with refs, on the level above
                refs, forbid = upsampled_state(ctx, refs, forbid, coarser)
            refs = ctx.relink(refs)
            if by_window:
                refs = solve_windowed_level(ctx, refs, forbid, solve_this, tick)
            else:
                refs = solve_this(ctx, refs, forbid, tick)
            if debug is not None:
                debug(f"level{lvl}_result", level_image(ex, refs, lvl))
        timings = {"analysis": t1 - t0, "synthesis": time.perf_counter() - t1}
        assert refs is not None  # the finest level ran
        # (the levels' working state goes before the result is made: the forbidden offsets, 8 B
        # a pixel, and the finest level's guide)
        del forbid, ctx
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
    references = np.empty(out_shape + (2,), np.int32)  # (filled a coordinate at a time: no temporaries held)
    references[..., 0] = levels[0].coords_y[refs]
    references[..., 1] = levels[0].coords_x[refs]
    t0 = time.perf_counter()
    window = inputs.config.window
    if blend == "gradient" and window and min(out_shape) > window + 2 * BLEND_HALO:  # (memory: a window's)
        image = blend_seams_in_windows(ex, references, canvas, window)
    elif blend == "gradient":  # the colour's seams blended in the gradient domain
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
