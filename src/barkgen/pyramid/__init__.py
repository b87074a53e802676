"""Gaussian pyramids of exemplars and the level sizes of outputs.

Level 0 is the finest (full resolution); level ``l`` has ``ceil(size / 2**l)`` pixels per side.
The same rule gives the output's level sizes, so a reference ``(y, x)`` at level ``l + 1`` maps
exactly to the four children ``(2y + dy, 2x + dx)`` at level ``l`` (laitoch2018 §3.3.2, exact
reference down/upsampling).
"""

from __future__ import annotations

import math

import numpy as np


def level_shape(shape: tuple[int, int], level: int) -> tuple[int, int]:
    """Shape of pyramid level ``level`` of an image of ``shape`` (ceil halving)."""
    h, w = shape
    f = 1 << level
    return (-(-h // f), -(-w // f))


def count_levels(
    exemplar_shape: tuple[int, int],
    output_shape: tuple[int, int],
    coarsest_exemplar: int = 32,
    coarsest_output: int = 16,
) -> int:
    """Number of levels so that the coarsest exemplar keeps >= ``coarsest_exemplar`` px on its
    short side and the coarsest output >= ``coarsest_output`` px."""
    ex = min(exemplar_shape)
    out = min(output_shape)
    n_ex = int(math.floor(math.log2(max(ex, 1) / coarsest_exemplar))) + 1 if ex >= coarsest_exemplar else 1
    n_out = int(math.floor(math.log2(max(out, 1) / coarsest_output))) + 1 if out >= coarsest_output else 1
    return max(1, min(n_ex, n_out))


#: rows or columns of wrapped padding before a pyrDown of an image that tiles (even, so the
#: subsampling grid stays on the image's own pixels; 4 >= the 5-tap kernel's reach)
_WRAP_PAD = 4


def _pyr_down(image: np.ndarray, wrap: tuple[bool, bool] = (False, False)) -> np.ndarray:
    import cv2

    h, w = image.shape[:2]
    py, px = (_WRAP_PAD if wrap[0] else 0), (_WRAP_PAD if wrap[1] else 0)
    if py or px:
        image = np.pad(image, ((py, py), (px, px), (0, 0)), mode="wrap")
    dst = ((w + 2 * px + 1) // 2, (h + 2 * py + 1) // 2)
    chans = [
        cv2.pyrDown(np.ascontiguousarray(image[:, :, c]), dstsize=dst, borderType=cv2.BORDER_REFLECT_101)
        for c in range(image.shape[2])
    ]
    out = np.stack(chans, axis=-1)
    return np.ascontiguousarray(out[py // 2 : py // 2 + (h + 1) // 2, px // 2 : px // 2 + (w + 1) // 2])


def gaussian_pyramid(image: np.ndarray, n_levels: int, wrap: tuple[bool, bool] = (False, False)) -> list[np.ndarray]:
    """Gaussian pyramid of an ``(H, W, C)`` float32 image, finest level first.

    Each level is blurred with the 5-tap binomial kernel and subsampled by two; level sizes follow
    :func:`level_shape`. ``wrap`` ``(rows, columns)``: the image tiles itself along that axis, so
    the blur runs round its edges (elsewhere they are reflected).
    """
    image = np.ascontiguousarray(image, dtype=np.float32)
    levels = [image]
    for _ in range(1, n_levels):
        levels.append(_pyr_down(levels[-1], wrap))
    return levels
