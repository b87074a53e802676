"""Numba kernels of the neighbour-search stage (compiled lazily, cached on disk)."""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit
def _far_from_kept(out, i, got, c, width, radius):
    """True when exemplar pixel ``c`` lies more than ``radius`` (Chebyshev) from each of the
    ``got`` entries already kept in ``out[i]``."""
    cy = c // width
    cx = c - cy * width
    for t in range(got):
        o = out[i, t]
        oy = o // width
        ox = o - oy * width
        if abs(cy - oy) <= radius and abs(cx - ox) <= radius:
            return False
    return True


@nb.njit
def _pad_row(out, i, got, k):
    """Fill the unfilled tail of ``out[i]`` with its last kept entry (or ``i`` itself)."""
    fill = out[i, got - 1] if got > 0 else i
    for t in range(got, k):
        out[i, t] = fill


@nb.njit
def _keep_nearest_spread(out, i, cand, dist, m, width, k, radius):
    """Fill ``out[i]`` with the nearest of the ``m`` candidates ``cand`` (squared distances
    ``dist``, consumed) that lie more than ``radius`` from each one already kept; pad the rest."""
    got = 0
    for _ in range(m):
        jbest = -1
        dbest = np.inf
        for j in range(m):
            if dist[j] < dbest:
                dbest = dist[j]
                jbest = j
        if jbest < 0:
            break
        dist[jbest] = np.inf
        c = cand[jbest]
        if _far_from_kept(out, i, got, c, width, radius):
            out[i, got] = c
            got += 1
            if got == k:
                break
    _pad_row(out, i, got, k)


@nb.njit(parallel=True, cache=True)
def select_spread_neighbours(knn, width, k, radius):  # pragma: no cover - compiled
    """Keep, per row of ``knn`` (nearest first), the first ``k`` exemplar pixels that lie more than
    ``radius`` (Chebyshev) from the query pixel and from each already kept one.

    Rows left short are padded with their last kept entry (or the query itself).
    """
    n, kk = knn.shape
    out = np.empty((n, k), np.int32)
    for i in nb.prange(n):
        qy = i // width
        qx = i - qy * width
        m = 0
        for j in range(kk):
            c = knn[i, j]
            if c < 0:
                continue
            cy = c // width
            cx = c - cy * width
            if abs(cy - qy) <= radius and abs(cx - qx) <= radius:
                continue
            if _far_from_kept(out, i, m, c, width, radius):
                out[i, m] = c
                m += 1
                if m == k:
                    break
        _pad_row(out, i, m, k)
    return out


@nb.njit(parallel=True, cache=True, fastmath=True)
def refine_child_sets(
    parent_sets, coarse_w, coarse_h, features, height, width, k, radius, out, row_start, row_stop
):  # pragma: no cover - compiled
    """Rows ``row_start:row_stop`` of the k-coherence sets (into ``out``, ``(height * width, k)``)
    of a pyramid level from those of the next coarser level.

    For each pixel, every entry of its parent's k-coherence set proposes its child with the same
    sub-pixel offset; the best of that child and its 3x3 neighbours (by appearance distance) is
    the proposal. Proposals are kept nearest first, spread apart by more than ``radius`` pixels
    (from the pixel and from each other) as in :func:`select_spread_neighbours`.
    """
    kp = parent_sets.shape[1]
    D = features.shape[1]
    for y in nb.prange(row_start, row_stop):
        cand = np.empty(kp, np.int32)
        dist = np.empty(kp, np.float32)
        for x in range(width):
            i = y * width + x
            py = min(y // 2, coarse_h - 1)
            px = min(x // 2, coarse_w - 1)
            p = py * coarse_w + px
            m = 0
            for t in range(kp):
                c = parent_sets[p, t]
                cy = c // coarse_w
                cx = c - cy * coarse_w
                by = 2 * cy + (y & 1)
                bx = 2 * cx + (x & 1)
                ubest = -1
                dbest = np.inf
                for dy in range(-1, 2):
                    yy = by + dy
                    if yy < 0 or yy >= height:
                        continue
                    for dx in range(-1, 2):
                        xx = bx + dx
                        if xx < 0 or xx >= width:
                            continue
                        if abs(yy - y) <= radius and abs(xx - x) <= radius:
                            continue
                        u = yy * width + xx
                        d2 = 0.0
                        for d in range(D):
                            diff = features[u, d] - features[i, d]
                            d2 += diff * diff
                        if d2 < dbest:
                            dbest = d2
                            ubest = u
                if ubest >= 0:
                    cand[m] = ubest
                    dist[m] = dbest
                    m += 1
            _keep_nearest_spread(out, i, cand, dist, m, width, k, radius)


@nb.njit(parallel=True, cache=True, fastmath=True)
def propagate_sets(sets, features, height, width, radius, out, row_start, row_stop):  # pragma: no cover - compiled
    """Rows ``row_start:row_stop`` of one pass of k-coherence propagation (Tong et al. 2002)
    over a level's sets: each pixel takes the best spread ``k`` of its own set and its 8
    neighbours' sets shifted back by the neighbour's offset (a neighbour's match, one step
    over, matches this pixel). Reads ``sets``, writes ``out`` (shaped as ``sets``; the same
    result whatever the thread order)."""
    k = sets.shape[1]
    D = features.shape[1]
    for y in nb.prange(row_start, row_stop):
        cand = np.empty(9 * k, np.int32)
        dist = np.empty(9 * k, np.float32)
        for x in range(width):
            i = y * width + x
            m = 0
            for oy in range(-1, 2):
                ny = y + oy
                if ny < 0 or ny >= height:
                    continue
                for ox in range(-1, 2):
                    nx = x + ox
                    if nx < 0 or nx >= width:
                        continue
                    for t in range(k):
                        c = sets[ny * width + nx, t]
                        cy = c // width - oy
                        cx = c - (c // width) * width - ox
                        if cy < 0 or cy >= height or cx < 0 or cx >= width:
                            continue
                        if abs(cy - y) <= radius and abs(cx - x) <= radius:
                            continue
                        u = cy * width + cx
                        d2 = 0.0
                        for d in range(D):
                            diff = features[u, d] - features[i, d]
                            d2 += diff * diff
                        cand[m] = u
                        dist[m] = d2
                        m += 1
            _keep_nearest_spread(out, i, cand, dist, m, width, k, radius)
