"""Numba kernels of the tree's texel maps: triangles rasterized into the UV atlas."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def rasterize(corners, height, width, triangle, barycentric):
    """Each texel centre of the ``(height, width)`` atlas inside a triangle of ``corners``
    ``(m, 3, 2)`` (column, row in texels) gets its index in ``triangle`` (else -1 as given)
    and its barycentric coordinates; triangles are drawn in order (a later one wins a texel
    two share: deterministic). Returns how many texels were drawn."""
    drawn = 0
    for f in range(corners.shape[0]):
        x0, y0 = corners[f, 0, 0], corners[f, 0, 1]
        x1, y1 = corners[f, 1, 0], corners[f, 1, 1]
        x2, y2 = corners[f, 2, 0], corners[f, 2, 1]
        det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
        if abs(det) < 1e-12:
            continue
        lo_x = max(int(np.floor(min(x0, min(x1, x2)) - 0.5)), 0)
        hi_x = min(int(np.ceil(max(x0, max(x1, x2)) - 0.5)), width - 1)
        lo_y = max(int(np.floor(min(y0, min(y1, y2)) - 0.5)), 0)
        hi_y = min(int(np.ceil(max(y0, max(y1, y2)) - 0.5)), height - 1)
        for y in range(lo_y, hi_y + 1):
            py = y + 0.5
            for x in range(lo_x, hi_x + 1):
                px = x + 0.5
                b0 = ((y1 - y2) * (px - x2) + (x2 - x1) * (py - y2)) / det
                b1 = ((y2 - y0) * (px - x2) + (x0 - x2) * (py - y2)) / det
                b2 = 1.0 - b0 - b1
                if b0 >= -1e-9 and b1 >= -1e-9 and b2 >= -1e-9:
                    triangle[y, x] = f
                    barycentric[y, x, 0] = b0
                    barycentric[y, x, 1] = b1
                    barycentric[y, x, 2] = b2
                    drawn += 1
    return drawn
