"""Numba kernels of the crack-network extraction: tracing a one-pixel skeleton into a graph."""

from __future__ import annotations

import numpy as np
from numba import njit

# 8-neighbourhood, 4-neighbours first (a walk prefers the straight step)
_DY = np.array([-1, 1, 0, 0, -1, -1, 1, 1], np.int64)
_DX = np.array([0, 0, -1, 1, -1, 1, -1, 1], np.int64)


@njit(cache=True)
def skeleton_degree(skel):
    """Number of 8-neighbours of every skeleton pixel (``-1`` off the skeleton)."""
    h, w = skel.shape
    deg = np.full((h, w), -1, np.int32)
    for y in range(h):
        for x in range(w):
            if skel[y, x] == 0:
                continue
            n = 0
            for k in range(8):
                yy = y + _DY[k]
                xx = x + _DX[k]
                if 0 <= yy < h and 0 <= xx < w and skel[yy, xx] != 0:
                    n += 1
            deg[y, x] = n
    return deg


@njit(cache=True)
def trace_edges(skel, node_id, node_py, node_px):
    """Trace the skeleton between its nodes.

    ``skel`` is a ``uint8`` one-pixel skeleton, ``node_id`` the node of every node pixel
    (junction clusters and end points; ``-1`` elsewhere), ``node_py, node_px`` the node pixels.
    Returns ``(edge_a, edge_b, offsets, path_y, path_x)``: edge ``e`` runs from node
    ``edge_a[e]`` to node ``edge_b[e]`` through the pixels ``offsets[e]:offsets[e + 1]`` of
    the path arrays (its inner pixels, node pixels excluded). Closed loops without a node come
    last, with ``edge_a = edge_b = -1``, their first pixel not repeated at the end.
    """
    h, w = skel.shape
    n_skel = 0
    for y in range(h):
        for x in range(w):
            if skel[y, x] != 0:
                n_skel += 1
    cap = n_skel + 8 * len(node_py) + 1
    edge_a = np.empty(cap, np.int64)
    edge_b = np.empty(cap, np.int64)
    offsets = np.zeros(cap + 1, np.int64)
    path_y = np.empty(n_skel + 1, np.int64)
    path_x = np.empty(n_skel + 1, np.int64)
    visited = np.zeros((h, w), np.uint8)
    n_edges = 0
    n_path = 0
    seen_pairs = {np.int64(0): np.int64(0)}
    n_nodes = 0
    for i in range(len(node_py)):
        if node_id[node_py[i], node_px[i]] + 1 > n_nodes:
            n_nodes = node_id[node_py[i], node_px[i]] + 1
    for i in range(len(node_py)):
        py = node_py[i]
        px = node_px[i]
        a = node_id[py, px]
        for k in range(8):
            qy = py + _DY[k]
            qx = px + _DX[k]
            if qy < 0 or qy >= h or qx < 0 or qx >= w or skel[qy, qx] == 0:
                continue
            b = node_id[qy, qx]
            if b >= 0:  # two adjacent node pixels of different nodes: an edge without pixels
                if b == a:
                    continue
                lo = min(a, b)
                hi = max(a, b)
                key = np.int64(lo) * n_nodes + hi + 1
                if key in seen_pairs:
                    continue
                seen_pairs[key] = 1
                edge_a[n_edges] = lo
                edge_b[n_edges] = hi
                n_edges += 1
                offsets[n_edges] = n_path
                continue
            if visited[qy, qx]:
                continue
            end, n_path = _walk_to_node(skel, node_id, visited, py, px, qy, qx, path_y, path_x, n_path)
            edge_a[n_edges] = a
            edge_b[n_edges] = end
            n_edges += 1
            offsets[n_edges] = n_path
    # closed loops of inner pixels only
    for y in range(h):
        for x in range(w):
            if skel[y, x] == 0 or node_id[y, x] >= 0 or visited[y, x]:
                continue
            n_path = _walk_loop(skel, visited, y, x, path_y, path_x, n_path)
            edge_a[n_edges] = -1
            edge_b[n_edges] = -1
            n_edges += 1
            offsets[n_edges] = n_path
    return (
        edge_a[:n_edges].copy(),
        edge_b[:n_edges].copy(),
        offsets[: n_edges + 1].copy(),
        path_y[:n_path].copy(),
        path_x[:n_path].copy(),
    )


@njit(cache=True)
def _walk_to_node(skel, node_id, visited, py, px, qy, qx, path_y, path_x, n_path):
    """Walk from node pixel ``(py, px)`` through the inner pixels from ``(qy, qx)`` until the
    next node pixel, appending them to the path arrays from ``n_path``; returns (the node
    reached or -1, the new path length)."""
    h, w = skel.shape
    prev_y = py
    prev_x = px
    cy = qy
    cx = qx
    end = -1
    while True:
        visited[cy, cx] = 1
        path_y[n_path] = cy
        path_x[n_path] = cx
        n_path += 1
        ny = -1
        nx = -1
        for kk in range(8):
            yy = cy + _DY[kk]
            xx = cx + _DX[kk]
            if yy < 0 or yy >= h or xx < 0 or xx >= w or skel[yy, xx] == 0:
                continue
            if yy == prev_y and xx == prev_x:
                continue
            if node_id[yy, xx] >= 0:
                ny = yy  # a node pixel ends the edge
                nx = xx
                break
            elif visited[yy, xx] == 0:
                if ny < 0:
                    ny = yy
                    nx = xx
        if ny < 0:
            break
        if node_id[ny, nx] >= 0:
            end = node_id[ny, nx]
            break
        prev_y = cy
        prev_x = cx
        cy = ny
        cx = nx
    return end, n_path


@njit(cache=True)
def _walk_loop(skel, visited, y, x, path_y, path_x, n_path):
    """Walk a closed loop of inner pixels from ``(y, x)``, appending them to the path arrays
    from ``n_path``; returns the new path length."""
    h, w = skel.shape
    prev_y = -5
    prev_x = -5
    cy = y
    cx = x
    while True:
        visited[cy, cx] = 1
        path_y[n_path] = cy
        path_x[n_path] = cx
        n_path += 1
        ny = -1
        nx = -1
        for kk in range(8):
            yy = cy + _DY[kk]
            xx = cx + _DX[kk]
            if yy < 0 or yy >= h or xx < 0 or xx >= w or skel[yy, xx] == 0:
                continue
            if (yy == prev_y and xx == prev_x) or visited[yy, xx]:
                continue
            ny = yy
            nx = xx
            break
        if ny < 0:
            break
        prev_y = cy
        prev_x = cx
        cy = ny
        cx = nx
    return n_path


@njit(cache=True)
def valley_update(gxx, gyy, gxy, s2, damping, index, out, scale):
    """``r = s2 * (l1 - damping * max(l2, 0))`` of the Hessian eigenvalues ``l1 >= l2``; where
    ``r`` beats ``out``, store it there and ``index`` in ``scale``."""
    h, w = out.shape
    for y in range(h):
        for x in range(w):
            a = gxx[y, x]
            b = gyy[y, x]
            c = gxy[y, x]
            tr = 0.5 * (a + b)
            d = np.sqrt(0.25 * (a - b) * (a - b) + c * c)
            l2 = tr - d
            r = s2 * (tr + d - damping * max(l2, 0.0))
            if r > out[y, x]:
                out[y, x] = r
                scale[y, x] = index


@njit(cache=True)
def path_direction(xy, reach):
    """Unit vector from the first point of a path to its point ``reach`` along it."""
    s = 0.0
    i = 0
    n = xy.shape[0]
    while i < n - 1 and s < reach:
        dx = xy[i + 1, 0] - xy[i, 0]
        dy = xy[i + 1, 1] - xy[i, 1]
        s += np.sqrt(dx * dx + dy * dy)
        i += 1
    dx = xy[i, 0] - xy[0, 0]
    dy = xy[i, 1] - xy[0, 1]
    nrm = np.sqrt(dx * dx + dy * dy)
    out = np.zeros(2)
    if nrm > 0:
        out[0] = dx / nrm
        out[1] = dy / nrm
    return out


@njit(cache=True)
def arc_length(xy):
    """Length of a polyline."""
    s = 0.0
    for i in range(xy.shape[0] - 1):
        dx = xy[i + 1, 0] - xy[i, 0]
        dy = xy[i + 1, 1] - xy[i, 1]
        s += np.sqrt(dx * dx + dy * dy)
    return s


@njit(cache=True)
def _gauss_run(v, sigma, anchor):
    n = v.shape[0]
    rad = min(int(np.ceil(3.0 * sigma)), n - 1)
    k = np.empty(2 * rad + 1)
    tot = 0.0
    for i in range(-rad, rad + 1):
        k[i + rad] = np.exp(-0.5 * (i / sigma) ** 2)
        tot += k[i + rad]
    out = np.empty(n)
    for i in range(n):
        acc = 0.0
        for j in range(-rad, rad + 1):
            t = i + j
            if t < 0:
                val = 2.0 * v[0] - v[-t] if anchor else v[-t]
            elif t >= n:
                m = 2 * (n - 1) - t
                val = 2.0 * v[n - 1] - v[m] if anchor else v[m]
            else:
                val = v[t]
            acc += k[j + rad] * val
        out[i] = acc / tot
    return out


@njit(cache=True)
def smooth_path(xy, r, sigma_xy, sigma_r):
    """Gaussian smoothing of a path's points (odd reflection at the ends, so the end points stay
    put) and of its thickness (even reflection); thickness stays >= 0.5."""
    n = xy.shape[0]
    out = xy.copy()
    rr = r.copy()
    if n < 4:
        return out, rr
    out[:, 0] = _gauss_run(np.ascontiguousarray(xy[:, 0]), sigma_xy, True)
    out[:, 1] = _gauss_run(np.ascontiguousarray(xy[:, 1]), sigma_xy, True)
    out[0] = xy[0]
    out[n - 1] = xy[n - 1]
    rr = _gauss_run(r, sigma_r, False)
    for i in range(n):
        if rr[i] < 0.5:
            rr[i] = 0.5
    return out, rr


@njit(cache=True)
def flatten_ends(xy, r, reach0, reach1):
    """Near a junction the distance transform sees the junction's blob: the thickness within
    ``reach0`` of the start (``reach1`` of the end) takes the value just beyond it (``reach <=
    0``: leave that end alone). Paths shorter than both reaches are left as they are."""
    n = xy.shape[0]
    out = r.copy()
    s = np.zeros(n)
    for i in range(n - 1):
        dx = xy[i + 1, 0] - xy[i, 0]
        dy = xy[i + 1, 1] - xy[i, 1]
        s[i + 1] = s[i] + np.sqrt(dx * dx + dy * dy)
    total = s[n - 1]
    if reach0 > 0:
        i = 0
        while i < n and s[i] < reach0:
            i += 1
        if 0 < i < n:
            for j in range(i):
                out[j] = r[i]
    if reach1 > 0:
        i = n - 1
        while i >= 0 and s[i] > total - reach1:
            i -= 1
        if 0 <= i < n - 1:
            for j in range(i + 1, n):
                out[j] = r[i]
    return out
