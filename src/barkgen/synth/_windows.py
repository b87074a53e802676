"""Large pyramid levels solved window by window, so the solver's working arrays are bounded by
the window and not the output (issue 69, "bark at any size").

A level is cut into square cores of ``config.window`` px, taken in raster order. Each core is
solved with a halo of :data:`WINDOW_HALO` px round it, read from the level's state as it is at
that moment (the cores already solved above and to the left, and the start state the level was
up-sampled to elsewhere; round the torus when the output tiles) and frozen: every step of the
level (M-step / E-step iterations, seam sweeps and cuts, expansion moves) runs on the window,
then the halo's references are put back (:meth:`barkgen.synth._level.LevelContext.hold`), so a
core continues into its neighbours' pieces as a whole solve would, and only its core is written
back. Only the :data:`WINDOWED_LEVELS` finest levels are windowed; the coarser ones are solved
whole as before.

The kernels need no change: a window is a small output that does not tile, its neighbourhoods
clamped at its own edge, which the halo keeps away from the core. Forbidden offsets (reference
minus position) are re-expressed for the window's positions on the way in and out
(:func:`barkgen.synth.seams.pieces.moved_offsets`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from barkgen.synth._level import LevelContext, move_seams
from barkgen.synth.guides.guidance import LevelGuidance, guide_out_at
from barkgen.synth.seams.pieces import moved_offsets

#: px of frozen halo round a window's core: the largest neighbourhood's radius (7 for 15x15),
#: the E-step's vote radius (at most 7) and the M-step's forward shift, with room to spare
WINDOW_HALO = 16
#: only this many of the finest levels are ever windowed: the coarser ones lay out the output's
#: large-scale structure and are solved whole (4096² from the 1024² sample, 512 px windows: the
#: mean coherence of six 1024² crops 1.18x the whole solve's with the third level windowed too,
#: 1.00x with the two finest only; 8192², 1024 px windows: 1.28x and 1.03x)
WINDOWED_LEVELS = 2
#: px either side of the first windows' borders that the second, half-shifted windows may move
#: (twice the band the graph cuts reroute a straight seam in, :data:`barkgen.synth.seams.cuts.BAND`,
#: so their moves stay clear of its edge)
SEAM_BAND = 32


@dataclass(frozen=True)
class Window:
    """One window of a level: the level's ``rows`` and ``cols`` it reads (core and halo, taken
    round the torus when the output tiles) and where its core lies in them (``core``: two
    slices); ``target``: the core's rows and columns in the level."""

    rows: np.ndarray
    cols: np.ndarray
    core: tuple[slice, slice]

    @property
    def target(self) -> tuple[np.ndarray, ...]:
        return np.ix_(self.rows[self.core[0]], self.cols[self.core[1]])


def _spans(n: int, side: int, halo: int, tile: bool, offset: int) -> Iterator[tuple[np.ndarray, slice]]:
    """Along one axis of ``n`` px: each core's positions with its halo and the core within
    them; the cores start at ``offset`` (the first, from 0, shorter when the axis does not wrap;
    round the torus when it does)."""
    if tile:
        starts = list(range(offset, offset + n, side))
        stops = [min(start + side, offset + n) for start in starts]
    else:
        starts = ([0] if offset else []) + list(range(offset, n, side))
        stops = starts[1:] + [n]
    for start, stop in zip(starts, stops):
        first, last = (start - halo, stop + halo) if tile else (max(start - halo, 0), min(stop + halo, n))
        yield np.arange(first, last) % n, slice(start - first, stop - first)


def window_grid(
    shape: tuple[int, int], side: int, tile: bool, halo: int = WINDOW_HALO, offset: int = 0
) -> list[Window]:
    """The windows of a level of ``shape`` with cores of ``side`` px from ``offset`` on (along
    both axes), in raster order."""
    rows = list(_spans(shape[0], side, halo, tile, offset))
    cols = list(_spans(shape[1], side, halo, tile, offset))
    return [Window(r, c, (r_core, c_core)) for r, r_core in rows for c, c_core in cols]


def is_windowed(ctx: LevelContext) -> bool:
    """Whether the level of ``ctx`` is solved window by window (:func:`windowed_level`)."""
    return windowed_level(ctx.config, ctx.level, ctx.shape, ctx.links)


def windowed_level(config, level: int, shape: tuple[int, int], links) -> bool:
    """Whether a level is solved window by window: a window is set (``config.window``), the
    level is one of the :data:`WINDOWED_LEVELS` finest and larger than a window and its halo on
    both sides, and no output pixel takes another's references (``links``, a texture atlas's
    gutters, may span the level: such a level is solved whole)."""
    side = config.window
    return bool(side) and level < WINDOWED_LEVELS and min(shape) > side + 2 * WINDOW_HALO and links is None


def window_guide(guide: LevelGuidance, grid: tuple[np.ndarray, ...]) -> LevelGuidance:
    """A level's texture-by-numbers guide (:class:`LevelGuidance`) for one window: its target
    labels and guide neighbourhoods read at the window's ``grid`` (each exemplar pixel's
    expected use stays the level's: the window's occurrence cost counts the whole level)."""
    if not guide.guided:
        return guide
    if guide.projections:  # projected on the window (the level's own never made whole)
        guide_out = guide_out_at(guide, grid[0].ravel(), grid[1].ravel())
    else:
        guide_out = {size: np.ascontiguousarray(channels[grid]) for size, channels in guide.guide_out.items()}
    return dataclasses.replace(
        guide,
        target=np.ascontiguousarray(guide.target[grid]),
        guide_out=guide_out,
        projections={},
        target_guide=None,
    )


def solve_windowed_level(
    ctx: LevelContext,
    refs: np.ndarray,
    forbid: np.ndarray,
    solve: Callable[[LevelContext, np.ndarray, np.ndarray, Callable[[], None]], np.ndarray],
    tick: Callable[[], None],
) -> np.ndarray:
    """The level of ``ctx`` from its starting state, window by window (:func:`window_grid`,
    each core with its frozen halo), by ``solve(context, references, forbidden offsets,
    tick)``: the whole level's solve (:func:`barkgen.synth._level.solve_level`) run on a
    window. Then the seams are
    moved again (:func:`barkgen.synth._level.move_seams`) in windows shifted by half a window,
    whose cores hold the first windows' borders, so a seam left straight along a frozen border
    is cut like any other: only the pixels within :data:`SEAM_BAND` px of those borders move, so
    a straight seam along the second windows' own borders, where they cross that band, is at
    most ``2 * SEAM_BAND`` long. ``tick`` is called as often as a whole solve would, spread over
    the windows. Returns the level's reference map (``refs`` and ``forbid`` are updated in
    place)."""
    side = ctx.config.window
    n_ticks = sum(it for _, it in ctx.config.schedule_for(ctx.level, ctx.n_levels))
    windows = window_grid(ctx.shape, side, ctx.tile)

    def solve_window(window_ctx: LevelContext, local: np.ndarray, local_forbid: np.ndarray) -> np.ndarray:
        return solve(window_ctx, local, local_forbid, lambda: None)

    # how often the whole level uses each exemplar pixel, kept up to date window by window: each
    # window's occurrence cost sees the level's use, as a whole solve does
    n = ctx.analysis.height * ctx.analysis.width
    counts = np.bincount(refs.ravel(), minlength=n).astype(np.float32)
    for i, window in enumerate(windows):
        _solve_window(ctx, refs, forbid, window, solve_window, counts=counts)
        for _ in range((i + 1) * n_ticks // len(windows) - i * n_ticks // len(windows)):
            tick()
    for window in window_grid(ctx.shape, side, ctx.tile, offset=side // 2):
        near = (_border_distance(window.rows, side)[:, None] < SEAM_BAND) | (
            _border_distance(window.cols, side)[None, :] < SEAM_BAND
        )
        _solve_window(ctx, refs, forbid, window, _recut, near)
    return refs


def _recut(ctx: LevelContext, refs: np.ndarray, forbid: np.ndarray) -> np.ndarray:
    """The second pass's seam moves: the local sweeps and the straight seams' graph cuts (the
    expansion moves ran in the first pass; the band they could still move is a few pixels)."""
    return move_seams(ctx, refs, forbid, expansion=False)


def _border_distance(positions: np.ndarray, side: int) -> np.ndarray:
    """Each position's distance, in px, from the nearest border between two window cores of
    ``side`` px (0 on either side of it)."""
    within = positions % side
    return np.minimum(within, side - 1 - within)


def _solve_window(
    ctx: LevelContext,
    refs: np.ndarray,
    forbid: np.ndarray,
    window: Window,
    solve: Callable[[LevelContext, np.ndarray, np.ndarray], np.ndarray],
    free: np.ndarray | None = None,
    counts: np.ndarray | None = None,
) -> None:
    """``solve(window's context, its references, its forbidden offsets)`` on one window of the
    level, its halo frozen (and, given ``free``, every pixel it does not mark); its core
    written back into ``refs`` and ``forbid``. ``counts``: the level's use of each exemplar
    pixel, which the window's occurrence cost reads and the new core updates."""
    grid = np.ix_(window.rows, window.cols)
    local = np.ascontiguousarray(refs[grid])
    n = counts.size if counts is not None else 0
    outside = None if counts is None else (counts - np.bincount(local.ravel(), minlength=n), refs.size)
    row_moves = np.arange(len(window.rows)) - window.rows
    col_moves = np.arange(len(window.cols)) - window.cols
    local_forbid = np.ascontiguousarray(moved_offsets(forbid[grid], row_moves, col_moves))
    halo = np.ones(local.shape, bool)
    halo[window.core] = False
    if free is not None:
        halo |= ~free
    window_ctx = dataclasses.replace(
        ctx,
        shape=local.shape,
        tile=False,
        guide=window_guide(ctx.guide, grid),
        frozen=(halo, local.copy()),
        outside=outside,
    )
    solved = solve(window_ctx, local, local_forbid)
    if counts is not None:
        counts += np.bincount(solved[window.core].ravel(), minlength=n)
        counts -= np.bincount(refs[window.target].ravel(), minlength=n)
    refs[window.target] = solved[window.core]
    forbid[window.target] = moved_offsets(local_forbid, -row_moves, -col_moves)[window.core]


def by_windows(
    refs: np.ndarray,
    side: int,
    step: Callable[[np.ndarray], np.ndarray],
    *,
    tile: bool,
    halo: int = WINDOW_HALO,
    offset: int = 0,
) -> np.ndarray:
    """A reference map ``(H, W)`` or ``(H, W, 2)`` with ``step`` run on it window by window
    (:func:`window_grid`: cores of ``side`` px from ``offset`` on, in raster order, each with
    ``halo`` px read round it from the map as the cores before it left it; round the torus when
    it ``tile``\\ s) and each window's core written back, in place: for a pass whose moves reach
    less than ``halo`` (seam moves, straight-seam cuts), whose working memory is then a
    window's, not the map's (issue 69). ``step(local)`` returns the window's new references
    (it may take ``local``, a copy, as its own)."""
    for window in window_grid(refs.shape[:2], side, tile, halo=halo, offset=offset):
        grid = np.ix_(window.rows, window.cols)
        refs[window.target] = step(refs[grid])[window.core]
    return refs
