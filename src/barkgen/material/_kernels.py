"""Numba kernels of the material maps."""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True)
def _sample(height: np.ndarray, y: int, x: int, wrap_y: bool, wrap_x: bool) -> float:
    h, w = height.shape
    # round the torus along a wrapping axis (steps are short: a compare beats a modulo), else
    # clamped to the border
    if wrap_y:
        while y < 0:
            y += h
        while y >= h:
            y -= h
    else:
        y = min(max(y, 0), h - 1)
    if wrap_x:
        while x < 0:
            x += w
        while x >= w:
            x -= w
    else:
        x = min(max(x, 0), w - 1)
    return height[y, x]


@njit(parallel=True, cache=True)
def horizon_occlusion(
    height: np.ndarray,
    directions: np.ndarray,
    radius: int,
    wrap_y: bool,
    wrap_x: bool,
    out: np.ndarray,
    row_start: int,
    row_stop: int,
) -> None:
    """Rows ``row_start:row_stop`` of the horizon-based ambient occlusion of a height field
    (heights in pixels), into ``out``.

    For each pixel and each unit ``direction`` ``(dy, dx)``, the horizon is the steepest
    elevation ``(h(p + t d) - h(p)) / t`` for ``t = 1..radius``; the pixel's visibility in that
    direction is ``1 - sin(horizon angle)``, averaged over the directions (Bavoil et al. 2008's
    horizon-based AO, on a height field). The height wraps along the axes ``wrap_y`` /
    ``wrap_x`` say, and is clamped at the other borders.
    """
    h, w = height.shape
    n_dir = directions.shape[0]
    # the pixel steps of every direction, rounded once (not once per pixel)
    step_y = np.empty((n_dir, radius), np.int64)
    step_x = np.empty((n_dir, radius), np.int64)
    for d in range(n_dir):
        for t in range(1, radius + 1):
            step_y[d, t - 1] = int(round(directions[d, 0] * t))
            step_x[d, t - 1] = int(round(directions[d, 1] * t))
    for y in prange(row_start, row_stop):
        for x in range(w):
            h0 = height[y, x]
            total = 0.0
            for d in range(n_dir):
                best = 0.0
                for t in range(1, radius + 1):
                    yy = y + step_y[d, t - 1]
                    xx = x + step_x[d, t - 1]
                    slope = (_sample(height, yy, xx, wrap_y, wrap_x) - h0) / t
                    if slope > best:
                        best = slope
                total += best / np.sqrt(1.0 + best * best)
            out[y, x] = 1.0 - total / n_dir


@njit(parallel=True, cache=True)
def neighbourhood_distance(padded: np.ndarray, reference: np.ndarray, offsets: np.ndarray, pad: int) -> np.ndarray:
    """RMS difference of every pixel's neighbourhood from ``reference`` (wang2003 §3.3's L2
    neighbourhood distance, per neighbour).

    ``padded``: the image with ``pad`` px of border (wrapped or mirrored by the caller);
    ``offsets``: the neighbourhood's ``(dy, dx)``; ``reference``: the edited pixel's values at
    those offsets. Returns ``(h, w)`` float32 for the unpadded image."""
    rows = padded.shape[0] - 2 * pad
    cols = padded.shape[1] - 2 * pad
    n = offsets.shape[0]
    out = np.empty((rows, cols), np.float32)
    for y in prange(rows):
        for x in range(cols):
            total = np.float32(0.0)
            for k in range(n):
                diff = padded[pad + y + offsets[k, 0], pad + x + offsets[k, 1]] - reference[k]
                total += diff * diff
            out[y, x] = np.sqrt(total / np.float32(n))
    return out
