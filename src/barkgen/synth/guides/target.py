"""The target's guide channels of a large output, made where a window reads them (issue 69, "bark
at any size").

Texture-by-numbers compares the soft labels of the output's neighbourhoods with the exemplar's
(laitoch2018 §3.3, eq. 3.2; :func:`barkgen.synth.guides.channels.guide_channels`). A level
solved window by window (:mod:`barkgen.synth._windows`) reads the target's channels only a
window at a time (:func:`barkgen.synth.guides.guidance.guide_out_at`), yet holding them whole cost
4 B a pixel a channel at the finest level (12 B at three labels: 3 GiB at 16384²). A
:class:`TargetGuideLevel` holds none: it makes a window's channels from the target's label codes
(held anyway), read with a margin wide enough that they are the whole map's: the blur's reach at
level 0 and, each level up, the 5-tap kernel of the Gaussian pyramid
(:func:`barkgen.pyramid.gaussian_pyramid`) on the level below, round the torus when the output
tiles and mirrored at its edges otherwise, as the whole map is.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.bands import NUMPY_STEP, row_bands
from barkgen.pyramid import gaussian_pyramid, level_shape
from barkgen.synth.guides.channels import SoftLabels

#: fine rows and columns read beyond a coarse block's (even, so the block's subsampling grid is
#: the level's own; >= the 5-tap kernel's reach)
_PYRAMID_MARGIN = 4


class TargetGuideLevel:
    """Level ``level`` of the target's guide pyramid: ``gaussian_pyramid(recipe(codes, tile))``'s,
    made where it is read.

    ``guide[np.ix_(rows, cols)]`` (consecutive positions of the level, round the torus when
    ``tile``) is that rectangle, ``np.asarray(guide)`` the whole level (made a band of rows at a
    time), ``shape`` the level's ``(H_l, W_l, channels)``.
    """

    ndim = 3
    dtype = np.dtype(np.float32)

    def __init__(self, codes: np.ndarray, recipe: SoftLabels, level: int, tile: bool) -> None:
        self.codes, self.recipe, self.level, self.tile = codes, recipe, int(level), bool(tile)
        self.shape = (*level_shape(codes.shape, self.level), recipe.channels)

    def __getitem__(self, grid: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        rows, cols = (np.asarray(g).ravel() for g in grid)
        return self._block(self.level, rows, cols)

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        h, w, c = self.shape
        out = np.empty(self.shape, np.float32)
        # each band reads 4**level level-0 rows a row, each with a stack of label indicators
        for start, stop in row_bands(h, w * c * 4**self.level * 8 * NUMPY_STEP):
            out[start:stop] = self._block(self.level, np.arange(start, stop), np.arange(w))
        return out if dtype is None else out.astype(dtype)

    def _block(self, level: int, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """The channels of level ``level`` at its ``rows`` and ``cols`` (consecutive positions,
        round the level when it tiles)."""
        if level == 0:
            margin = self.recipe.reach
            ys, top = _with_margin(rows, margin, self.codes.shape[0], self.tile)
            xs, left = _with_margin(cols, margin, self.codes.shape[1], self.tile)
            channels = self.recipe(self.codes[np.ix_(ys, xs)])
            return channels[top : top + rows.size, left : left + cols.size]
        # a run at a time: round a torus of odd side the pyramid's grid does not run on
        return np.concatenate(
            [np.concatenate([self._run(level, ys, xs) for xs in _runs(cols)], axis=1) for ys in _runs(rows)],
            axis=0,
        )

    def _run(self, level: int, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """:meth:`_block` of a level above the finest on a run of ``rows`` and one of ``cols``
        (each increasing by one): one pyramid step of the finer level's block under it."""
        fine_h, fine_w = level_shape(self.codes.shape, level - 1)
        fine_rows, top = _children(rows, fine_h, self.tile)
        fine_cols, left = _children(cols, fine_w, self.tile)
        coarse = gaussian_pyramid(self._block(level - 1, fine_rows, fine_cols), 2)[1]
        return coarse[top : top + rows.size, left : left + cols.size]


def _runs(positions: np.ndarray) -> list[np.ndarray]:
    """Consecutive ``positions`` cut where they go round the axis."""
    return np.split(positions, np.flatnonzero(np.diff(positions) != 1) + 1)


def _with_margin(positions: np.ndarray, margin: int, n: int, wrap: bool) -> tuple[np.ndarray, int]:
    """``positions`` (consecutive, round the axis of ``n`` px when it ``wrap``\\ s) with
    ``margin`` more either side (round the axis, or up to its ends) and how many came before."""
    first, last = int(positions[0]), int(positions[-1])
    if wrap:
        before, after = np.arange(first - margin, first) % n, np.arange(last + 1, last + 1 + margin) % n
    else:
        before, after = np.arange(max(first - margin, 0), first), np.arange(last + 1, min(last + 1 + margin, n))
    return np.concatenate([before, positions, after]), before.size


def _children(run: np.ndarray, fine_n: int, wrap: bool) -> tuple[np.ndarray, int]:
    """The finer level's positions whose pyramid step gives the ``run`` exactly (its children
    and :data:`_PYRAMID_MARGIN` more either side: round the axis, or clipped to it where the
    pyramid mirrors the edge as the whole level's does), and where the run's first position
    lands in that step's output."""
    lo, hi = 2 * int(run[0]) - _PYRAMID_MARGIN, 2 * int(run[-1]) + 2 + _PYRAMID_MARGIN
    if wrap:
        return np.arange(lo, hi) % fine_n, _PYRAMID_MARGIN // 2
    lo = max(lo, 0)
    return np.arange(lo, min(hi, fine_n)), int(run[0]) - lo // 2


def target_guide_pyramid(
    codes: np.ndarray, recipe: SoftLabels, n_levels: int, tile: bool, made_where_read: int = 0
) -> list:
    """The target's guide channels at every level, finest first: whole arrays
    (``gaussian_pyramid(recipe(codes, tile))``), but for the ``made_where_read`` finest levels,
    :class:`TargetGuideLevel`\\ s (the levels a windowed solve reads a window at a time)."""
    lazy = min(made_where_read, n_levels)
    if lazy == 0:
        return gaussian_pyramid(recipe(codes, tile), n_levels, (tile, tile))
    levels: list = [TargetGuideLevel(codes, recipe, lvl, tile) for lvl in range(lazy)]
    if n_levels > lazy:  # the coarser levels whole, from the first of them (made in bands)
        first = np.asarray(TargetGuideLevel(codes, recipe, lazy, tile))
        levels += gaussian_pyramid(first, n_levels - lazy, (tile, tile))
    return levels
