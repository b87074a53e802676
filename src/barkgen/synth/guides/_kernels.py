"""Numba kernels of texture-by-numbers' guides: the initialisation's region growing
(laitoch2018 §3.4.2) and the label clean-up after the finest level."""

from __future__ import annotations

import numba as nb
import numpy as np

from barkgen.synth._kernels import _mix, _shifted_neighbour_source, _wrap_or_clamp


@nb.njit
def _load_output(target, by, bx, radius, lab, dist):
    """The output neighbourhood of (by, bx) into ``lab`` / ``dist`` (``target = (idb, db,
    tile)``: wrapped when the output tiles)."""
    idb, db, tile = target
    H, W = idb.shape
    k = 0
    for dy in range(-radius, radius + 1):
        vy = _wrap_or_clamp(by + dy, H, tile)
        for dx in range(-radius, radius + 1):
            vx = _wrap_or_clamp(bx + dx, W, tile)
            lab[k] = idb[vy, vx]
            dist[k] = db[vy, vx]
            k += 1


@nb.njit
def _guide_distance(pad_a, pad_da, ay, ax, lab, dist, radius, label_weight, bound):
    """laitoch2018 eq. 3.6 over the ``(2 radius + 1)^2`` neighbourhood, mean-normalised:
    ``label_weight`` x the fraction of mismatching labels + the RMS difference of the boundary
    distances, between exemplar pixel (ay, ax) (``pad_a``, ``pad_da``: labels and distances
    padded by ``radius`` with edge values) and an output neighbourhood loaded by
    :func:`_load_output`. Stops early (returning a value >= ``bound``) once the partial sum
    exceeds ``bound``."""
    side = 2 * radius + 1
    n = side * side
    per_label = label_weight / n
    mism = 0.0
    dd = 0.0
    k = 0
    for dy in range(side):
        for dx in range(side):
            if pad_a[ay + dy, ax + dx] != lab[k]:
                mism += per_label
            diff = pad_da[ay + dy, ax + dx] - dist[k]
            dd += diff * diff
            k += 1
        if mism + np.sqrt(dd / n) >= bound:
            break
    return mism + np.sqrt(dd / n)


@nb.njit
def _seed_match(pad, pool, seed, salt, neighbourhood, params, usage, cand, dist):
    """The exemplar pixel a seed's region copies: the nearest under eq. 3.6 among at most
    ``max_candidates`` pixels of ``pool`` (the seed's label), and among those within
    ``tolerance`` of it the least used so far. ``pad`` ``(labels, distances)`` of the padded
    exemplar, ``neighbourhood`` ``(labels, distances)`` of the seed's output neighbourhood,
    ``params`` ``(radius, label_weight, tolerance, max_candidates)``; ``cand``, ``dist`` are
    scratch. Returns ``(pixel, distance)``."""
    pad_a, pad_da = pad
    nb_lab, nb_dist = neighbourhood
    radius, label_weight, tolerance, max_candidates = params
    w = pad_a.shape[1] - 2 * radius
    n_ex = (pad_a.shape[0] - 2 * radius) * w
    # a first estimate of the best distance from a few candidates bounds the scan: candidates
    # beyond it + tolerance stop early (they cannot be chosen)
    bound = np.inf
    for t in range(32):
        a = pool[np.int64(_mix(salt ^ np.uint64(seed * 32 + t + 1)) % np.uint64(pool.size))]
        qy = a // w
        d = _guide_distance(pad_a, pad_da, qy, a - qy * w, nb_lab, nb_dist, radius, label_weight, bound)
        if d + tolerance < bound:
            bound = d + tolerance
    # a regular subsample with a random phase: at most max_candidates of the exemplar's pixels
    step = max(1, n_ex // max_candidates)
    phase = np.int64(_mix(salt ^ np.uint64(seed + 7)) % np.uint64(min(step, pool.size)))
    n_cand = 0
    d_min = np.inf
    for i in range(phase, pool.size, step):
        a = pool[i]
        qy = a // w
        d = _guide_distance(pad_a, pad_da, qy, a - qy * w, nb_lab, nb_dist, radius, label_weight, bound)
        cand[n_cand] = a
        dist[n_cand] = d
        n_cand += 1
        if d < d_min:
            d_min = d
    best = -1
    best_d = np.inf
    best_use = 0
    best_key = np.uint64(0)
    for i in range(n_cand):
        if dist[i] > d_min + tolerance:
            continue
        a = cand[i]
        key = _mix(salt ^ np.uint64(a + 1))
        if best < 0 or usage[a] < best_use or (usage[a] == best_use and key < best_key):
            best = a
            best_d = dist[i]
            best_use = usage[a]
            best_key = key
    return best, best_d


@nb.njit(cache=True)
def grow_regions(exemplar, target, label_pools, order, params, salt, refs):  # pragma: no cover - compiled
    """Seeded region growing of Bonneel et al. 2010's first pass (laitoch2018 §3.4.2).

    Output pixels are taken as seeds in ``order`` (a random permutation); an unfilled seed ``pB``
    is matched to the exemplar pixel ``pA`` nearest under eq. 3.6 (searched among at most
    ``max_candidates`` exemplar pixels of the seed's label, listed in ``label_pool`` from
    ``label_start[label]``; among those within ``tolerance`` of the best, the least used so
    far, so the exemplar is covered evenly), and the region grows by flood fill with the
    constant offset ``pA - pB``: a neighbour ``p'`` joins while
    ``d(p' + offset, p') < (d(pA, pB) + 5) * 1.25`` and (stricter than the thesis, which lets
    regions spill over label edges the solver must then repair) its own label matches. ``refs``
    (``-1`` = unfilled) receives flat exemplar indices. Returns the number of regions.

    ``exemplar`` ``(labels, boundary distances)`` of the exemplar (``ida``, ``da``), ``target``
    the same of the output and whether it wraps round (``idb``, ``db``, ``tile``), ``label_pools`` ``(label_pool, label_start)``,
    ``params`` ``(radius, label_weight, tolerance, max_candidates)``.
    """
    ida, da = exemplar
    idb, db, tile = target
    label_pool, label_start = label_pools
    radius, label_weight = params[0], params[1]
    h, w = ida.shape
    H, W = idb.shape
    side = 2 * radius + 1
    pad_a = np.empty((h + 2 * radius, w + 2 * radius), ida.dtype)
    pad_da = np.empty((h + 2 * radius, w + 2 * radius), da.dtype)
    for y in range(h + 2 * radius):
        sy = min(max(y - radius, 0), h - 1)
        for x in range(w + 2 * radius):
            sx = min(max(x - radius, 0), w - 1)
            pad_a[y, x] = ida[sy, sx]
            pad_da[y, x] = da[sy, sx]
    cand = np.empty(h * w, np.int64)
    dist = np.empty(h * w, np.float64)
    nb_lab = np.empty(side * side, idb.dtype)
    nb_dist = np.empty(side * side, db.dtype)
    usage = np.zeros(h * w, np.int64)
    tested = np.full(H * W, -1, np.int64)
    queue_y = np.empty(H * W, np.int64)
    queue_x = np.empty(H * W, np.int64)
    n_regions = 0
    for seed in order:
        if refs[seed] >= 0:
            continue
        by = seed // W
        bx = seed - by * W
        _load_output(target, by, bx, radius, nb_lab, nb_dist)
        # candidates: the exemplar pixels of the seed's label
        own = idb[by, bx]
        pool = label_pool[label_start[own] : label_start[own + 1]]
        best, best_d = _seed_match((pad_a, pad_da), pool, seed, salt, (nb_lab, nb_dist), params, usage, cand, dist)
        ay = best // w
        ax = best - ay * w
        threshold = (best_d + 5.0) * 1.25
        oy = ay - by
        ox = ax - bx
        refs[seed] = best
        usage[best] += 1
        tested[seed] = n_regions
        queue_y[0] = by
        queue_x[0] = bx
        head = 0
        tail = 1
        while head < tail:
            uy = queue_y[head]
            ux = queue_x[head]
            head += 1
            for k in range(4):
                ny = uy + (k == 0) - (k == 1)
                nx = ux + (k == 2) - (k == 3)
                if not tile and (ny < 0 or ny >= H or nx < 0 or nx >= W):
                    continue
                sy = ny + oy
                sx = nx + ox
                if sy < 0 or sy >= h or sx < 0 or sx >= w:
                    continue
                vy = _wrap_or_clamp(ny, H, tile)
                vx = _wrap_or_clamp(nx, W, tile)
                p = vy * W + vx
                if refs[p] >= 0 or tested[p] == n_regions or ida[sy, sx] != idb[vy, vx]:
                    continue
                tested[p] = n_regions
                _load_output(target, vy, vx, radius, nb_lab, nb_dist)
                if _guide_distance(pad_a, pad_da, sy, sx, nb_lab, nb_dist, radius, label_weight, threshold) < threshold:
                    a = sy * w + sx
                    refs[p] = a
                    usage[a] += 1
                    queue_y[tail] = ny
                    queue_x[tail] = nx
                    tail += 1
        n_regions += 1
    return n_regions


@nb.njit(parallel=True, cache=True)
def enforce_labels(output, exemplar, ex_labels, target, out):  # pragma: no cover - compiled
    """Label clean-up (texture-by-numbers): an output pixel whose exemplar label differs from the
    wanted one takes, among the forward-shifted references of its 8 neighbours that have the
    wanted label, the one most of them agree on (so it continues a neighbouring piece); pixels
    with no such neighbour keep their reference. ``output = (refs, tile)``: the output's
    references and whether it wraps round. Returns the number of pixels changed."""
    refs = output[0]
    H, W = refs.shape
    changed = np.zeros(H, np.int64)
    for y in nb.prange(H):
        cand = np.empty(8, np.int32)
        support = np.empty(8, np.int32)
        for x in range(W):
            e = refs[y, x]
            want = target[y, x]
            out[y, x] = e
            if ex_labels[e] == want:
                continue
            n = 0
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    if dy == 0 and dx == 0:
                        continue
                    u = _shifted_neighbour_source(output, y, x, dy, dx, exemplar)
                    if u < 0 or ex_labels[u] != want:
                        continue
                    found = False
                    for t in range(n):
                        if cand[t] == u:
                            support[t] += 1
                            found = True
                            break
                    if not found:
                        cand[n] = u
                        support[n] = 1
                        n += 1
            if n == 0:
                continue
            best = 0
            for t in range(1, n):
                if support[t] > support[best]:
                    best = t
            out[y, x] = cand[best]
            changed[y] += 1
    return changed.sum()
