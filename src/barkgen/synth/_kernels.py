"""Numba kernels of the discrete solver (mazzolini2012 §4.1.2, laitoch2018 §3.3.5).

All kernels are ``parallel`` over output rows and write only their own rows, so results never
depend on thread timing. Output state is an image of references: flat exemplar indices
``y * ex_w + x`` at the current pyramid level.
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(inline="always")
def _wrap_or_clamp(v, n, tile):
    if tile:
        v = v % n
        if v < 0:
            v += n
        return v
    if v < 0:
        return 0
    if v >= n:
        return n - 1
    return v


@nb.njit(parallel=True, cache=True, fastmath=True)
def m_step(refs, ex_feat, ex_h, ex_w, proj_w, proj_mean, appearance, ksets, penalty,
           kset_cost, stride, oy, ox, tile, match):  # pragma: no cover - compiled
    """M-step on the sparse grid ``(oy + i * stride, ox + j * stride)``.

    For each grid pixel, the output neighbourhood (resolved references) is projected into
    appearance space and compared with the candidates of k-coherence search: the forward-shifted
    sources of its 3x3 neighbours and their k-coherence sets (laitoch2018 eq. 3.4). The cost adds
    the occurrence ``penalty`` of the candidate and ``kset_cost`` for non-coherent candidates.
    ``match`` receives the best exemplar index at grid pixels (others are left untouched).
    """
    H, W = refs.shape
    D, S, _, C = proj_w.shape
    r = S // 2
    K = ksets.shape[1]
    ny = (H - oy + stride - 1) // stride
    for iy in nb.prange(ny):
        y = oy + iy * stride
        q = np.empty(D, np.float32)
        seen = np.empty(9, np.int32)
        for x in range(ox, W, stride):
            for d in range(D):
                q[d] = 0.0
            for dy in range(-r, r + 1):
                yy = _wrap_or_clamp(y + dy, H, tile)
                for dx in range(-r, r + 1):
                    xx = _wrap_or_clamp(x + dx, W, tile)
                    e = refs[yy, xx]
                    for c in range(C):
                        v = ex_feat[e, c] - proj_mean[dy + r, dx + r, c]
                        for d in range(D):
                            q[d] += proj_w[d, dy + r, dx + r, c] * v
            best = refs[y, x]
            best_cost = np.inf
            n_seen = 0
            for dy in range(-1, 2):
                yy = y + dy
                if not tile and (yy < 0 or yy >= H):
                    continue
                yy = _wrap_or_clamp(yy, H, tile)
                for dx in range(-1, 2):
                    xx = x + dx
                    if not tile and (xx < 0 or xx >= W):
                        continue
                    xx = _wrap_or_clamp(xx, W, tile)
                    e = refs[yy, xx]
                    ey = e // ex_w - dy
                    ex = e - (e // ex_w) * ex_w - dx
                    if ey < 0 or ey >= ex_h or ex < 0 or ex >= ex_w:
                        continue
                    u = ey * ex_w + ex
                    dup = False
                    for t in range(n_seen):
                        if seen[t] == u:
                            dup = True
                            break
                    if dup:
                        continue
                    seen[n_seen] = u
                    n_seen += 1
                    cost = penalty[u]
                    for d in range(D):
                        diff = appearance[u, d] - q[d]
                        cost += diff * diff
                    if cost < best_cost:
                        best_cost = cost
                        best = u
                    for t in range(K):
                        v2 = ksets[u, t]
                        cost = penalty[v2] + kset_cost
                        if cost >= best_cost:
                            continue
                        for d in range(D):
                            diff = appearance[v2, d] - q[d]
                            cost += diff * diff
                        if cost < best_cost:
                            best_cost = cost
                            best = v2
            match[y, x] = best


@nb.njit(parallel=True, cache=True, fastmath=True)
def e_step(match, refs, ex_feat, ex_h, ex_w, radius, stride, oy, ox, tile, sigma,
           out):  # pragma: no cover - compiled
    """E-step (laitoch2018 eq. 3.5, Han et al. 2006): every output pixel collects the
    forward-shifted references voted by the matched neighbourhoods that cover it (Gaussian
    weights by distance to the neighbourhood centre) and takes the reference with the largest
    total weight; among equally supported references, the one whose features are closest to the
    weighted average of all votes (the least-squares value of the original E-step). Choosing the
    best-supported vote instead of the nearest-to-average one keeps neighbouring pixels on the
    same exemplar patch, so patches stay whole and seams stay thin. Pixels with no valid vote
    keep their reference.
    """
    H, W = refs.shape
    C = ex_feat.shape[1]
    nmax = (2 * radius + 1) * (2 * radius + 1)
    inv2s2 = 0.5 / (sigma * sigma)
    for y in nb.prange(H):
        votes = np.empty(nmax, np.int32)
        vw = np.empty(nmax, np.float32)
        avg = np.empty(C, np.float32)
        for x in range(W):
            nv = 0
            wsum = 0.0
            for c in range(C):
                avg[c] = 0.0
            for dy in range(-radius, radius + 1):
                yy = y + dy
                if tile:
                    yy = _wrap_or_clamp(yy, H, True)
                elif yy < 0 or yy >= H:
                    continue
                if (yy - oy) % stride != 0 or yy < oy:
                    continue
                for dx in range(-radius, radius + 1):
                    xx = x + dx
                    if tile:
                        xx = _wrap_or_clamp(xx, W, True)
                    elif xx < 0 or xx >= W:
                        continue
                    if (xx - ox) % stride != 0 or xx < ox:
                        continue
                    m = match[yy, xx]
                    if m < 0:
                        continue
                    ey = m // ex_w - dy
                    ex = m - (m // ex_w) * ex_w - dx
                    if ey < 0 or ey >= ex_h or ex < 0 or ex >= ex_w:
                        continue
                    v = ey * ex_w + ex
                    wgt = np.exp(-(dy * dy + dx * dx) * inv2s2)
                    votes[nv] = v
                    vw[nv] = wgt
                    nv += 1
                    wsum += wgt
                    for c in range(C):
                        avg[c] += wgt * ex_feat[v, c]
            if nv == 0:
                out[y, x] = refs[y, x]
                continue
            for c in range(C):
                avg[c] /= wsum
            best = votes[0]
            best_support = -1.0
            best_cost = np.inf
            for t in range(nv):
                v = votes[t]
                support = 0.0
                for t2 in range(nv):
                    if votes[t2] == v:
                        support += vw[t2]
                if support < best_support - 1e-6:
                    continue
                cost = 0.0
                for c in range(C):
                    diff = ex_feat[v, c] - avg[c]
                    cost += diff * diff
                if support > best_support + 1e-6 or cost < best_cost:
                    best_support = support
                    best_cost = cost
                    best = v
            out[y, x] = best


@nb.njit(parallel=True, cache=True)
def resolve(refs, table, out):  # pragma: no cover - compiled
    """``out[y, x, :] = table[refs[y, x], :]`` (turn references into pixel values)."""
    H, W = refs.shape
    C = table.shape[1]
    for y in nb.prange(H):
        for x in range(W):
            e = refs[y, x]
            for c in range(C):
                out[y, x, c] = table[e, c]
