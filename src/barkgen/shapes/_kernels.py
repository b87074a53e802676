"""Numba kernels of the binary shape synthesis (Rosenberger et al. 2009, laitoch2018 §3.6)."""

from __future__ import annotations

import numba as nb


@nb.njit
def _index(v, n, wraps):
    """``v`` wrapped into ``0..n-1`` along an axis that ``wraps``, else ``v`` or -1 when
    outside."""
    if wraps:
        return v % n
    return v if 0 <= v < n else -1


@nb.njit(cache=True, parallel=True)
def boundary_mask(shape, wrap, out):
    """``out[y, x] = 1`` where the binary ``shape`` differs from one of its 4-neighbours (both
    sides of every edge are boundary pixels). Neighbours wrap around along the axes ``wrap =
    (rows, columns)`` says; elsewhere the image border is not an edge."""
    wrap_y, wrap_x = wrap
    h, w = shape.shape
    for y in nb.prange(h):
        for x in range(w):
            v = shape[y, x]
            edge = False
            for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                ny = _index(y + dy, h, wrap_y)
                nx = _index(x + dx, w, wrap_x)
                if ny < 0 or nx < 0:
                    continue
                if shape[ny, nx] != v:
                    edge = True
                    break
            out[y, x] = 1 if edge else 0


@nb.njit(cache=True)
def assign_with_capacity(order, query, cand, capacity, out):
    """Greedy boundary-patch matching with even use (laitoch2018 §3.6.2): candidate pairs
    ``(query[i], cand[i])`` are visited in ``order`` (closest first); a query takes its pair when
    it has no match yet and the exemplar patch ``cand`` has capacity left (``Q`` or ``Q + 1``
    uses). Returns the number of queries matched; ``out[q]`` is the chosen pair index or -1."""
    matched = 0
    for t in range(order.shape[0]):
        i = order[t]
        q = query[i]
        if out[q] >= 0:
            continue
        e = cand[i]
        if capacity[e] <= 0:
            continue
        capacity[e] -= 1
        out[q] = i
        matched += 1
    return matched


@nb.njit(cache=True)
def accumulate_weights(ys, xs, patches, weights, falloff, wrap, out):
    """Shape adjustment weights (laitoch2018 eq. 3.10): every matched exemplar patch (``patches``
    ``(m, n, n)`` of +1 inside / -1 outside, already rotated) is superimposed on its synthesized
    boundary pixel ``(ys, xs)``, multiplied by the Gaussian ``falloff`` and by ``weights``
    ``= 1 / (1 + D)``, and summed into ``out``, round the axes ``wrap = (rows, columns)`` says.
    Serial: superimposed patches overlap."""
    wrap_y, wrap_x = wrap
    h, w = out.shape
    n = patches.shape[1]
    r = n // 2
    for i in range(ys.shape[0]):
        wi = weights[i]
        for dy in range(n):
            y = _index(ys[i] + dy - r, h, wrap_y)
            if y < 0:
                continue
            for dx in range(n):
                x = _index(xs[i] + dx - r, w, wrap_x)
                if x < 0:
                    continue
                out[y, x] += wi * falloff[dy, dx] * patches[i, dy, dx]
