"""Numba kernels of the colour's seam blend (:func:`barkgen.synth.seams.gradient.blend_seams`):
the excess of every step over a step the photo could have taken there (:func:`excess_steps`)
and the screened Poisson correction on the band along the seams, by red-black successive
over-relaxation (:func:`relax_band`; Pérez et al. 2003's cloning with the seams as its region).

Both are ``parallel`` and write only their own pixels: :func:`excess_steps` over output rows,
:func:`relax_band` over the pixels of one colour of the red-black order at a time, so the
result is the same on any number of threads.
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(inline="always")
def _carried_step(exemplar, ry, rx, axis, wrap, c):
    """The exemplar's forward step along ``axis`` at ``(ry, rx)``, channel ``c``: to the next
    pixel (round the exemplar where it ``wrap``\\s along that axis; the last step again at its
    end where it does not)."""
    h, w = exemplar.shape[0], exemplar.shape[1]
    n = h if axis == 0 else w
    i = ry if axis == 0 else rx
    if n < 2:
        return 0.0
    if wrap:
        j = (i + 1) % n
    elif i + 1 < n:
        j = i + 1
    else:
        j, i = i, i - 1
    if axis == 0:
        return exemplar[j, rx, c] - exemplar[i, rx, c]
    return exemplar[ry, j, c] - exemplar[ry, i, c]


@nb.njit(parallel=True, cache=True)
def excess_steps(exemplar, refs, flags, limits, excess_y, excess_x, reach_y, reach_x):  # pragma: no cover - compiled
    """Per output pixel and axis, the excess of its step to the next pixel over a step the
    photo could have taken there, and how far its correction reaches.

    The mismatch ``d`` is the step less the exemplar's step at the pixel's reference (zero
    inside a piece). Of it, what is shorter than ``threshold * |carried step| + floor`` is
    left; the rest is written to ``excess_y`` / ``excess_x`` (``(H, W, C)``), and its reach to
    ``reach_y`` / ``reach_x`` (``(H, W)``: 0 without an excess, else ``1 + ceil((k - 1) / 2)``
    for an excess of ``k`` times ``spread`` of the photo's mean steps, at most ``max_reach``).
    ``flags = (wrap_y, wrap_x, tile)``: the exemplar's wrap, the output's; no step across the
    output's edges unless it tiles. ``limits = (threshold, floor_y, floor_x, unit_y, unit_x,
    max_reach)``, the floors and units (``spread`` x mean step) in the map's values.
    """
    wrap_y, wrap_x, tile = flags
    threshold, floor_y, floor_x, unit_y, unit_x, max_reach = limits
    H, W = refs.shape[0], refs.shape[1]
    C = exemplar.shape[2]
    for row in nb.prange(H):
        y = np.int64(row)  # (a parfor's index may be unsigned, and y + 1 then a float)
        d = np.empty(C)
        for x in range(W):
            ry, rx = refs[y, x, 0], refs[y, x, 1]
            for axis in range(2):
                qy, qx = (y + 1, x) if axis == 0 else (y, x + 1)
                out = excess_y if axis == 0 else excess_x
                reach = reach_y if axis == 0 else reach_x
                if qy == H or qx == W:
                    if not tile:
                        for c in range(C):
                            out[y, x, c] = 0.0
                        reach[y, x] = 0
                        continue
                    qy, qx = qy % H, qx % W
                wrap = wrap_y if axis == 0 else wrap_x
                qry, qrx = refs[qy, qx, 0], refs[qy, qx, 1]
                mismatch, carried = 0.0, 0.0
                for c in range(C):
                    g = _carried_step(exemplar, ry, rx, axis, wrap, c)
                    d[c] = exemplar[qry, qrx, c] - exemplar[ry, rx, c] - g
                    mismatch += d[c] * d[c]
                    carried += g * g
                mismatch = np.sqrt(mismatch)
                allowed = threshold * np.sqrt(carried) + (floor_y if axis == 0 else floor_x)
                scale = 1.0 - allowed / mismatch if mismatch > allowed else 0.0
                for c in range(C):
                    out[y, x, c] = d[c] * scale
                if scale > 0.0:
                    k = scale * mismatch / (unit_y if axis == 0 else unit_x)
                    reach[y, x] = 1 + min(max(int(np.ceil((k - 1.0) / 2.0)), 0), max_reach - 1)
                else:
                    reach[y, x] = 0


@nb.njit(inline="always")
def _step_weight(excess, y, x, border_weight):
    """The weight of the step from ``(y, x)`` onwards: ``border_weight`` with an excess."""
    for c in range(excess.shape[2]):
        if excess[y, x, c] != 0.0:
            return border_weight
    return 1.0


@nb.njit
def _relax_pixel(p, free, index, excess, correction, settings):
    """One over-relaxed Gauss-Seidel update of free pixel ``p`` (all channels); returns the
    largest change."""
    ys, xs = free
    tile, border_weight, anchor, omega = settings
    H, W = index.shape
    C = correction.shape[1]
    y, x = ys[p], xs[p]
    total = np.zeros(C)
    weight = anchor
    for axis in range(2):
        for side in (-1, 1):
            ny, nx = (y + side, x) if axis == 0 else (y, x + side)
            if ny < 0 or ny >= H or nx < 0 or nx >= W:
                if not tile:
                    continue
                ny, nx = ny % H, nx % W
            ey, ex = (y, x) if side == 1 else (ny, nx)  # the step's first pixel
            e = excess[0] if axis == 0 else excess[1]
            w = _step_weight(e, ey, ex, border_weight)
            weight += w
            q = index[ny, nx]
            for c in range(C):
                cq = correction[q, c] if q >= 0 else 0.0
                total[c] += w * (cq + side * e[ey, ex, c])
    change = 0.0
    for c in range(C):
        new = (1.0 - omega) * correction[p, c] + omega * total[c] / weight
        change = max(change, abs(new - correction[p, c]))
        correction[p, c] = new
    return change


@nb.njit(parallel=True, cache=True)
def relax_band(correction, free, index, excess, settings, stop):  # pragma: no cover - compiled
    """The correction ``(n, C)`` of the ``n`` free pixels ``free = (ys, xs, colour_start)`` (the
    red pixels first, then from ``colour_start[1]`` the black, then from ``colour_start[2]`` those
    of neither, which sit on an odd-sized tiled output's wrap and are updated one by one) that
    minimises ``sum_steps w (c_q - c_p + e_pq)^2 + anchor * sum c^2``, every other pixel held at
    0, ``index`` ``(H, W)`` the free pixels' rows in ``correction`` (-1: held), ``excess =
    (excess_y, excess_x)`` (:func:`excess_steps`), ``settings = (tile, border_weight, anchor,
    omega)``. Sweeps until no value moves by more than ``stop[0]``, at most ``stop[1]`` sweeps;
    returns the sweeps made."""
    ys, xs, colour_start = free
    tolerance, max_sweeps = stop
    n = ys.shape[0]
    pixels = (ys, xs)
    sweeps = 0
    for sweep in range(max_sweeps):
        sweeps = sweep + 1
        change = 0.0
        for colour in range(2):
            start, stop_ = colour_start[colour], colour_start[colour + 1]
            changes = np.zeros(stop_ - start)
            for i in nb.prange(stop_ - start):
                changes[i] = _relax_pixel(start + i, pixels, index, excess, correction, settings)
            if changes.size:
                change = max(change, changes.max())
        for p in range(colour_start[2], n):
            change = max(change, _relax_pixel(p, pixels, index, excess, correction, settings))
        if change <= tolerance:
            break
    return sweeps
