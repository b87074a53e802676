"""Numba kernels of the seams' expansion moves (:mod:`barkgen.synth.expansion`).

Each builds one expansion move's graph (Boykov, Veksler & Zabih 2001) over a reference map of
flat exemplar indices, with the level's exemplar grid as one tuple ``exemplar = (ex_y, ex_x,
ex_h, ex_w, wrap_y, wrap_x)`` (:attr:`barkgen.synth.analysis.LevelAnalysis.grid`). They run
one after another on a single thread: each move is small, and the moves of a round depend on
the ones before them.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from barkgen.synth._kernels import _ex_inside, _neighbour4, _seam_cost, offset_code

#: marks of ``node_of``: not looked at yet / looked at and fixed (no node)
_UNSEEN = -1
_FIXED = -2
#: extra cost of a pair of pixels whose pieces both end at the exemplar's border between them
#: (the upper one on its last row, the lower one on its first, along an axis that does not
#: wrap): no move of those two pieces can shift such a seam, so a third piece takes it over
STUCK_COST = 1e3


@nb.njit
def _pair_cost(feat, exemplar, c, f, dy, dx):
    """:func:`_seam_cost` of output neighbours taking flat exemplar indices ``c`` and ``f``
    (``f`` at ``(dy, dx)`` from ``c``), plus :data:`STUCK_COST` where both pieces end at the
    exemplar's border between them."""
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    cy, cx, fy, fx = ex_y[c], ex_x[c], ex_y[f], ex_x[f]
    cost = _seam_cost(feat, ex_h, ex_w, wrap_y, wrap_x, cy, cx, fy, fx, dy, dx)
    if dy != 0 and not wrap_y:
        last = ex_h - 1
        if (dy > 0 and cy == last and fy == 0) or (dy < 0 and cy == 0 and fy == last):
            cost += STUCK_COST
    if dx != 0 and not wrap_x:
        last = ex_w - 1
        if (dx > 0 and cx == last and fx == 0) or (dx < 0 and cx == 0 and fx == last):
            cost += STUCK_COST
    return cost


@nb.njit(parallel=True, cache=True, fastmath=True)
def border_costs(refs, codes, feat, exemplar, tile, out):  # pragma: no cover - compiled
    """``out`` ``(H, W)``: each output pixel's highest seam cost (:func:`_pair_cost`) with a
    4-neighbour of another piece (offset ``codes``), 0 inside a piece."""
    H, W = refs.shape
    for y in nb.prange(H):
        for x in range(W):
            best = 0.0
            for k in range(4):
                qy, qx, dy, dx, inside = _neighbour4(y, x, k, H, W, tile)
                if inside and codes[qy, qx] != codes[y, x]:
                    best = max(best, _pair_cost(feat, exemplar, refs[y, x], refs[qy, qx], dy, dx))
            out[y, x] = best


@nb.njit(cache=True)
def expansion_nodes(refs, codes, alpha, members, exemplar, tile, keep, labels, band,
                    node_of, out):  # pragma: no cover - compiled
    """The nodes of the expansion move of piece offset ``alpha``: every output pixel within
    ``band`` pixels (a square) of a border pixel of the piece (``members``: the flat output
    indices whose offset code was ``alpha`` when the round began; those no longer ``alpha`` in
    ``codes`` are skipped) whose seam costs at least ``least`` (``border_cost``, from
    :func:`border_costs`: cheap stretches of border are left where they are), and that may take
    the piece continued to it.

    A pixel may not when the continued reference leaves an exemplar that does not wrap, when
    its offset is the pixel's forbidden one (``keep = (forbid, rare, border_cost, least)``:
    ``forbid`` (H, W), the copy-size control's), when its own reference is one the output has too few of (``rare``,
    per flat exemplar index: taking it over would leave that part of the exemplar out), or when
    guided
    (``labels = (ex_labels, target)`` with more than one exemplar label) it would give a pixel
    of the wanted label a wrong one. ``node_of`` ``(H, W)`` int32, all ``-1`` on entry, receives
    each node's index, ``-2`` on the pixels looked at that are not nodes; ``out = (node_y,
    node_x, node_ref, touched)`` receive the nodes' positions, their continued references and
    the flat indices of every pixel marked (so the caller can reset ``node_of``). Returns
    ``(n_nodes, n_touched)``."""
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    ex_labels, target = labels
    forbid, rare, border_cost, least = keep
    node_y, node_x, node_ref, touched = out
    H, W = refs.shape
    guided = ex_labels.shape[0] > 1
    n = 0
    n_touched = 0
    for t in range(members.shape[0]):
        b = members[t]
        by = b // W
        bx = b - by * W
        if codes[by, bx] != alpha or border_cost[by, bx] < least:
            continue
        e = refs[by, bx]
        for dy in range(-band, band + 1):
            qy = by + dy
            if tile:
                qy %= H
            elif qy < 0 or qy >= H:
                continue
            for dx in range(-band, band + 1):
                qx = bx + dx
                if tile:
                    qx %= W
                elif qx < 0 or qx >= W:
                    continue
                if node_of[qy, qx] != _UNSEEN:
                    continue
                touched[n_touched] = qy * W + qx
                n_touched += 1
                node_of[qy, qx] = _FIXED
                if codes[qy, qx] == alpha or rare[refs[qy, qx]]:
                    continue
                ay = _ex_inside(ex_y[e] + dy, ex_h, wrap_y)
                ax = _ex_inside(ex_x[e] + dx, ex_w, wrap_x)
                if ay < 0 or ax < 0:
                    continue
                fb = forbid[qy, qx]
                if fb >= 0 and offset_code(ay, ax, qy, qx) == fb:
                    continue
                u = ay * ex_w + ax
                if guided and ex_labels[u] != target[qy, qx] \
                        and ex_labels[refs[qy, qx]] == target[qy, qx]:
                    continue
                node_of[qy, qx] = n
                node_y[n] = qy
                node_x[n] = qx
                node_ref[n] = u
                n += 1
    return n, n_touched


@nb.njit(parallel=True, cache=True, fastmath=True)
def expansion_terms(refs, node_of, nodes, n, feat, exemplar, tile,
                    out):  # pragma: no cover - compiled
    """The terms of one expansion move's graph over its ``n`` nodes (``nodes = (node_y, node_x,
    node_ref)`` from :func:`expansion_nodes`): choice 0 keeps a node's reference, choice 1 takes
    the piece's. The energy is Kwatra et al. 2003's seam cost (:func:`_pair_cost` on ``feat``,
    the exemplar features as an ``(h, w, C)`` image) summed over neighbouring pixels; a pair
    with a fixed pixel is a unary term, a pair of nodes is reduced as Kolmogorov & Zabih 2004
    do (``E00 + E11 <= E01 + E10`` holds because the seam cost is a sum of two distances; where
    the clamp at a non-wrapping exemplar edge or the stuck cost breaks it, ``E00`` is lowered
    to the bound, Rother et al. 2005, so the move never raises the true energy).

    ``out = (unary, edge_i, edge_j, edge_cap, partner)``: each node's unary term (what choice 1
    costs more than choice 0) and the directed pair edges (``partner``, of ``2 * n`` entries
    like the edge arrays, is scratch). The nodes' own terms are computed in parallel, each in
    its own slots, then summed in node order, so the result does not depend on the threads.
    Returns the number of edges."""
    node_y, node_x, node_ref = nodes
    unary, edge_i, edge_j, edge_cap, partner = out
    H, W = refs.shape
    for t in nb.prange(n):
        py = node_y[t]
        px = node_x[t]
        c0 = refs[py, px]
        c1 = node_ref[t]
        u = 0.0
        for k in range(4):
            slot = 2 * t + (k >> 1)  # below -> slot 0, right -> slot 1
            if k == 0 or k == 2:
                edge_j[slot] = -1
            qy, qx, dy, dx, inside = _neighbour4(py, px, k, H, W, tile)
            if not inside:
                continue
            j = node_of[qy, qx]
            f0 = refs[qy, qx]
            if j < 0:  # a fixed neighbour: a unary term
                u += _pair_cost(feat, exemplar, c1, f0, dy, dx) - _pair_cost(feat, exemplar, c0, f0, dy, dx)
                continue
            if k == 1 or k == 3:  # a pair of nodes is taken once, from the pixel above / left
                continue
            f1 = node_ref[j]
            a = _pair_cost(feat, exemplar, c0, f0, dy, dx)
            b = _pair_cost(feat, exemplar, c0, f1, dy, dx)
            c = _pair_cost(feat, exemplar, c1, f0, dy, dx)
            d = _pair_cost(feat, exemplar, c1, f1, dy, dx)
            if a + d > b + c:
                a = b + c - d
            # E = a + (c - a) x_p + (d - c) x_q + (b + c - a - d) (1 - x_p) x_q
            u += c - a
            edge_j[slot] = j
            edge_cap[slot] = b + c - a - d
            partner[slot] = d - c
        unary[t] = u
    m = 0
    for slot in range(2 * n):  # the partners' shares, and the edges compacted in place
        j = edge_j[slot]
        if j < 0:
            continue
        unary[j] += partner[slot]
        w = edge_cap[slot]
        if w > 0.0:
            edge_i[m] = slot >> 1
            edge_j[m] = j
            edge_cap[m] = w
            m += 1
    return m
