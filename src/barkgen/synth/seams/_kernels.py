"""Numba kernels of the seam work (kwatra2003 §3): the pieces a reference map copies
(:func:`label_pieces`), the local seam moves (:func:`refine_seams`), the straight runs of seam
and the bands the graph cuts re-cut them in (:func:`seam_runs`, :func:`seam_band`,
:mod:`barkgen.synth.seams.cuts`), and the graphs of the expansion moves
(:mod:`barkgen.synth.seams.expansion`, Boykov, Veksler & Zabih 2001).

They take the level's exemplar grid as one tuple ``exemplar = (ex_y, ex_x, ex_h, ex_w,
wrap_y, wrap_x)`` (:attr:`barkgen.synth._analysis.LevelAnalysis.grid`); the helpers they share
with the solver's kernels live in :mod:`barkgen.synth._kernels`. :func:`label_pieces` and
:func:`refine_seams` are ``parallel`` over output rows and write only their own rows; the
expansion kernels build one move's graph after another on a single thread: each move is small,
and the moves of a round depend on the ones before them.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from barkgen.synth._kernels import (
    _ex_inside,
    _listed,
    _shifted_neighbour_source,
    _wrap_or_clamp,
    offset_code,
)

#: marks of ``node_of`` (expansion moves): not looked at yet / looked at and fixed (no node)
_UNSEEN = -1
_FIXED = -2
#: extra cost of a pair of pixels whose pieces both end at the exemplar's border between them
#: (the upper one on its last row, the lower one on its first, along an axis that does not
#: wrap): no move of those two pieces can shift such a seam, so a third piece takes it over
STUCK_COST = 1e3


@nb.njit
def _continues(refs, exemplar, py, px, qy, qx, dy, dx):
    """True when output pixel (qy, qx) = (py + dy, px + dx) (a neighbour) copies the exemplar
    pixel next to the one (py, px) copies, the same step away (on the exemplar's torus along
    its wrapping axes): the two belong to one verbatim piece."""
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    e = refs[py, px]
    f = refs[qy, qx]
    cy = _ex_inside(ex_y[e] + dy, ex_h, wrap_y)
    cx = _ex_inside(ex_x[e] + dx, ex_w, wrap_x)
    return cy >= 0 and cx >= 0 and cy == ex_y[f] and cx == ex_x[f]


@nb.njit
def _neighbour4(y, x, k, output):
    """The ``k``-th (0..3: below, above, right, left) 4-neighbour of output pixel (y, x):
    ``(qy, qx, dy, dx, inside)``, round the torus when the output tiles (``output = (refs,
    tile)``); ``inside`` is False for a neighbour beyond the edge of an output that does not."""
    refs, tile = output
    H, W = refs.shape
    dy = (k == 0) - (k == 1)
    dx = (k == 2) - (k == 3)
    qy = y + dy
    qx = x + dx
    if tile:
        return _wrap_or_clamp(qy, H, True), _wrap_or_clamp(qx, W, True), dy, dx, True
    return qy, qx, dy, dx, 0 <= qy < H and 0 <= qx < W


@nb.njit(cache=True)
def label_pieces(output, exemplar, labels):  # pragma: no cover - compiled
    """Label the pieces copied verbatim from the exemplar: the 4-connected regions whose
    neighbouring output pixels copy neighbouring exemplar pixels (:func:`_continues`). A piece
    that runs round a tiled output (``output = (refs, tile)``) or across a wrapping exemplar's
    edge is one piece. Fills ``labels`` and returns each piece's pixel count."""
    refs = output[0]
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
                    qy, qx, dy, dx, inside = _neighbour4(py, px, k, output)
                    if not inside or labels[qy, qx] >= 0:
                        continue
                    if _continues(refs, exemplar, py, px, qy, qx, dy, dx):
                        labels[qy, qx] = n
                        stack[top] = qy * W + qx
                        top += 1
            sizes[n] = count
            n += 1
    return sizes[:n].copy()


@nb.njit
def _feat_dist(feat, ay, ax, by, bx):
    d2 = 0.0
    for c in range(feat.shape[2]):
        v = feat[ay, ax, c] - feat[by, bx, c]
        d2 += v * v
    return np.sqrt(d2)


@nb.njit
def _seam_cost(feat, sides, cy, cx, fy, fx, dy, dx):
    """Cost of the seam between an output pixel taking exemplar pixel ``(cy, cx)`` and its
    neighbour ``(dy, dx)`` away taking ``(fy, fx)`` (Kwatra et al. 2003, eq. 1): ||A(p) - B(p)||
    + ||A(q) - B(q)||, A and B the two pieces, each continued one pixel across the seam; 0 when
    the first continues into the other. A piece that cannot be continued (it reaches a
    non-wrapping exemplar edge) is taken as its last pixel. ``feat``: ``(h, w, C)``;
    ``sides = (ex_h, ex_w, wrap_y, wrap_x)``, the exemplar's size and its wrapping axes."""
    ex_h, ex_w, wrap_y, wrap_x = sides
    ay = _ex_inside(cy + dy, ex_h, wrap_y)
    ax = _ex_inside(cx + dx, ex_w, wrap_x)
    if ay >= 0 and ax >= 0 and ay == fy and ax == fx:
        return 0.0
    if ay < 0 or ax < 0:
        ay = cy
        ax = cx
    by = _ex_inside(fy - dy, ex_h, wrap_y)
    bx = _ex_inside(fx - dx, ex_w, wrap_x)
    if by < 0 or bx < 0:
        by = fy
        bx = fx
    return _feat_dist(feat, cy, cx, by, bx) + _feat_dist(feat, ay, ax, fy, fx)


@nb.njit(parallel=True, cache=True, fastmath=True)
def refine_seams(output, feat, exemplar, parity, forbid, labels, after, moved, out):  # pragma: no cover - compiled
    """One half-sweep of seam optimisation (Kwatra et al. 2003, §3: the seam cost minimised by
    local moves): every output pixel with ``(y + x) % 2 == parity`` takes, among its own
    reference and the forward-shifted references of its 4 neighbours (each continues a
    neighbouring piece), the one whose seams with its 4 neighbours cost least
    (:func:`_seam_cost` on ``feat``, the exemplar features as an ``(h, w, C)`` image). Pixels
    of one parity only have neighbours of the other, so a
    half-sweep is exact and independent of threads, and the total seam cost never rises. The
    borders between pieces thus move onto low-error paths instead of running straight along
    the up-sampling grid. Candidates with the forbidden offset are skipped; when guided
    (``ex_labels`` has more than one entry) a candidate of the wrong label never replaces one of
    the wanted label. Pixels of the other parity are copied.

    ``after`` ``(H, W)`` uint8, or shape ``(1, 1)`` for a first half-sweep that looks at every
    pixel: the ``moved`` map of the previous half-sweep, when this parity's pixels have been
    swept before; a pixel is then looked at only if a neighbour moved (its choice depends on
    nothing else, so the others would keep theirs). ``moved`` ``(H, W)`` uint8 receives 1 where
    a pixel changed. Returns the number changed. ``output = (refs, tile)``: the output's
    references and whether it wraps round; ``labels = (ex_labels, target)``."""
    refs = output[0]
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    sides = (ex_h, ex_w, wrap_y, wrap_x)
    ex_labels, target = labels
    H, W = refs.shape
    guided = ex_labels.shape[0] > 1
    every = after.shape[0] != H or after.shape[1] != W
    changed = np.zeros(H, np.int64)
    for y in nb.prange(H):
        cand = np.empty(5, np.int32)
        for x in range(W):
            e0 = refs[y, x]
            out[y, x] = e0
            moved[y, x] = 0
            if (y + x) % 2 != parity:
                continue
            if not every:
                near = False
                for k in range(4):
                    qy, qx, dy, dx, inside = _neighbour4(y, x, k, output)
                    if inside and after[qy, qx] != 0:
                        near = True
                        break
                if not near:
                    continue
            n = 1
            cand[0] = e0
            fb = forbid[y, x]
            own_ok = (not guided) or ex_labels[e0] == target[y, x]
            for k in range(4):
                dy = (k == 0) - (k == 1)
                dx = (k == 2) - (k == 3)
                u = _shifted_neighbour_source(output, y, x, dy, dx, exemplar)
                if u < 0:
                    continue
                if fb >= 0 and offset_code(ex_y[u], ex_x[u], y, x) == fb:
                    continue
                if guided and own_ok and ex_labels[u] != target[y, x]:
                    continue
                if not _listed(cand, n, u):
                    cand[n] = u
                    n += 1
            if n == 1:
                continue
            best = e0
            best_cost = np.inf
            for t in range(n):
                c = cand[t]
                cost = 0.0
                for k in range(4):
                    qy, qx, dy, dx, inside = _neighbour4(y, x, k, output)
                    if not inside:
                        continue
                    f = refs[qy, qx]
                    cost += _seam_cost(feat, sides, ex_y[c], ex_x[c], ex_y[f], ex_x[f], dy, dx)
                if cost < best_cost - 1e-6:
                    best_cost = cost
                    best = c
            if best != e0:
                out[y, x] = best
                moved[y, x] = 1
                changed[y] += 1
    return changed.sum()


@nb.njit
def _steps_on(d, n, wraps):
    """A coordinate step ``d`` that should be 0, folded onto the exemplar's torus when it wraps
    along that axis (``n`` its side)."""
    if wraps:
        d = d % n
        if d > n // 2:
            d -= n
    return d


@nb.njit(cache=True)
def seam_runs(output, sides, min_run):  # pragma: no cover - compiled
    """The straight seams between rows of a reference map (``output = (ry, rx, tile)``: exemplar
    row and column per output pixel, and whether it wraps round; ``sides``: :func:`_seam_cost`'s):
    runs of at least ``min_run`` neighbouring columns along which output rows ``i`` and ``i + 1``
    do not continue one piece (round the end when it tiles; the last row pairs with the first).
    Returns ``(n, 3)`` int64 rows ``(i, start, length)``."""
    ry, rx, tile = output
    ex_h, ex_w, wrap_y, wrap_x = sides
    H, W = ry.shape
    n_pairs = H if tile else H - 1
    out = np.empty((max(n_pairs * (W // max(min_run, 1) + 1), 1), 3), np.int64)
    n = 0
    seam = np.empty(W, np.bool_)
    for i in range(n_pairs):
        j = i + 1 if i + 1 < H else 0
        any_seam = False
        all_seam = True
        for x in range(W):
            dy = _steps_on(ry[j, x] - ry[i, x] - 1, ex_h, wrap_y)
            dx = _steps_on(rx[j, x] - rx[i, x], ex_w, wrap_x)
            seam[x] = dy != 0 or dx != 0
            any_seam = any_seam or seam[x]
            all_seam = all_seam and seam[x]
        if not any_seam:
            continue
        if all_seam:
            if W >= min_run:
                out[n, 0] = i
                out[n, 1] = 0
                out[n, 2] = W
                n += 1
            continue
        first = 0
        if tile:  # start the scan on a pixel that is no seam, so no run is split by the end
            while seam[first]:
                first += 1
        length = 0
        start = 0
        for t in range(W + 1):
            x = (first + t) % W if tile else t
            on = t < W and seam[x]
            if on:
                if length == 0:
                    start = x
                length += 1
            else:
                if length >= min_run:
                    out[n, 0] = i
                    out[n, 1] = start
                    out[n, 2] = length
                    n += 1
                length = 0
            if not tile and t == W - 1:
                if length >= min_run:
                    out[n, 0] = i
                    out[n, 1] = start
                    out[n, 2] = length
                    n += 1
                break
    return out[:n].copy()


@nb.njit(cache=True)
def seam_band(output, feat, wrap_y, wrap_x, i, cols, band, out):  # pragma: no cover - compiled
    """The graph of one straight seam's re-cut (``barkgen.synth.seams.cuts``), between output rows
    ``i`` and ``i + 1`` along columns ``cols``, over the ``2 * band`` rows around it.

    Fills, per band pixel ``(k, c)`` (output row ``i - band + 1 + k``, column ``cols[c]``):
    ``cand_y/cand_x[l]`` the reference of choice ``l`` (0: the pixel of row ``i`` continued up
    or down, 1: that of row ``i + 1``), ``valid[l]`` whether it exists on the exemplar,
    ``member`` whether the pixel is in the band (it belongs to its side's piece, unbroken from
    the seam; :func:`_band_members`), ``cost[l]`` the seam cost with its neighbours outside the
    band (plus the graph-representable part of the pair terms) and ``w_down``/``w_right`` the
    pair weights to the band pixel below / to the right (:func:`_band_costs`). Returns the
    number of band pixels. ``output = (ry, rx, tile)``: the reference map and whether it wraps
    round; ``out = (cand_y, cand_x, valid, member, cost, w_down, w_right)``."""
    sides = (feat.shape[0], feat.shape[1], wrap_y, wrap_x)
    seam = (i, cols, band)
    _band_members(output, sides, seam, out)
    return _band_costs(output, feat, sides, seam, out)


@nb.njit
def _band_members(output, sides, seam, out):
    """:func:`seam_band`'s choices per band pixel and whether it is in the band (``seam = (i,
    cols, band)``; ``sides``: :func:`_seam_cost`'s)."""
    ry, rx, tile = output
    cand_y, cand_x, valid, member, cost, w_down, w_right = out
    i, cols, band = seam
    ex_h, ex_w, wrap_y, wrap_x = sides
    H, W = ry.shape
    L = cols.shape[0]
    K2 = 2 * band
    j = i + 1 if i + 1 < H else 0
    for c in range(L):
        x = cols[c]
        for k in range(K2):
            off = k - (band - 1)
            y = i + off
            inside = True
            if tile:
                y = y % H
            elif y < 0 or y >= H:
                inside = False
                y = min(max(y, 0), H - 1)
            vy = _ex_inside(ry[i, x] + off, ex_h, wrap_y)
            cand_y[0, k, c] = max(vy, 0)
            cand_x[0, k, c] = rx[i, x]
            valid[0, k, c] = vy >= 0
            vy = _ex_inside(ry[j, x] + off - 1, ex_h, wrap_y)
            cand_y[1, k, c] = max(vy, 0)
            cand_x[1, k, c] = rx[j, x]
            valid[1, k, c] = vy >= 0
            side = 0 if off <= 0 else 1
            member[k, c] = (
                inside and valid[side, k, c] and ry[y, x] == cand_y[side, k, c] and rx[y, x] == cand_x[side, k, c]
            )
        # unbroken from the seam: rows i, i - 1, ... and i + 1, i + 2, ...
        for k in range(band - 2, -1, -1):
            member[k, c] = member[k, c] and member[k + 1, c]
        for k in range(band + 1, K2):
            member[k, c] = member[k, c] and member[k - 1, c]


@nb.njit
def _band_costs(output, feat, sides, seam, out):
    """:func:`seam_band`'s terms: each band pixel's seam cost with its neighbours outside the
    band, and the pair weights inside it (Kolmogorov & Zabih 2004's reduction of a 2x2 table,
    clipped at 0 where it is not submodular). Returns the number of band pixels."""
    ry, rx, tile = output
    cand_y, cand_x, valid, member, cost, w_down, w_right = out
    i, cols, band = seam
    H, W = ry.shape
    L = cols.shape[0]
    K2 = 2 * band
    n = 0
    for c in range(L):
        for k in range(K2):
            cost[0, k, c] = 0.0
            cost[1, k, c] = 0.0
            w_down[k, c] = 0.0
            w_right[k, c] = 0.0
    for c in range(L):
        x = cols[c]
        for k in range(K2):
            if not member[k, c]:
                continue
            n += 1
            y = (i + k - (band - 1)) % H
            for t in range(4):
                dy = (t == 0) - (t == 1)
                dx = (t == 2) - (t == 3)
                kk = k + dy
                cc = c + dx
                if 0 <= kk < K2 and 0 <= cc < L and member[kk, cc]:
                    continue  # a pair inside the band: below
                qy = y + dy
                qx = x + dx
                if tile:
                    qy = qy % H
                    qx = qx % W
                elif qy < 0 or qy >= H or qx < 0 or qx >= W:
                    continue
                for lab in range(2):
                    cost[lab, k, c] += _seam_cost(
                        feat,
                        sides,
                        cand_y[lab, k, c],
                        cand_x[lab, k, c],
                        ry[qy, qx],
                        rx[qy, qx],
                        dy,
                        dx,
                    )
            for t in range(2):  # pairs with the band pixel below (t = 0) and to the right
                kk = k + 1 - t
                cc = c + t
                if kk >= K2 or cc >= L or not member[kk, cc]:
                    continue
                dy = 1 - t
                dx = t
                e = np.empty((2, 2))
                for u in range(2):
                    for v in range(2):
                        e[u, v] = _seam_cost(
                            feat,
                            sides,
                            cand_y[u, k, c],
                            cand_x[u, k, c],
                            cand_y[v, kk, cc],
                            cand_x[v, kk, cc],
                            dy,
                            dx,
                        )
                cost[1, k, c] += e[1, 0] - e[0, 0]
                cost[1, kk, cc] += e[1, 1] - e[1, 0]
                w = max(e[0, 1] + e[1, 0] - e[0, 0] - e[1, 1], 0.0)
                if t == 0:
                    w_down[k, c] = w
                else:
                    w_right[k, c] = w
            for lab in range(2):
                if not valid[lab, k, c]:
                    cost[lab, k, c] += 1e9
    return n


@nb.njit
def _pair_cost(feat, exemplar, c, f, dy, dx):
    """:func:`_seam_cost` of output neighbours taking flat exemplar indices ``c`` and ``f``
    (``f`` at ``(dy, dx)`` from ``c``), plus :data:`STUCK_COST` where both pieces end at the
    exemplar's border between them."""
    ex_y, ex_x, ex_h, ex_w, wrap_y, wrap_x = exemplar
    cy, cx, fy, fx = ex_y[c], ex_x[c], ex_y[f], ex_x[f]
    cost = _seam_cost(feat, (ex_h, ex_w, wrap_y, wrap_x), cy, cx, fy, fx, dy, dx)
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
def border_costs(output, codes, feat, exemplar, out):  # pragma: no cover - compiled
    """``out`` ``(H, W)``: each output pixel's highest seam cost (:func:`_pair_cost`) with a
    4-neighbour of another piece (offset ``codes``), 0 inside a piece; ``output = (refs,
    tile)``."""
    refs = output[0]
    H, W = refs.shape
    for y in nb.prange(H):
        for x in range(W):
            best = 0.0
            for k in range(4):
                qy, qx, dy, dx, inside = _neighbour4(y, x, k, output)
                if inside and codes[qy, qx] != codes[y, x]:
                    best = max(best, _pair_cost(feat, exemplar, refs[y, x], refs[qy, qx], dy, dx))
            out[y, x] = best


@nb.njit(cache=True)
def expansion_nodes(output, codes, piece, exemplar, keep, labels, band, node_of, out):  # pragma: no cover - compiled
    """The nodes of the expansion move of the piece ``piece = (alpha, members)`` (its offset
    code ``alpha``): every output pixel within ``band`` pixels (a square) of a border pixel of
    the piece (``members``: the flat output indices whose offset code was ``alpha`` when the
    round began; those no longer ``alpha`` in ``codes`` are skipped) whose seam costs at least ``least`` (``border_cost``, from
    :func:`border_costs`: cheap stretches of border are left where they are), and that may take
    the piece continued to it.

    A pixel may not when the continued reference leaves an exemplar that does not wrap, when
    its offset is the pixel's forbidden one (``keep = (forbid, rare, border_cost, least)``:
    ``forbid`` (H, W), the copy-size control's, or (1, 1), the same for every pixel), when its own reference is one the output has too few of (``rare``,
    per flat exemplar index: taking it over would leave that part of the exemplar out), or when
    guided
    (``labels = (ex_labels, target)`` with more than one exemplar label) it would give a pixel
    of the wanted label a wrong one. ``node_of`` ``(H, W)`` int32, all ``-1`` on entry, receives
    each node's index, ``-2`` on the pixels looked at that are not nodes; ``out = (node_y,
    node_x, node_ref, touched)`` receive the nodes' positions, their continued references and
    the flat indices of every pixel marked (so the caller can reset ``node_of``). Returns
    ``(n_nodes, n_touched)``; ``(-1, n_touched)`` when more pixels are marked than ``touched``
    holds (the caller resets those, grows the buffers and asks again)."""
    refs, tile = output
    alpha, members = piece
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
                if n_touched == touched.shape[0]:  # the buffers are full: the caller grows them
                    return -1, n_touched
                touched[n_touched] = qy * W + qx
                n_touched += 1
                node_of[qy, qx] = _FIXED
                if codes[qy, qx] == alpha or rare[refs[qy, qx]]:
                    continue
                ay = _ex_inside(ex_y[e] + dy, ex_h, wrap_y)
                ax = _ex_inside(ex_x[e] + dx, ex_w, wrap_x)
                if ay < 0 or ax < 0:
                    continue
                fb = forbid[qy % forbid.shape[0], qx % forbid.shape[1]]  # (1, 1): one for all
                if fb >= 0 and offset_code(ay, ax, qy, qx) == fb:
                    continue
                u = ay * ex_w + ax
                if guided and ex_labels[u] != target[qy, qx] and ex_labels[refs[qy, qx]] == target[qy, qx]:
                    continue
                node_of[qy, qx] = n
                node_y[n] = qy
                node_x[n] = qx
                node_ref[n] = u
                n += 1
    return n, n_touched


@nb.njit(parallel=True, cache=True, fastmath=True)
def expansion_terms(output, node_of, nodes, n, feat, exemplar, out):  # pragma: no cover - compiled
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
    refs = output[0]
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
            qy, qx, dy, dx, inside = _neighbour4(py, px, k, output)
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
