"""Pictures of label maps for people: the photo tinted by label with outlined regions, and
contact sheets of mask images (wang2003 Fig. 4)."""

from __future__ import annotations

import numpy as np

from barkgen._shared.checks import check_image
from barkgen.labels.regions import to_codes


def label_colours(n_labels: int) -> np.ndarray:
    """``(n, 3)`` uint8 distinct colours, hues a golden angle apart."""
    import cv2

    hue = (np.arange(n_labels) * 0.618034 % 1.0 * 180).astype(np.uint8)
    hsv = np.stack([hue, np.full(n_labels, 210, np.uint8), np.full(n_labels, 255, np.uint8)], -1)
    return cv2.cvtColor(hsv[None], cv2.COLOR_HSV2RGB)[0]


def label_colour_map(label_map: np.ndarray, values: np.ndarray | None = None) -> np.ndarray:
    """Each label of ``label_map`` in its colour, the colours of :func:`label_preview`.

    Parameters
    ----------
    label_map : ndarray, shape (h, w)
        A grey label map.
    values : ndarray, optional
        The grey values of all labels (e.g. of the input label map, so that a synthesized map
        missing a label keeps the same colours). Default: the map's own values.

    Returns
    -------
    ndarray of uint8, shape (h, w, 3)
        RGB colours, hues a golden angle apart.
    """
    codes, own = to_codes(label_map)
    if values is None:
        return label_colours(own.size)[codes]
    values = np.asarray(values)
    return label_colours(values.size)[np.searchsorted(values, own)[codes]]


def label_preview(image: np.ndarray, label_map: np.ndarray, *, alpha: float = 0.4) -> np.ndarray:
    """The photo with each label tinted and the region outlines in white, beside the plain photo.

    Parameters
    ----------
    image : ndarray, shape (h, w) or (h, w, C)
        The photo: uint8, uint16 or float in [0, 1].
    label_map : ndarray, shape (h, w)
        Its label map.
    alpha : float, default 0.4
        Strength of the tint.

    Returns
    -------
    ndarray of uint8, shape (h, 2 * w + 4, 3)
        Plain photo, a 4 px white gap, the tinted photo.

    References
    ----------
    .. [1] wang2003, Fig. 4 (feature masks shown on the photo).
    """
    rgb = (check_image(image) * 255.0 + 0.5).astype(np.uint8)
    codes, _ = to_codes(label_map)
    colours = label_colours(int(codes.max()) + 1).astype(np.float32)
    tinted = (1 - alpha) * rgb.astype(np.float32) + alpha * colours[codes]
    edge = np.zeros(codes.shape, bool)
    edge[1:, :] |= codes[1:, :] != codes[:-1, :]
    edge[:, 1:] |= codes[:, 1:] != codes[:, :-1]
    tinted[edge] = 255.0
    gap = np.full((rgb.shape[0], 4, 3), 255, np.uint8)
    return np.concatenate([rgb, gap, tinted.astype(np.uint8)], axis=1)


#: a tile of a contact sheet is at most this many times as tall as it is wide
MAX_TILE_ASPECT = 4


def contact_sheet(
    tiles: list[np.ndarray], captions: list[str] | None = None, *, columns: int = 5, tile_size: int = 160
) -> np.ndarray:
    """A grid of images with optional captions, as one image.

    Parameters
    ----------
    tiles : list of ndarray
        Grey ``(h, w)`` or RGB ``(h, w, 3)`` uint8 images of any size, each scaled to
        ``tile_size`` px wide (narrower and centred when that would make it more than
        :data:`MAX_TILE_ASPECT` times as tall).
    captions : list of str, optional
        One caption per tile, written under it.
    columns : int, default 5
        Tiles per row.
    tile_size : int, default 160
        Width of every tile in the sheet, in pixels.

    Returns
    -------
    ndarray of uint8, shape (H, W, 3)
        The sheet on a white background.

    Examples
    --------
    >>> import numpy as np
    >>> contact_sheet([np.zeros((10, 10), np.uint8)] * 3, columns=2, tile_size=20).shape
    (84, 52, 3)
    """
    import cv2

    cells = []
    for i, t in enumerate(tiles):
        t = np.asarray(t)
        if t.ndim == 2:
            t = np.repeat(t[:, :, None], 3, axis=2)
        # fitted into a box tile_size wide and MAX_TILE_ASPECT times as tall: a thin strip
        # (1x100000) stays a thin picture, not an image of millions of rows
        s = min(tile_size / t.shape[1], MAX_TILE_ASPECT * tile_size / t.shape[0])
        size = (max(1, round(t.shape[1] * s)), max(1, round(t.shape[0] * s)))
        t = cv2.resize(t, size, interpolation=cv2.INTER_AREA)
        cell = np.full((t.shape[0] + 22, tile_size + 6, 3), 255, np.uint8)
        x0 = 3 + (tile_size - t.shape[1]) // 2
        cell[3 : 3 + t.shape[0], x0 : x0 + t.shape[1]] = t
        if captions:
            cv2.putText(
                cell, captions[i], (4, cell.shape[0] - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA
            )
        cells.append(cell)
    blank_width = cells[0].shape[1]
    rows = []
    for r in range(0, len(cells), columns):
        row = cells[r : r + columns]
        height = max(c.shape[0] for c in row)
        row = [np.pad(c, ((0, height - c.shape[0]), (0, 0), (0, 0)), constant_values=255) for c in row]
        row += [np.full((height, blank_width, 3), 255, np.uint8)] * (columns - len(row))
        rows.append(np.concatenate(row, axis=1))
    return np.concatenate(rows, axis=0)
