"""Straight lines in any image or map, found from the pixels alone (no reference map needed).

Where two copied pieces meet along a row or a column and the cut fails to hide the border, the
image steps across that one boundary between pixel rows (or columns) much more than it steps
across the boundaries a few pixels to either side, and does so for many pixels along it. A
texture's own features (bark's furrows, plates, lichen) do not: they step where they cross an
edge, but their edges wind, so along any one boundary the excess is short. The detector here
measures, for every pair of neighbouring pixels, the step across their boundary against the
median step of the boundaries 2-4 px beside it (the local texture's own step), smooths that
excess along the boundary and returns the longest run over a threshold, px.

It looks for lines along rows and columns: the seams of patch-based synthesis on a pixel grid
(mazzolini2012 §3.2) and the borders of a tiled image are axis-aligned.
"""

from __future__ import annotations

import numpy as np

from barkgen.evaluate.patches import as_unit_image

#: the boundaries either side whose steps are the local texture's own (px away)
_BESIDE = (2, 3, 4)
#: the excess of a boundary's step over its neighbours' that marks a line
THRESHOLD = 2.5
#: px along the boundary the excess is averaged over (a line's step changes sign and size)
WINDOW = 9
#: px of gap bridged within one line (where both sides happen to match)
GAP = 4


def _steps(image: np.ndarray, tile: bool) -> np.ndarray:
    """``(H, B)``: the step (norm over channels) across each boundary between columns ``j`` and
    ``j + 1`` (``B = W - 1``, or ``W`` when ``tile``: the last column against the first)."""
    nxt = np.roll(image, -1, axis=1) if tile else image[:, 1:]
    cur = image if tile else image[:, :-1]
    return np.sqrt(np.sum((nxt - cur) ** 2, axis=2))


def _excess(steps: np.ndarray, tile: bool) -> np.ndarray:
    """Each step over the median of the steps :data:`_BESIDE` boundaries to either side (floored
    at half the image's median step: flat areas and compression blocks are not lines)."""
    n = steps.shape[1]
    idx = np.arange(n)
    beside = []
    for off in _BESIDE:
        for sign in (-1, 1):
            cols = (idx + sign * off) % n if tile else np.clip(idx + sign * off, 0, n - 1)
            beside.append(steps[:, cols])
    local = np.median(np.stack(beside), axis=0)
    floor = 0.5 * max(float(np.median(steps)), 1e-6)
    return steps / np.maximum(local, floor)


def _along(values: np.ndarray, length: int, tile: bool) -> np.ndarray:
    """Mean of ``length`` consecutive values down axis 0, centred (round the end when ``tile``)."""
    half = length // 2
    if tile:
        padded = np.concatenate((values[-half:], values, values[:half]), axis=0)
    else:
        padded = np.pad(values, ((half, half), (0, 0)), mode="edge")
    total = np.cumsum(np.concatenate((np.zeros((1, values.shape[1])), padded), axis=0), axis=0)
    return (total[length:] - total[:-length]) / length


def _longest_down(on: np.ndarray, tile: bool) -> int:
    """The longest run of True down axis 0 of a mask, runs ``GAP`` px apart joined."""
    from scipy import ndimage

    from barkgen.evaluate.seams import longest_run

    if GAP:
        structure = np.ones((GAP + 1, 1), bool)
        if tile:
            reps = np.concatenate((on, on, on), axis=0)
            on = ndimage.binary_closing(reps, structure)[len(on) : 2 * len(on)]
        else:
            padded = np.pad(on, ((GAP, GAP), (0, 0)))
            on = ndimage.binary_closing(padded, structure)[GAP:-GAP]
    return longest_run(on.T, wrap=tile)


def line_mask(image: np.ndarray, *, tile: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The boundaries on a straight line: ``(across_cols, across_rows)`` masks of neighbour
    pairs (``across_cols[i, j]``: between pixels ``(i, j)`` and ``(i, j + 1)``, on a vertical
    line; ``across_rows[i, j]``: between ``(i, j)`` and ``(i + 1, j)``, on a horizontal one)."""
    img = as_unit_image(image)
    masks = []
    for arr in (img, img.transpose(1, 0, 2)):
        steps = _steps(arr, tile)
        masks.append(_along(_excess(steps, tile), WINDOW, tile) > THRESHOLD)
    return masks[0], masks[1].T


def longest_line(image: np.ndarray, *, tile: bool = False) -> int:
    """The longest straight line visible in an image or map, px, from its pixels alone.

    A line is a run along one boundary between pixel rows or columns where the image steps
    :data:`THRESHOLD` times more than across the boundaries 2-4 px beside it (averaged over
    :data:`WINDOW` px along the boundary, gaps of up to :data:`GAP` px bridged). A photo of bark
    scores a few tens of px (its furrows wind); a hard straight seam or step scores its length;
    a tiled image's border counts when ``tile`` (the last row or column against the first).

    Parameters
    ----------
    image : ndarray
        ``(H, W)`` or ``(H, W, C)``: a texture, a height, normal, AO or label map; uint8,
        uint16 or float.
    tile : bool, default False
        The image tiles: its edges meet, and lines may run round it.

    Returns
    -------
    int
        px; compare with the photo's own figure (its straight features count too).
    """
    across_cols, across_rows = line_mask(image, tile=tile)
    return max(_longest_down(across_cols, tile), _longest_down(across_rows.T, tile))
