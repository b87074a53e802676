"""Where copied pieces meet, read from a reference map: the largest piece copied whole, the
borders between pieces, the longest straight run of border, and how much an image steps across
the borders against inside the pieces.

A reference map (``reference.png`` of ``barkgen generate``, :func:`barkgen.io.read_reference`)
holds for every output pixel the ``(row, col)`` of the photo pixel it shows. Two neighbouring
output pixels continue one piece when their references are neighbours the same way (the
*offset*, reference minus position, is the same); elsewhere two pieces meet. Patch-based
synthesis hides those borders by choosing where to cut (the minimum-error boundary cut,
mazzolini2012 §3.2) and by blending across them; a border that runs straight along a row or a
column for long is the artefact an eye finds at once.
"""

from __future__ import annotations

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.evaluate.patches import as_unit_image


def _check_references(references: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    refs = np.asarray(references)
    if refs.ndim != 3 or refs.shape[2] != 2 or refs.dtype.kind not in "iu" or min(refs.shape[:2]) < 1:
        raise InvalidInputError(f"references: expected an (H, W, 2) integer map of (row, col), got {refs.shape}")
    return refs[:, :, 0].astype(np.int64), refs[:, :, 1].astype(np.int64)


def _gap(step: np.ndarray, period: int | None) -> np.ndarray:
    """|step| of a reference step that continues a piece at 0; modulo ``period`` when the photo
    wraps round (a step from its last row to its first continues the piece)."""
    if period:
        step = np.mod(step, period)
        step = np.minimum(step, period - step)
    return np.abs(step)


def piece_borders(
    references: np.ndarray,
    *,
    tile: bool = False,
    exemplar_wrap: tuple[int, int] | None = None,
    tolerance: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """The borders between copied pieces, as two masks of neighbour pairs.

    Parameters
    ----------
    references : ndarray of int, shape (H, W, 2)
        ``(row, col)`` in the photo of every output pixel.
    tile : bool, default False
        The output tiles: its last row and column border its first.
    exemplar_wrap : (int, int), optional
        The photo's ``(h, w)`` when it tiles itself (``report.json``'s ``exemplar_wrap``):
        references continue across its edges; 0 for an axis along which it does not.
    tolerance : int, default 0
        Px by which a neighbour's reference may miss the continuing one and still continue the
        piece.

    Returns
    -------
    across_rows : ndarray of bool, shape (H - 1, W), or (H, W) when ``tile``
        ``[i, j]``: pixels ``(i, j)`` and ``(i + 1, j)`` belong to different pieces (a border
        running along the row; the last row against the first when ``tile``).
    across_cols : ndarray of bool, shape (H, W - 1), or (H, W) when ``tile``
        ``[i, j]``: pixels ``(i, j)`` and ``(i, j + 1)`` do.
    """
    ry, rx = _check_references(references)
    ph, pw = exemplar_wrap if exemplar_wrap else (None, None)
    masks = []
    for axis in (0, 1):
        if tile:
            dy, dx = np.roll(ry, -1, axis) - ry, np.roll(rx, -1, axis) - rx
        else:
            dy, dx = np.diff(ry, axis=axis), np.diff(rx, axis=axis)
        gap = np.maximum(_gap(dy - (axis == 0), ph), _gap(dx - (axis == 1), pw))
        masks.append(gap > tolerance)
    return masks[0], masks[1]


def seam_mask(
    references: np.ndarray, *, tile: bool = False, exemplar_wrap: tuple[int, int] | None = None, tolerance: int = 0
) -> np.ndarray:
    """``(H, W)`` bool: the output pixels on a border between copied pieces (both pixels of
    every pair :func:`piece_borders` finds). Parameters as :func:`piece_borders`."""
    across_rows, across_cols = piece_borders(references, tile=tile, exemplar_wrap=exemplar_wrap, tolerance=tolerance)
    h, w = np.shape(references)[:2]
    mask = np.zeros((h, w), bool)
    if tile:
        mask |= across_rows | np.roll(across_rows, 1, 0) | across_cols | np.roll(across_cols, 1, 1)
        return mask
    mask[:-1] |= across_rows
    mask[1:] |= across_rows
    mask[:, :-1] |= across_cols
    mask[:, 1:] |= across_cols
    return mask


def longest_run(mask: np.ndarray, *, wrap: bool = False) -> int:
    """The longest run of True along any row of a 2-D mask (round the row's end when ``wrap``)."""
    mask = np.asarray(mask, bool)
    if mask.size == 0 or not mask.any():
        return 0
    width = mask.shape[1]
    if wrap:
        if mask.all(axis=1).any():
            return width
        mask = np.concatenate((mask, mask), axis=1)
    padded = np.zeros((mask.shape[0], mask.shape[1] + 2), np.int8)
    padded[:, 1:-1] = mask
    edges = np.diff(padded, axis=1)
    starts, ends = np.nonzero(edges == 1), np.nonzero(edges == -1)
    # row-major order: the k-th start and the k-th end of the whole array belong together
    return int(min(int((ends[1] - starts[1]).max()), width))


def longest_seam(
    references: np.ndarray, *, tile: bool = False, exemplar_wrap: tuple[int, int] | None = None, tolerance: int = 0
) -> int:
    """The longest straight border between copied pieces, px: a run of border along one row
    (horizontal) or one column (vertical), round the output's edge when ``tile``.

    0 for an output copied in one piece; short (a few tens of px) for well-cut patches, whose
    borders wind; the output's full side for blocks laid in a grid. Parameters as
    :func:`piece_borders`.
    """
    across_rows, across_cols = piece_borders(references, tile=tile, exemplar_wrap=exemplar_wrap, tolerance=tolerance)
    return max(longest_run(across_rows, wrap=tile), longest_run(across_cols.T, wrap=tile))


def stacked_pieces(
    references: np.ndarray, *, tile: bool = False, exemplar_wrap: tuple[int, int] | None = None
) -> tuple[int, int]:
    """``(stacked, borders)``: of the neighbour pairs on a border between copied pieces
    (:func:`piece_borders`), how many stack two pieces of one photo column (one pixel above the
    other, both copying the same column of the photo, its rows jumping) or of one photo row (side
    by side, the same row, its columns jumping), and how many there are in all.

    A stacked border continues whatever straight edge the photo has along that column or row
    across it: the photo's own line, copied twice, becomes one twice as long. Parameters as
    :func:`piece_borders`.
    """
    ry, rx = _check_references(references)
    ph, pw = exemplar_wrap if exemplar_wrap else (None, None)
    borders = piece_borders(references, tile=tile, exemplar_wrap=exemplar_wrap)
    stacked = 0
    for axis, (along, period) in enumerate(((rx, pw), (ry, ph))):
        # across rows (axis 0) the column must stay; across columns the row
        step = np.roll(along, -1, axis) - along if tile else np.diff(along, axis=axis)
        stacked += int(np.count_nonzero(borders[axis] & (_gap(step, period) == 0)))
    return stacked, int(borders[0].sum() + borders[1].sum())


def piece_labels(
    references: np.ndarray, *, tile: bool = False, exemplar_wrap: tuple[int, int] | None = None
) -> np.ndarray:
    """``(H, W)`` int: the copied piece of every output pixel, numbered from 0: the 4-connected
    regions of one offset (reference minus position, modulo the photo's size along an axis it
    wraps along; across the output's edges when ``tile``)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from skimage.measure import label

    ry, rx = _check_references(references)
    h, w = ry.shape
    oy = ry - np.arange(h)[:, None]
    ox = rx - np.arange(w)[None, :]
    if exemplar_wrap and exemplar_wrap[0]:
        oy = np.mod(oy, exemplar_wrap[0])
    if exemplar_wrap and exemplar_wrap[1]:
        ox = np.mod(ox, exemplar_wrap[1])
    _, key = np.unique(np.stack((oy.ravel(), ox.ravel()), 1), axis=0, return_inverse=True)
    labels = label(key.reshape(h, w) + 1, background=0, connectivity=1) - 1
    if not tile:
        return labels
    across_rows, across_cols = piece_borders(references, tile=True, exemplar_wrap=exemplar_wrap)
    pairs = [(labels[-1][~across_rows[-1]], labels[0][~across_rows[-1]])]
    pairs.append((labels[:, -1][~across_cols[:, -1]], labels[:, 0][~across_cols[:, -1]]))
    a = np.concatenate([p[0] for p in pairs])
    b = np.concatenate([p[1] for p in pairs])
    n = int(labels.max()) + 1
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    _, merged = connected_components(graph, directed=False)
    return merged[labels]


def largest_copy(references: np.ndarray, *, tile: bool = False, exemplar_wrap: tuple[int, int] | None = None) -> float:
    """The fraction of the output covered by the largest piece copied whole from the photo
    (:func:`piece_labels`).

    1 for a plain copy of the photo; for synthesis, a few per cent at most: a large value means
    that part of the photo is pasted as it is, and a viewer who knows the photo sees it.
    """
    labels = piece_labels(references, tile=tile, exemplar_wrap=exemplar_wrap)
    return float(np.bincount(labels.ravel()).max() / labels.size)


def border_distance(
    references: np.ndarray, *, tile: bool = False, exemplar_wrap: tuple[int, int] | None = None
) -> np.ndarray:
    """``(H, W)`` float: each output pixel's distance (px, city block) to the nearest pixel on
    a border between copied pieces (:func:`seam_mask`); ``inf`` everywhere for one piece."""
    from scipy import ndimage

    border = seam_mask(references, tile=tile, exemplar_wrap=exemplar_wrap)
    if not border.any():
        return np.full(border.shape, np.inf)
    if tile:  # on a torus: the distance within a copy of the output surrounded by itself
        h, w = border.shape
        tiled = np.tile(border, (3, 3))
        return ndimage.distance_transform_cdt(~tiled, metric="taxicab")[h : 2 * h, w : 2 * w].astype(np.float64)
    return ndimage.distance_transform_cdt(~border, metric="taxicab").astype(np.float64)


def border_step_ratio(
    image: np.ndarray,
    references: np.ndarray,
    *,
    tile: bool = False,
    exemplar_wrap: tuple[int, int] | None = None,
) -> float:
    """Mean step between neighbours across a border between copied pieces, over the mean step
    between neighbours inside a piece (both directions pooled; the step is the norm of the
    difference over the image's channels).

    1 means the borders are invisible in ``image`` (a photo has 1 by definition); 1.5 and more
    shows them as cliffs or lines, which a cut and blend between pieces (mazzolini2012 §3.2)
    should prevent. ``nan`` when the map has one piece (no border) or no inside.

    Parameters
    ----------
    image : ndarray
        The texture or any map aligned with ``references`` (height, normal, AO, ...).
    references : ndarray of int, shape (H, W, 2)
        The reference map.
    tile, exemplar_wrap
        As :func:`piece_borders`.
    """
    img = as_unit_image(image)
    if img.shape[:2] != np.shape(references)[:2]:
        raise InvalidInputError(
            f"image: {img.shape[1]}x{img.shape[0]}, the reference map is "
            f"{np.shape(references)[1]}x{np.shape(references)[0]}"
        )
    borders = piece_borders(references, tile=tile, exemplar_wrap=exemplar_wrap)
    across, inside = [], []
    for axis, cut in zip((0, 1), borders):
        diff = (np.roll(img, -1, axis) - img) if tile else np.diff(img, axis=axis)
        step = np.linalg.norm(diff, axis=-1)
        across.append(step[cut])
        inside.append(step[~cut])
    on, off = np.concatenate(across), np.concatenate(inside)
    if on.size == 0 or off.size == 0:
        return float("nan")
    return float(on.mean() / max(off.mean(), 1e-12))
