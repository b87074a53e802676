"""Numba kernels of the discrete solver (mazzolini2012 §4.1.2, laitoch2018 §3.3.5).

All kernels are ``parallel`` over output rows and write only their own rows, so results never
depend on thread timing. Output state is an image of references: flat exemplar indices
``y * ex_w + x`` at the current pyramid level.

Kernels take the level's exemplar grid as one tuple ``exemplar = (ex_y, ex_x, ex_h, ex_w,
wrap_y, wrap_x)``: the row and column of each flat index (division-free decoding), the level's
size, and whether the exemplar tiles along its rows / columns
(:attr:`barkgen.synth._analysis.LevelAnalysis.grid`).

Here are the M- and E-steps, the exact up-sampling and the helpers shared with the kernels of
the wings: the seam kernels (local seam moves, pieces, straight runs, cut bands, expansion
moves) are in :mod:`barkgen.synth.seams._kernels`, texture-by-numbers' (region growing, label
clean-up) in :mod:`barkgen.synth.guides._kernels`.

The small helpers are plain ``@nb.njit`` functions, not inlined at numba's IR level
(``inline="always"``): LLVM inlines them anyway when it optimises the kernel, so the machine code
and the bytes are the same, and the kernels compile in half the time (the quickstart's first run
with an empty cache went from 55 s to 31 s, 2026-12-03).
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit
def _wrap_or_clamp(v, n, wraps):
    """``v`` on an axis of ``n`` pixels: round it when the axis ``wraps``, else clamped."""
    if wraps:
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


@nb.njit
def offset_code(ey, ex, y, x):
    """Code of the offset from output pixel (y, x) to exemplar pixel (ey, ex)."""
    return (np.int64(ey - y) + OFFSET_BIAS) * (2 * OFFSET_BIAS) + (ex - x + OFFSET_BIAS)


@nb.njit
def _reflect(v, n):
    """Index ``v`` reflected into ``[0, n)`` without repeating the edge (OpenCV's
    BORDER_REFLECT_101, as the analysis's filters use), for offsets smaller than ``n``."""
    if v < 0:
        v = -v
    if v >= n:
        v = 2 * n - 2 - v
    return min(max(v, 0), n - 1)


@nb.njit
def _ex_coord(v, n, wrap):
    """Exemplar coordinate ``v`` of a neighbourhood pixel: on the torus when the exemplar tiles
    along this axis (``wrap``), else reflected like the analysis's filters."""
    if wrap:
        if v < 0:
            return v + n
        if v >= n:
            return v - n
        return v
    return _reflect(v, n)


@nb.njit
def _ex_inside(v, n, wrap):
    """Exemplar coordinate ``v`` of a shifted reference: wrapped when the exemplar tiles along
    this axis, else -1 when it falls outside."""
    if v < 0:
        return v + n if wrap else -1
    if v >= n:
        return v - n if wrap else -1
    return v


@nb.njit
def _listed(values, n, v):
    """True when ``v`` is among the first ``n`` entries of ``values``."""
    for t in range(n):
        if values[t] == v:
            return True
    return False


@nb.njit
def _mix(z):
    """splitmix64 finaliser: a well-mixed 64-bit hash of a uint64."""
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@nb.njit
def _shifted_neighbour_source(output, y, x, dy, dx, exemplar):
    """The exemplar pixel that output pixel (y, x) would take to continue the piece its
    neighbour (y + dy, x + dx) was copied from (the neighbour's reference shifted back by
    (dy, dx)); -1 when the neighbour is outside the output (not tiled) or the shifted pixel
    outside the exemplar (which wraps along the axes ``wrap_y`` / ``wrap_x``). ``output =
    (refs, tile)``: the output's references and whether it wraps round."""
    refs, tile = output
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    H, W = refs.shape
    yy = y + dy
    xx = x + dx
    if not tile and (yy < 0 or yy >= H or xx < 0 or xx >= W):
        return -1
    e = refs[_wrap_or_clamp(yy, H, tile), _wrap_or_clamp(xx, W, tile)]
    cy = _ex_inside(ex_y[e] - dy, ex_h, wrap_y)
    cx = _ex_inside(ex_x[e] - dx, ex_w, wrap_x)
    if cy < 0 or cx < 0:
        return -1
    return cy * ex_w + cx


@nb.njit
def _project_query(output, y, x, exemplar, ex_feat, projection, q, guide):
    """The output neighbourhood of (y, x) (resolved references) projected into appearance space
    into ``q``; returns how many of its pixels have the wrong label (``ex_labels`` of its
    reference against ``target``, counted when ``n_random`` > 0; ``guide``: :func:`m_step`'s).

    Incremental projection: the neighbourhood is compared with the exemplar neighbourhood of its
    centre's reference, whose projection is known (``appearance[e0]``, reflected at the exemplar
    border like the analysis); only the pixels that differ from it are projected (exact, the
    projection is linear). Pieces copied whole cost nothing; a full projection is done when
    most pixels differ."""
    refs, tile = output
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    proj_w, proj_mean, appearance = projection
    _, _, ex_labels, target, _, _, n_random, _ = guide
    H, W = refs.shape
    S, _, C, D = proj_w.shape
    r = S // 2
    e0 = refs[y, x]
    cy0 = ex_y[e0]
    cx0 = ex_x[e0]
    n_diff = 0
    n_wrong = 0
    for dy in range(-r, r + 1):
        yy = _wrap_or_clamp(y + dy, H, tile)
        ey = _ex_coord(cy0 + dy, ex_h, wrap_y)
        for dx in range(-r, r + 1):
            xx = _wrap_or_clamp(x + dx, W, tile)
            if refs[yy, xx] != ey * ex_w + _ex_coord(cx0 + dx, ex_w, wrap_x):
                n_diff += 1
            if n_random > 0 and ex_labels[refs[yy, xx]] != target[yy, xx]:
                n_wrong += 1
    if 2 * n_diff < S * S:
        for d in range(D):
            q[d] = appearance[e0, d]
        if n_diff > 0:
            for dy in range(-r, r + 1):
                yy = _wrap_or_clamp(y + dy, H, tile)
                ey = _ex_coord(cy0 + dy, ex_h, wrap_y)
                for dx in range(-r, r + 1):
                    xx = _wrap_or_clamp(x + dx, W, tile)
                    e = refs[yy, xx]
                    u = ey * ex_w + _ex_coord(cx0 + dx, ex_w, wrap_x)
                    if e == u:
                        continue
                    for c in range(C):
                        v = ex_feat[e, c] - ex_feat[u, c]
                        for d in range(D):
                            q[d] += proj_w[dy + r, dx + r, c, d] * v
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
    return n_wrong


@nb.njit
def _label_candidates(incumbent, y, x, r, output, exemplar, costs, guide, query, fb):
    """Texture-by-numbers' drawn candidates of the M-step at (y, x) (see :func:`m_step`):
    ``n_random`` from the wanted label's exemplar pixels and one aligned on the nearest pixel
    that wants another label. Returns the new ``(best, best_cost)`` from ``incumbent``, the
    ones so far."""
    best, best_cost = incumbent
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    penalty, kset_cost, _ = costs
    _, _, _, target, pool, pool_start, n_random, random_key = guide
    W = target.shape[1]
    for t in range(n_random + 1):
        h = _mix(random_key ^ _mix(np.uint64((y * W + x) * (n_random + 1) + t + 1)))
        if t < n_random:
            lab = target[y, x]
            sy = 0
            sx = 0
        else:
            lab, sy, sx = _nearest_other_label(target, y, x, r, output)
            if lab < 0:
                continue
        p0 = pool_start[lab]
        n_pool = pool_start[lab + 1] - p0
        v2 = pool[p0 + np.int64(h % np.uint64(n_pool))]
        if sy != 0 or sx != 0:
            vy = _ex_inside(ex_y[v2] - sy, ex_h, wrap_y)
            vx = _ex_inside(ex_x[v2] - sx, ex_w, wrap_x)
            if vy < 0 or vx < 0:
                continue
            v2 = vy * ex_w + vx
        best, best_cost = _consider(v2, penalty[v2] + kset_cost, best, best_cost, fb, y, x, ex_y, ex_x, query)
    return best, best_cost


@nb.njit(parallel=True, cache=True, fastmath=True)
def m_step(output, exemplar, ex_feat, projection, ksets, costs, grid, guide, match):  # pragma: no cover - compiled
    """M-step on the sparse grid ``(oy + i * stride, ox + j * stride)`` of the output, ``output =
    (refs, tile)`` (its references, whether it wraps round), ``grid = (stride, oy, ox)``; ``projection = (proj_w, proj_mean, appearance)``, ``costs = (penalty, kset_cost,
    forbid)``, ``guide = (guide_ex, guide_out, ex_labels, target, pool, pool_start, n_random,
    random_key)``.

    For each grid pixel, the output neighbourhood (resolved references) is projected into
    appearance space (``proj_w[dy, dx, c, d]``, ``proj_mean[dy, dx, c]``) and compared with the
    candidates of k-coherence search: the forward-shifted sources of its 3x3 neighbours and
    their k-coherence sets (laitoch2018 eq. 3.4). The cost adds the occurrence ``penalty`` of the
    candidate and ``kset_cost`` for non-coherent candidates. Candidates whose offset
    (reference - position) equals ``forbid[y, x]`` are skipped (copy-size control, see
    :func:`barkgen.synth.seams.pieces.limit_copies`). ``match`` receives the best exemplar index at grid pixels (others
    are left untouched).

    Texture-by-numbers (laitoch2018 eq. 3.2, A : A' :: B : B'): when ``guide_ex`` has columns,
    a candidate also pays the squared distance between its label neighbourhood
    (``guide_ex[u]``, the exemplar's label map in its own appearance space) and the wanted one
    (``guide_out[y, x]``, the target label map projected the same way), and ``n_random`` extra
    candidates per pixel are drawn from the exemplar pixels of the wanted label ``target[y, x]``
    (``pool``, ``pool_start``; a hash of ``random_key`` and the position picks them, independent
    of threads), plus one drawn from the label of the nearest pixel of the neighbourhood that
    wants another label, shifted so that the drawn pixel lands on it: small features get
    candidates that put them where the target wants them. These are tried only where some pixel
    of the neighbourhood has the wrong label (``ex_labels`` of its reference differs from
    ``target``): elsewhere coherent candidates already fit. Unguided synthesis passes zero guide
    columns and ``n_random = 0``.
    """
    refs = output[0]
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    proj_w, proj_mean, appearance = projection
    penalty, kset_cost, forbid = costs
    stride, oy, ox = grid
    guide_ex, guide_out, ex_labels, target, pool, pool_start, n_random, random_key = guide
    H, W = refs.shape
    S, _, C, D = proj_w.shape
    r = S // 2
    K = ksets.shape[1]
    ny = (H - oy + stride - 1) // stride
    for iy in nb.prange(ny):
        y = oy + iy * stride
        q = np.empty(D, np.float32)
        seen = np.empty(9, np.int32)
        query = (appearance, q, guide_ex, guide_out)
        for x in range(ox, W, stride):
            n_wrong = _project_query(output, y, x, exemplar, ex_feat, projection, q, guide)
            best = np.int64(refs[y, x])
            best_cost = np.inf
            n_seen = 0
            fb = forbid[y, x]
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    u = _shifted_neighbour_source(output, y, x, dy, dx, exemplar)
                    if u < 0:
                        continue
                    if _listed(seen, n_seen, u):
                        continue
                    seen[n_seen] = u
                    n_seen += 1
                    if fb >= 0 and offset_code(ex_y[u], ex_x[u], y, x) == fb:
                        continue  # (its k-coherence set goes with it)
                    best, best_cost = _consider(u, penalty[u], best, best_cost, -1, y, x, ex_y, ex_x, query)
                    for t in range(K):
                        v2 = ksets[u, t]
                        best, best_cost = _consider(
                            v2, penalty[v2] + kset_cost, best, best_cost, fb, y, x, ex_y, ex_x, query
                        )
            if n_wrong > 0:
                best, best_cost = _label_candidates(
                    (best, best_cost), y, x, r, output, exemplar, costs, guide, query, fb
                )
            match[y, x] = best


@nb.njit
def _nearest_other_label(target, y, x, radius, output):
    """``(label, dy, dx)`` of a nearest pixel (ring by ring, Chebyshev distance <= ``radius``)
    whose wanted label differs from ``target[y, x]`` (round the output's torus when it tiles,
    ``output = (refs, tile)``); label -1 if there is none."""
    tile = output[1]
    H, W = target.shape
    own = target[y, x]
    for d in range(1, radius + 1):
        for dy in range(-d, d + 1):
            yy = y + dy
            if not tile and (yy < 0 or yy >= H):
                continue
            yy = _wrap_or_clamp(yy, H, tile)
            step = 1 if (dy == -d or dy == d) else 2 * d
            for dx in range(-d, d + 1, step):
                xx = x + dx
                if not tile and (xx < 0 or xx >= W):
                    continue
                lab = target[yy, _wrap_or_clamp(xx, W, tile)]
                if lab != own:
                    return lab, dy, dx
    return -1, 0, 0


@nb.njit
def _consider(v, base, best, best_cost, fb, y, x, ex_y, ex_x, query):
    """M-step candidate ``v`` at cost ``base`` (occurrence penalty, coherence bias) plus its
    distances (:func:`_cost`; ``query = (appearance, q, guide_ex, guide_out)``): returns
    ``(v, cost)`` if it beats ``(best, best_cost)``, else those. A candidate whose offset is the
    forbidden one ``fb`` is never taken."""
    appearance, q, guide_ex, guide_out = query
    if base >= best_cost:
        return best, best_cost
    if fb >= 0 and offset_code(ex_y[v], ex_x[v], y, x) == fb:
        return best, best_cost
    cost = _cost(base, best_cost, appearance, q, guide_ex, guide_out, v, y, x)
    if cost < best_cost:
        return np.int64(v), cost
    return best, best_cost


@nb.njit
def _cost(base, bound, appearance, q, guide_ex, guide_out, u, y, x):
    """``base`` + appearance distance of exemplar pixel ``u`` to the query ``q`` + (guided) the
    label-neighbourhood distance; the label part is skipped once the sum reaches ``bound``."""
    cost = base
    for d in range(q.shape[0]):
        diff = appearance[u, d] - q[d]
        cost += diff * diff
    if cost >= bound:
        return cost
    for d in range(guide_ex.shape[1]):
        diff = guide_ex[u, d] - guide_out[y, x, d]
        cost += diff * diff
    return cost


@nb.njit
def first_on_grid(y, radius, o, stride, n, wraps):
    """First offset d >= -radius with (y + d - o) divisible by ``stride`` on an axis of ``n``
    pixels (on the torus, when it ``wraps``, if ``n`` is a multiple of it), or -radius when the
    grid is irregular."""
    if wraps and n % stride != 0:
        return -radius
    return -radius + (o - (y - radius)) % stride


@nb.njit
def _least_squares_vote(votes, vw, nv, uniq, usup, nu, top, ex_feat, avg):
    """Among the ``nu`` distinct votes ``uniq`` tied for the largest support ``usup[top]``, the
    one whose features are closest to the weighted average of all ``nv`` votes (``votes``,
    weights ``vw``; ``avg`` is scratch): the least-squares value of the original E-step. The
    first when every vote was discounted to zero."""
    C = ex_feat.shape[1]
    wsum = 0.0
    for c in range(C):
        avg[c] = 0.0
    for t in range(nv):
        wsum += vw[t]
        for c in range(C):
            avg[c] += vw[t] * ex_feat[votes[t], c]
    best = uniq[top]
    if wsum <= 0.0:  # only votes of the wrong label, all discounted to zero: the first
        return best
    for c in range(C):
        avg[c] /= wsum
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
    return best


@nb.njit(parallel=True, cache=True, fastmath=True)
def e_step(match, output, exemplar, ex_feat, votes, forbid, labels, out):  # pragma: no cover - compiled
    """E-step (laitoch2018 eq. 3.5, Han et al. 2006): every output pixel collects the
    forward-shifted references voted by the matched neighbourhoods that cover it (Gaussian
    weights by distance to the neighbourhood centre) and takes the reference with the largest
    total weight; among equally supported references, the one whose features are closest to the
    weighted average of all votes (the least-squares value of the original E-step). Choosing the
    best-supported vote instead of the nearest-to-average one keeps neighbouring pixels on the
    same exemplar patch, so patches stay whole and seams stay thin. Votes whose offset equals
    ``forbid[y, x]`` are ignored. Pixels with no valid vote keep their reference.

    Texture-by-numbers: when ``label_discount < 1``, a vote whose exemplar label
    (``ex_labels``) differs from the wanted label ``target[y, x]`` weighs ``label_discount``
    times as much, so labels are kept wherever any vote agrees with them (with 0, wrong votes
    count only when there is no other: then the first one is taken).

    ``output = (refs, tile)``: the output's references and whether it wraps round; ``votes =
    (radius, stride, oy, ox, sigma)``: the matched neighbourhoods' radius and grid, and the
    Gaussian's width; ``labels = (ex_labels, target, label_discount)``.
    """
    refs, tile = output
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    radius, stride, oy, ox, sigma = votes
    ex_labels, target, label_discount = labels
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
        votes_at = np.empty(nmax, np.int32)
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
                    ey = _ex_inside(ex_y[m] - dy, ex_h, wrap_y)
                    ex = _ex_inside(ex_x[m] - dx, ex_w, wrap_x)
                    if ey < 0 or ex < 0:
                        continue
                    v = ey * ex_w + ex
                    if fb >= 0 and offset_code(ey, ex, y, x) == fb:
                        continue
                    wgt = wtab[dy + radius, dx + radius]
                    if label_discount < 1.0 and ex_labels[v] != target[y, x]:
                        wgt *= label_discount
                    votes_at[nv] = v
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
            out[y, x] = _least_squares_vote(votes_at, vw, nv, uniq, usup, nu, top, ex_feat, avg)


@nb.njit(parallel=True, cache=True)
def upsample_state(
    refs, forbid, coarse_y, coarse_x, fine_h, fine_w, wrap_y, wrap_x, out_refs, out_forbid
):  # pragma: no cover - compiled
    """Exact reference up-sampling (laitoch2018 §3.3.2): output pixel (y, x) takes the child
    (2v + y % 2, 2u + x % 2) of the exemplar reference (v, u) of its parent (y // 2, x // 2)
    (on an exemplar of odd side, a child past its edge is its first row or column when it wraps,
    else its last). Forbidden offsets (copy-size control) double with the resolution."""
    H, W = out_refs.shape
    two_b = 2 * OFFSET_BIAS
    for y in nb.prange(H):
        py = y // 2
        for x in range(W):
            px = x // 2
            e = refs[py, px]
            fy = 2 * coarse_y[e] + (y & 1)
            fx = 2 * coarse_x[e] + (x & 1)
            if fy >= fine_h:  # (odd exemplar sides: the last child row does not exist)
                fy = 0 if wrap_y else fine_h - 1
            if fx >= fine_w:
                fx = 0 if wrap_x else fine_w - 1
            out_refs[y, x] = fy * fine_w + fx
            code = forbid[py, px]
            if code < 0:
                out_forbid[y, x] = -1
            else:
                dy = code // two_b - OFFSET_BIAS
                dx = code - (code // two_b) * two_b - OFFSET_BIAS
                out_forbid[y, x] = (2 * dy + OFFSET_BIAS) * two_b + (2 * dx + OFFSET_BIAS)
