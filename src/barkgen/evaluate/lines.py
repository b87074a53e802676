"""Straight lines in any image or map, found from the pixels alone (no reference map needed).

Where two copied pieces meet along a row or a column and the cut fails to hide the border, the
image jumps across that one boundary between pixel rows (or columns): the step between the two
pixels either side is larger than the steps across the boundaries next to it, for many pixels
along it, whatever the sign or size of the jump. A texture's own features (bark's furrows,
plates, lichen) step where their edges cross a boundary too, but their edges wind and are a few
pixels soft, so along any one boundary the pattern is short. The detector here marks, for every
pair of neighbouring pixels, whether the step across their boundary is the largest of the
boundaries within :data:`REACH` px of it; a boundary is on a line where it is so for more than
:data:`SHARE` of the :data:`WINDOW` px along it; runs :data:`GAP` px apart are one line (where
both sides of a seam happen to match). The measure is the longest run, px: blind to contrast
(a height map in metres and a texture in sRGB score alike) and to the sign of the step.

It looks for lines along rows and columns: the seams of patch-based synthesis on a pixel grid
(mazzolini2012 §3.2) and the borders of a tiled image are axis-aligned.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from barkgen.errors import InvalidInputError
from barkgen.evaluate.patches import as_lab, as_unit_image
from barkgen.evaluate.seams import longest_run

#: the boundaries either side a step is compared with, px
REACH = 3
#: px along a boundary over which it must mostly be the local maximum
WINDOW = 32
#: the share of the window where it must be (a boundary of a texture that is no line: ~1/4)
SHARE = 0.6
#: px of gap bridged within one line
GAP = 32


def _steps(image: np.ndarray, tile: bool) -> np.ndarray:
    """``(H, B)``: the step (norm over channels) across each boundary between columns ``j`` and
    ``j + 1`` (``B = W - 1``, or ``W`` when ``tile``: the last column against the first)."""
    nxt = np.roll(image, -1, axis=1) if tile else image[:, 1:]
    cur = image if tile else image[:, :-1]
    return np.sqrt(np.sum((nxt - cur) ** 2, axis=2))


def _local_maxima(steps: np.ndarray, tile: bool) -> np.ndarray:
    """Where a step is larger than every step within :data:`REACH` boundaries of it on the
    same row (round the row when ``tile``; at an edge, the boundaries there are)."""
    n = steps.shape[1]
    idx = np.arange(n)
    beside = np.zeros_like(steps)
    for off in range(1, REACH + 1):
        for sign in (-1, 1):
            cols = (idx + sign * off) % n if tile else np.clip(idx + sign * off, 0, n - 1)
            np.maximum(beside, np.where(cols == idx, 0.0, steps[:, cols]), out=beside)
    return steps > beside


def _runs_on(maxima: np.ndarray) -> np.ndarray:
    """Pixels on a line down axis 0: covered by a :data:`WINDOW` px window where the boundary
    is the local maximum more than :data:`SHARE` of the time, gaps of :data:`GAP` px closed."""
    length = maxima.shape[0]
    if length < WINDOW:
        return np.zeros_like(maxima)
    total = np.cumsum(np.concatenate((np.zeros((1, maxima.shape[1])), maxima), axis=0), axis=0)
    strong = (total[WINDOW:] - total[:-WINDOW]) / WINDOW > SHARE  # window k covers k .. k + WINDOW - 1
    cover = np.zeros((length + 1, maxima.shape[1]), np.int32)
    cover[: len(strong)] += strong
    cover[WINDOW : WINDOW + len(strong)] -= strong
    on = np.cumsum(cover, axis=0)[:length] > 0
    padded = np.pad(on, ((GAP, GAP), (0, 0)))
    return ndimage.binary_closing(padded, np.ones((GAP + 1, 1), bool))[GAP:-GAP]


def _vertical_lines(image: np.ndarray, tile: bool) -> np.ndarray:
    """``(H, B)`` mask of the boundaries between columns that are on a vertical line."""
    maxima = _local_maxima(_steps(image, tile), tile).astype(np.float64)
    if not tile:
        return _runs_on(maxima)
    h = maxima.shape[0]  # round the image's end: measured on three copies, the middle one kept
    return _runs_on(np.concatenate((maxima, maxima, maxima), axis=0))[h : 2 * h]


def line_mask(image: np.ndarray, *, tile: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The boundaries on a straight line: ``(across_cols, across_rows)`` masks of neighbour
    pairs (``across_cols[i, j]``: between pixels ``(i, j)`` and ``(i, j + 1)``, on a vertical
    line; ``across_rows[i, j]``: between ``(i, j)`` and ``(i + 1, j)``, on a horizontal one;
    with ``tile`` the last column and row pair with the first)."""
    img = as_unit_image(image)
    return _vertical_lines(img, tile), _vertical_lines(img.transpose(1, 0, 2), tile).T


def longest_line(image: np.ndarray, *, tile: bool = False) -> int:
    """The longest straight line visible in an image or map, px, from its pixels alone.

    A line is a run along one boundary between pixel rows or columns where the step across it
    is mostly the largest of the boundaries within :data:`REACH` px (:func:`line_mask`). A
    photo of bark scores well under 100 px at 1024 px (its furrows wind); a hard straight seam
    or step scores its length; a tiled image's border counts when ``tile`` (the last row or
    column against the first), and a line may run round it.

    Parameters
    ----------
    image : ndarray
        ``(H, W)`` or ``(H, W, C)``: a texture, a height, normal, AO or label map; uint8,
        uint16 or float.
    tile : bool, default False
        The image tiles: its edges meet.

    Returns
    -------
    int
        px; compare with the photo's own figure (its straight features count too).
    """
    across_cols, across_rows = line_mask(image, tile=tile)
    return max(longest_run(across_cols.T, wrap=tile), longest_run(across_rows, wrap=tile))


def wrap_step_ratio(image: np.ndarray) -> float:
    """How visible the border of a tiling image is when tiled: the mean step (CIELAB norm for a
    colour image; the norm over channels for a map) between its last column and its first and
    its last row and its first, over the mean step between neighbouring columns and rows inside.

    1 means the tiles meet as seamlessly as the image's own pixels; 2 and more shows a grid of
    seams when the texture repeats. For an image that does not tile the figure is not meaningful
    (a photo's opposite edges are unrelated: several times 1).
    """
    img = as_unit_image(image)
    if img.shape[2] == 3:
        img = as_lab(image).astype(np.float64)
    across, inside = [], []
    for axis in (0, 1):
        steps = np.sqrt(np.sum(np.diff(img, axis=axis) ** 2, axis=2))
        edge = np.take(img, [0], axis=axis) - np.take(img, [-1], axis=axis)
        across.append(np.sqrt(np.sum(edge**2, axis=2)).ravel())
        inside.append(steps.ravel())
    return float(np.concatenate(across).mean() / max(float(np.concatenate(inside).mean()), 1e-12))


def grid_step_ratio(image: np.ndarray, side: int, *, tile: bool = False) -> float:
    """How visible a grid of ``side`` px cells is in an image (the windows a large output was
    solved in, the tiles of a UDIM row laid side by side): the mean step (as
    :func:`wrap_step_ratio` measures it) across the boundaries between cells, every ``side``-th
    row and column, over the mean step across every other boundary between neighbouring rows
    and columns. ``tile``: the image wraps round, so its last row and column border its first.

    1 means the cells meet as seamlessly as the image's own pixels; 1.25 and more shows the grid.
    """
    img = as_unit_image(image)
    if img.shape[2] == 3:
        img = as_lab(image).astype(np.float64)
    on_grid, off_grid = [], []
    for axis in (0, 1):
        nxt = np.roll(img, -1, axis=axis) if tile else np.delete(img, 0, axis=axis)
        cur = img if tile else np.delete(img, -1, axis=axis)
        steps = np.sqrt(np.sum((nxt - cur) ** 2, axis=2)).mean(axis=1 - axis)
        border = np.arange(len(steps)) % side == side - 1
        on_grid.append(steps[border])
        off_grid.append(steps[~border])
    grid = np.concatenate(on_grid)
    if grid.size == 0:
        raise InvalidInputError(f"the image is no larger than one {side} px cell: no boundary to measure")
    return float(grid.mean() / max(float(np.concatenate(off_grid).mean()), 1e-12))
