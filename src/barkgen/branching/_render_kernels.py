"""Numba kernels of the fragment composition (sibbing2010 §5.3): per-pixel distances to a
fragment's skeleton and the harmonic colour offset of the photometric correction."""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True)
def crack_distance(xs, ys, px, py, pt, ok):
    """Signed distance of the points ``(xs, ys)`` (two float arrays of one 2-D shape) to the
    edge of a crack.

    The crack is the polyline ``(px, py)`` with half-width ``pt`` per vertex (interpolated
    along each segment); only segments whose both ends have ``ok`` count. Returns
    ``distance to the skeleton - local half-width`` as float32 (<= 0 inside the crack);
    +inf where no segment counts.
    """
    h, w = xs.shape
    out = np.full((h, w), np.inf, np.float32)
    n = px.shape[0]
    for s in range(n - 1):
        if not (ok[s] and ok[s + 1]):
            continue
        ax = px[s]
        ay = py[s]
        dx = px[s + 1] - ax
        dy = py[s + 1] - ay
        ll = dx * dx + dy * dy
        ta = pt[s]
        tb = pt[s + 1]
        for i in range(h):
            for j in range(w):
                x = xs[i, j]
                y = ys[i, j]
                u = 0.0
                if ll > 1e-12:
                    u = ((x - ax) * dx + (y - ay) * dy) / ll
                    if u < 0.0:
                        u = 0.0
                    elif u > 1.0:
                        u = 1.0
                ex = ax + u * dx - x
                ey = ay + u * dy - y
                d = np.sqrt(ex * ex + ey * ey) - (ta + u * (tb - ta))
                if d < out[i, j]:
                    out[i, j] = d
    return out


@nb.njit(cache=True)
def harmonic_offset(inside, boundary, tol, max_iter):
    """Harmonic interpolation of a colour offset (Poisson photometric correction, §5.3).

    ``inside`` (h, w) bool marks the unknown pixels; ``boundary`` (h, w, C) float32 holds the
    fixed offsets of every other pixel (the seam difference old - new where the pixel has old
    content, 0 where it has none). Pixels outside the box are not neighbours (Neumann at the
    canvas edge). Solved by successive over-relaxation from the mean of the boundary values
    next to the region; returns the (h, w, C) offset, equal to ``boundary`` outside.
    """
    h, w, c = boundary.shape
    off = boundary.copy()
    ys = np.empty(h * w, np.int64)
    xs = np.empty(h * w, np.int64)
    n = 0
    for i in range(h):
        for j in range(w):
            if inside[i, j]:
                ys[n] = i
                xs[n] = j
                n += 1
    if n == 0:
        return off
    # start from the mean of the fixed values that touch the region
    mean = np.zeros(c, np.float64)
    cnt = 0
    for t in range(n):
        i = ys[t]
        j = xs[t]
        for k in range(4):
            ii = i + (1 if k == 0 else (-1 if k == 1 else 0))
            jj = j + (1 if k == 2 else (-1 if k == 3 else 0))
            if 0 <= ii < h and 0 <= jj < w and not inside[ii, jj]:
                for ch in range(c):
                    mean[ch] += boundary[ii, jj, ch]
                cnt += 1
    for ch in range(c):
        mean[ch] = mean[ch] / cnt if cnt > 0 else 0.0
    for t in range(n):
        for ch in range(c):
            off[ys[t], xs[t], ch] = mean[ch]
    # over-relaxation factor for a region of this size (optimal for a square of side sqrt(n))
    side = max(np.sqrt(n), 2.0)
    omega = 2.0 / (1.0 + np.sin(np.pi / (side + 1.0)))
    for _ in range(max_iter):
        change = 0.0
        for t in range(n):
            i = ys[t]
            j = xs[t]
            for ch in range(c):
                s = 0.0
                m = 0
                if i + 1 < h:
                    s += off[i + 1, j, ch]
                    m += 1
                if i > 0:
                    s += off[i - 1, j, ch]
                    m += 1
                if j + 1 < w:
                    s += off[i, j + 1, ch]
                    m += 1
                if j > 0:
                    s += off[i, j - 1, ch]
                    m += 1
                if m == 0:
                    continue
                delta = omega * (s / m - off[i, j, ch])
                off[i, j, ch] += delta
                if abs(delta) > change:
                    change = abs(delta)
        if change < tol:
            break
    return off
