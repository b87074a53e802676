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
        while v < 0:
            v += n
        while v >= n:
            v -= n
        return v
    if v < 0:
        return 0
    if v >= n:
        return n - 1
    return v


#: offsets (ref - position) are encoded as one int64: (dy + BIAS) * 2 * BIAS + (dx + BIAS)
OFFSET_BIAS = 1 << 20


@nb.njit(inline="always")
def offset_code(ey, ex, y, x):
    """Code of the offset from output pixel (y, x) to exemplar pixel (ey, ex)."""
    return (np.int64(ey - y) + OFFSET_BIAS) * (2 * OFFSET_BIAS) + (ex - x + OFFSET_BIAS)


@nb.njit(parallel=True, cache=True, fastmath=True)
def m_step(refs, ex_feat, ex_y, ex_x, ex_h, ex_w, proj_w, proj_mean, appearance, ksets,
           penalty, kset_cost, stride, oy, ox, tile, forbid, match):  # pragma: no cover - compiled
    """M-step on the sparse grid ``(oy + i * stride, ox + j * stride)``.

    For each grid pixel, the output neighbourhood (resolved references) is projected into
    appearance space (``proj_w[dy, dx, c, d]``, ``proj_mean[dy, dx, c]``) and compared with the candidates of k-coherence search: the forward-shifted
    sources of its 3x3 neighbours and their k-coherence sets (laitoch2018 eq. 3.4). The cost adds
    the occurrence ``penalty`` of the candidate and ``kset_cost`` for non-coherent candidates.
    Candidates whose offset (reference - position) equals ``forbid[y, x]`` are skipped (copy-size
    control, see ``solver._limit_copies``). ``match`` receives the best exemplar index at grid pixels (others are left untouched).
    """
    H, W = refs.shape
    S, _, C, D = proj_w.shape
    r = S // 2
    K = ksets.shape[1]
    ny = (H - oy + stride - 1) // stride
    for iy in nb.prange(ny):
        y = oy + iy * stride
        q = np.empty(D, np.float32)
        seen = np.empty(9, np.int32)
        for x in range(ox, W, stride):
            # fast path: a neighbourhood copied whole from the exemplar projects exactly onto the
            # exemplar's own appearance vector, no need to recompute it
            e0 = refs[y, x]
            cy0 = ex_y[e0]
            cx0 = ex_x[e0]
            whole = True
            for dy in range(-r, r + 1):
                if not whole:
                    break
                yy = y + dy
                if not tile and (yy < 0 or yy >= H):
                    whole = False
                    break
                yy = _wrap_or_clamp(yy, H, tile)
                for dx in range(-r, r + 1):
                    xx = x + dx
                    if not tile and (xx < 0 or xx >= W):
                        whole = False
                        break
                    xx = _wrap_or_clamp(xx, W, tile)
                    e = refs[yy, xx]
                    if ex_y[e] != cy0 + dy or ex_x[e] != cx0 + dx:
                        whole = False
                        break
            if whole:
                for d in range(D):
                    q[d] = appearance[e0, d]
            else:
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
                                q[d] += proj_w[dy + r, dx + r, c, d] * v
            best = refs[y, x]
            best_cost = np.inf
            n_seen = 0
            fb = forbid[y, x]
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
                    ey = ex_y[e] - dy
                    ex = ex_x[e] - dx
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
                    if fb >= 0 and offset_code(ey, ex, y, x) == fb:
                        continue
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
                        if fb >= 0 and offset_code(ex_y[v2], ex_x[v2], y, x) == fb:
                            continue
                        for d in range(D):
                            diff = appearance[v2, d] - q[d]
                            cost += diff * diff
                        if cost < best_cost:
                            best_cost = cost
                            best = v2
            match[y, x] = best


@nb.njit(inline="always")
def first_on_grid(y, radius, o, stride, n, tile):
    """First offset d >= -radius with (y + d - o) divisible by ``stride`` (on the torus when
    ``n`` is a multiple of it), or -radius when the grid is irregular."""
    if tile and n % stride != 0:
        return -radius
    return -radius + (o - (y - radius)) % stride


@nb.njit(parallel=True, cache=True, fastmath=True)
def e_step(match, refs, ex_feat, ex_y, ex_x, ex_h, ex_w, radius, stride, oy, ox, tile, sigma,
           forbid, out):  # pragma: no cover - compiled
    """E-step (laitoch2018 eq. 3.5, Han et al. 2006): every output pixel collects the
    forward-shifted references voted by the matched neighbourhoods that cover it (Gaussian
    weights by distance to the neighbourhood centre) and takes the reference with the largest
    total weight; among equally supported references, the one whose features are closest to the
    weighted average of all votes (the least-squares value of the original E-step). Choosing the
    best-supported vote instead of the nearest-to-average one keeps neighbouring pixels on the
    same exemplar patch, so patches stay whole and seams stay thin. Votes whose offset equals
    ``forbid[y, x]`` are ignored. Pixels with no valid vote keep their reference.
    """
    H, W = refs.shape
    C = ex_feat.shape[1]
    side = 2 * radius + 1
    nmax = side * side
    inv2s2 = 0.5 / (sigma * sigma)
    wtab = np.empty((side, side), np.float32)
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            wtab[dy + radius, dx + radius] = np.exp(-(dy * dy + dx * dx) * inv2s2)
    # neighbourhood centres lie on a grid of step ``stride``: visit only those, unless a wrap
    # with a size that is not a multiple of the stride breaks the regularity
    y_step = stride if (not tile or H % stride == 0) else 1
    x_step = stride if (not tile or W % stride == 0) else 1
    for y in nb.prange(H):
        votes = np.empty(nmax, np.int32)
        vw = np.empty(nmax, np.float32)
        uniq = np.empty(nmax, np.int32)
        usup = np.empty(nmax, np.float32)
        avg = np.empty(C, np.float32)
        for x in range(W):
            nv = 0
            nu = 0
            fb = forbid[y, x]
            for dy in range(first_on_grid(y, radius, oy, stride, H, tile), radius + 1, y_step):
                yy = y + dy
                if tile:
                    yy = _wrap_or_clamp(yy, H, True)
                elif yy < 0 or yy >= H:
                    continue
                if y_step == 1 and (yy < oy or (yy - oy) % stride != 0):
                    continue
                for dx in range(first_on_grid(x, radius, ox, stride, W, tile), radius + 1, x_step):
                    xx = x + dx
                    if tile:
                        xx = _wrap_or_clamp(xx, W, True)
                    elif xx < 0 or xx >= W:
                        continue
                    if x_step == 1 and (xx < ox or (xx - ox) % stride != 0):
                        continue
                    m = match[yy, xx]
                    if m < 0:
                        continue
                    ey = ex_y[m] - dy
                    ex = ex_x[m] - dx
                    if ey < 0 or ey >= ex_h or ex < 0 or ex >= ex_w:
                        continue
                    v = ey * ex_w + ex
                    if fb >= 0 and offset_code(ey, ex, y, x) == fb:
                        continue
                    wgt = wtab[dy + radius, dx + radius]
                    votes[nv] = v
                    vw[nv] = wgt
                    nv += 1
                    found = False
                    for t in range(nu):
                        if uniq[t] == v:
                            usup[t] += wgt
                            found = True
                            break
                    if not found:
                        uniq[nu] = v
                        usup[nu] = wgt
                        nu += 1
            if nv == 0:
                out[y, x] = refs[y, x]
                continue
            top = 0
            n_top = 1
            for t in range(1, nu):
                if usup[t] > usup[top] + 1e-6:
                    top = t
                    n_top = 1
                elif usup[t] > usup[top] - 1e-6:
                    n_top += 1
            if n_top == 1:
                out[y, x] = uniq[top]
                continue
            # tie: the least-squares choice among the best-supported references
            wsum = 0.0
            for c in range(C):
                avg[c] = 0.0
            for t in range(nv):
                wsum += vw[t]
                for c in range(C):
                    avg[c] += vw[t] * ex_feat[votes[t], c]
            for c in range(C):
                avg[c] /= wsum
            best = uniq[top]
            best_cost = np.inf
            for t in range(nu):
                if usup[t] < usup[top] - 1e-6:
                    continue
                v = uniq[t]
                cost = 0.0
                for c in range(C):
                    diff = ex_feat[v, c] - avg[c]
                    cost += diff * diff
                if cost < best_cost:
                    best_cost = cost
                    best = v
            out[y, x] = best


@nb.njit(cache=True)
def label_offset_regions(refs, ex_y, ex_x, labels):  # pragma: no cover - compiled
    """Label the 4-connected regions of constant offset (reference - position), i.e. the pieces
    copied verbatim from the exemplar. Fills ``labels`` and returns each region's pixel count."""
    H, W = refs.shape
    for y in range(H):
        for x in range(W):
            labels[y, x] = -1
    stack = np.empty(H * W, np.int32)
    sizes = np.empty(H * W, np.int32)
    n = 0
    for y0 in range(H):
        for x0 in range(W):
            if labels[y0, x0] >= 0:
                continue
            e0 = refs[y0, x0]
            code = offset_code(ex_y[e0], ex_x[e0], y0, x0)
            labels[y0, x0] = n
            stack[0] = y0 * W + x0
            top = 1
            count = 0
            while top > 0:
                top -= 1
                p = stack[top]
                py = p // W
                px = p - py * W
                count += 1
                for k in range(4):
                    qy = py + (k == 0) - (k == 1)
                    qx = px + (k == 2) - (k == 3)
                    if qy < 0 or qy >= H or qx < 0 or qx >= W or labels[qy, qx] >= 0:
                        continue
                    e1 = refs[qy, qx]
                    if offset_code(ex_y[e1], ex_x[e1], qy, qx) == code:
                        labels[qy, qx] = n
                        stack[top] = qy * W + qx
                        top += 1
            sizes[n] = count
            n += 1
    return sizes[:n].copy()


@nb.njit(parallel=True, cache=True)
def upsample_state(refs, forbid, coarse_y, coarse_x, fine_h, fine_w, out_refs,
                   out_forbid):  # pragma: no cover - compiled
    """Exact reference up-sampling (laitoch2018 §3.3.2): output pixel (y, x) takes the child
    (2v + y % 2, 2u + x % 2) of the exemplar reference (v, u) of its parent (y // 2, x // 2).
    Forbidden offsets (copy-size control) double with the resolution."""
    H, W = out_refs.shape
    two_b = 2 * OFFSET_BIAS
    for y in nb.prange(H):
        py = y // 2
        for x in range(W):
            px = x // 2
            e = refs[py, px]
            fy = 2 * coarse_y[e] + (y & 1)
            fx = 2 * coarse_x[e] + (x & 1)
            if fy >= fine_h:
                fy = fine_h - 1
            if fx >= fine_w:
                fx = fine_w - 1
            out_refs[y, x] = fy * fine_w + fx
            code = forbid[py, px]
            if code < 0:
                out_forbid[y, x] = -1
            else:
                dy = code // two_b - OFFSET_BIAS
                dx = code - (code // two_b) * two_b - OFFSET_BIAS
                out_forbid[y, x] = (2 * dy + OFFSET_BIAS) * two_b + (2 * dx + OFFSET_BIAS)
