"""Numba kernels of the fragment-based synthesis (sibbing2010 §5.2-5.3): colour costs of the
candidates, the smooth displacement field, source sampling, the graph-cut set-up and the
harmonic colour offset of the photometric correction."""

from __future__ import annotations

import numba as nb
import numpy as np

#: the photometric correction works on log(value + LOG_BIAS): a gain, not an offset, so that a
#: dark crack keeps its depth when the background around it is lifted or lowered
LOG_BIAS = 8.0
#: seam differences are clipped to +-LOG_CLIP (log units) before they are interpolated: the
#: correction is for the colour shift between fragments, not for the pixel noise of the texture
#: (whose outliers, a dark speck on one side of the seam, would otherwise tint the fragment)
LOG_CLIP = 0.5


@nb.njit
def _window_mean(values, fixed, i, j, r, acc):
    """Mean of ``values`` over the fixed pixels within ``r`` of ``(i, j)`` into ``acc``."""
    h, w, c = values.shape
    acc[:] = 0.0
    n = 0
    for ii in range(max(i - r, 0), min(i + r + 1, h)):
        for jj in range(max(j - r, 0), min(j + r + 1, w)):
            if fixed[ii, jj]:
                for ch in range(c):
                    acc[ch] += values[ii, jj, ch]
                n += 1
    for ch in range(c):
        acc[ch] /= max(n, 1)


@nb.njit(cache=True)
def harmonic_offset(inside, fixed, boundary, tol, max_iter, smooth):
    """Harmonic interpolation of a colour offset (Poisson photometric correction, §5.3).

    ``inside`` (h, w) bool marks the unknown pixels; a neighbour outside the region with
    ``fixed`` holds the Dirichlet value ``boundary`` (h, w, C): the seam difference where the
    pixel has old content, 0 where it has none (no colour shift where the fragment touches
    nothing placed before), averaged over the fixed pixels of the ``smooth`` square window
    around it and clipped to +-``LOG_CLIP``. A neighbour that is not fixed (a crack edge, where
    old and new are expected to differ) and pixels outside the box are not neighbours (Neumann).
    Solved by successive over-relaxation from the mean of the fixed values next to the region.
    Returns the (h, w, C) offset of the region's pixels (0 elsewhere).
    """
    h, w, c = boundary.shape
    off = np.zeros((h, w, c), np.float32)
    index = np.full((h, w), -1, np.int64)
    n = 0
    for i in range(h):
        for j in range(w):
            if inside[i, j]:
                index[i, j] = n
                n += 1
    if n == 0:
        return off
    # per unknown: its unknown neighbours, its count of neighbours, the sum of its fixed ones
    nbr = np.full((n, 4), -1, np.int64)
    cnt = np.zeros(n, np.int64)
    fsum = np.zeros((n, c), np.float64)
    ys = np.empty(n, np.int64)
    xs = np.empty(n, np.int64)
    mean = np.zeros(c, np.float64)
    acc = np.zeros(c, np.float64)
    n_fixed = 0
    for i in range(h):
        for j in range(w):
            t = index[i, j]
            if t < 0:
                continue
            ys[t] = i
            xs[t] = j
            u = 0
            for k in range(4):
                ii = i + (1 if k == 0 else (-1 if k == 1 else 0))
                jj = j + (1 if k == 2 else (-1 if k == 3 else 0))
                if ii < 0 or ii >= h or jj < 0 or jj >= w:
                    continue
                if inside[ii, jj]:
                    nbr[t, u] = index[ii, jj]
                    u += 1
                    cnt[t] += 1
                elif fixed[ii, jj]:
                    cnt[t] += 1
                    n_fixed += 1
                    _window_mean(boundary, fixed, ii, jj, smooth // 2, acc)
                    for ch in range(c):
                        v = min(max(acc[ch], -LOG_CLIP), LOG_CLIP)
                        fsum[t, ch] += v
                        mean[ch] += v
    if n_fixed == 0:
        return off
    val = np.empty((n, c), np.float64)
    for t in range(n):
        for ch in range(c):
            val[t, ch] = mean[ch] / n_fixed
    # over-relaxation factor for a region of this size (optimal for a square of side sqrt(n))
    side = max(np.sqrt(n), 2.0)
    omega = 2.0 / (1.0 + np.sin(np.pi / (side + 1.0)))
    inv = np.zeros(n)
    for t in range(n):
        if cnt[t] > 0:
            inv[t] = omega / cnt[t]
    for _ in range(max_iter):
        change = 0.0
        for t in range(n):
            if cnt[t] == 0:
                continue
            f = inv[t]
            for ch in range(c):
                s = fsum[t, ch]
                for k in range(4):
                    q = nbr[t, k]
                    if q < 0:
                        break
                    s += val[q, ch]
                delta = f * s - omega * val[t, ch]
                val[t, ch] += delta
                if abs(delta) > change:
                    change = abs(delta)
        if change < tol:
            break
    for t in range(n):
        for ch in range(c):
            off[ys[t], xs[t], ch] = val[t, ch]
    return off


@nb.njit(cache=True)
def source_map(x0, y0, h, w, cx, cy, zx, zy, rc, rs, field):
    """Source coordinates of the ``h x w`` box at ``(x0, y0)``: the target pixel ``x`` reads
    the source at ``z + R^T (x - c + d(x))`` (R = rotation ``(rc, rs)``, d the complex
    displacement ``field``); two float32 maps for ``cv2.remap``."""
    mapx = np.empty((h, w), np.float32)
    mapy = np.empty((h, w), np.float32)
    for i in range(h):
        for j in range(w):
            d = field[i, j]
            ux = x0 + j - cx + d.real
            uy = y0 + i - cy + d.imag
            mapx[i, j] = zx + rc * ux + rs * uy
            mapy[i, j] = zy - rs * ux + rc * uy
    return mapx, mapy


@nb.njit(cache=True)
def own_distance(x0, y0, h, w, px, py, pt, ok):
    """Distance of each pixel of the ``h x w`` box at ``(x0, y0)`` to the polyline ``(px, py)``
    (segments whose both ends have ``ok``) and the half-width ``pt`` interpolated at the nearest
    point (+inf and 0 where no segment counts)."""
    dist = np.full((h, w), np.inf)
    thick = np.zeros((h, w))
    for s in range(px.shape[0] - 1):
        if not (ok[s] and ok[s + 1]):
            continue
        ax = px[s]
        ay = py[s]
        dx = px[s + 1] - ax
        dy = py[s + 1] - ay
        ll = max(dx * dx + dy * dy, 1e-12)
        ta = pt[s]
        tb = pt[s + 1]
        for i in range(h):
            y = y0 + i
            for j in range(w):
                x = x0 + j
                u = min(max(((x - ax) * dx + (y - ay) * dy) / ll, 0.0), 1.0)
                ex = ax + u * dx - x
                ey = ay + u * dy - y
                d = ex * ex + ey * ey
                if d < dist[i, j]:
                    dist[i, j] = d
                    thick[i, j] = ta + u * (tb - ta)
    return np.sqrt(dist), thick


@nb.njit(cache=True)
def sample_nearest(src, mapx, mapy, tdist, tthick, spx, spy, spt, sok, margin):
    """``src`` (H, W, C) float32 read at the nearest pixel of each map position (clamped).

    On the fragment's own crack (pixels within the local half-width ``tthick`` + ``margin`` of
    the target skeleton, ``tdist`` away from it) the pixel is instead the one of the 3 x 3
    around the map position whose distance to the source polyline ``sp*`` is closest to the
    target pixel's distance to its skeleton (ties to the nearest): the crack's dark core lands
    on the target skeleton, not up to a pixel beside it as plain rounding (of the target's
    raster and of the map) would put it.
    """
    h, w = mapx.shape
    hs, ws, c = src.shape
    out = np.empty((h, w, c), np.float32)
    # the source pixels' distances to the polyline, computed once each (neighbouring target
    # pixels share most of their 3 x 3 candidates): a lazy table over the map's bounding box
    lo_x, lo_y, hi_x, hi_y = ws, hs, -1, -1
    for i in range(h):
        for j in range(w):
            x = min(max(int(np.floor(mapx[i, j] + 0.5)), 0), ws - 1)
            y = min(max(int(np.floor(mapy[i, j] + 0.5)), 0), hs - 1)
            lo_x = min(lo_x, x)
            hi_x = max(hi_x, x)
            lo_y = min(lo_y, y)
            hi_y = max(hi_y, y)
    lo_x = max(lo_x - 1, 0)
    lo_y = max(lo_y - 1, 0)
    table = np.full((max(hi_y + 2 - lo_y, 1), max(hi_x + 2 - lo_x, 1)), -1.0)
    for i in range(h):
        for j in range(w):
            mx = mapx[i, j]
            my = mapy[i, j]
            x = min(max(int(np.floor(mx + 0.5)), 0), ws - 1)
            y = min(max(int(np.floor(my + 0.5)), 0), hs - 1)
            dt = tdist[i, j]
            if dt <= tthick[i, j] + margin:
                best = np.inf
                bx = x
                by = y
                for dy in range(-1, 2):
                    for dx in range(-1, 2):
                        cx = min(max(x + dx, 0), ws - 1)
                        cy = min(max(y + dy, 0), hs - 1)
                        ds = table[cy - lo_y, cx - lo_x]
                        if ds < 0.0:
                            ds, _ = _poly_nearest(cx, cy, spx, spy, spt, sok)
                            table[cy - lo_y, cx - lo_x] = ds
                        e = (ds - dt) * (ds - dt) + 0.25 * ((cx - mx) * (cx - mx) + (cy - my) * (cy - my))
                        if e < best:
                            best = e
                            bx = cx
                            by = cy
                x = bx
                y = by
            for ch in range(c):
                out[i, j, ch] = src[y, x, ch]
    return out


@nb.njit
def _segment_projection(x, y, px, py, s):
    """Distance of ``(x, y)`` to segment ``s`` of the polyline and the position ``u`` in [0, 1]
    of its nearest point along the segment."""
    ax = px[s]
    ay = py[s]
    dx = px[s + 1] - ax
    dy = py[s + 1] - ay
    ll = dx * dx + dy * dy
    u = 0.0
    if ll > 1e-12:
        u = ((x - ax) * dx + (y - ay) * dy) / ll
        u = min(max(u, 0.0), 1.0)
    ex = ax + u * dx - x
    ey = ay + u * dy - y
    return np.sqrt(ex * ex + ey * ey), u


@nb.njit
def _poly_nearest(x, y, px, py, pt, ok):
    """Distance of ``(x, y)`` to the polyline and the half-width interpolated there."""
    best = np.inf
    thick = 0.0
    for s in range(px.shape[0] - 1):
        if not (ok[s] and ok[s + 1]):
            continue
        d, u = _segment_projection(x, y, px, py, s)
        if d < best:
            best = d
            thick = pt[s] + u * (pt[s + 1] - pt[s])
    return best, thick


@nb.njit
def _poly_distance(x, y, px, py, pt, ok):
    """Distance of ``(x, y)`` to the polyline's body (distance minus the half-width)."""
    best = np.inf
    for s in range(px.shape[0] - 1):
        if not (ok[s] and ok[s + 1]):
            continue
        d, u = _segment_projection(x, y, px, py, s)
        d -= pt[s] + u * (pt[s + 1] - pt[s])
        if d < best:
            best = d
    return best


@nb.njit(cache=True)
def seam_setup(corner, new, maps, layers, cracks, disk, own_target, own_source, margins):
    """Constraints and weights of the graph cut of one fragment (§5.3).

    Per pixel of the box at ``corner = (x0, y0)`` (``new``: the fragment's pixels, ``maps =
    (mapx, mapy)``: where they come from in the source): ``take`` (forced to the new fragment:
    its own crack, within ``own_margin`` of its edge, ``tdist - tthick`` away, empty canvas, the
    cleared centre of a junction within ``clear`` px), ``keep`` (forced to the old content:
    outside the disk, its rim, other cracks of the target, source cracks that are not the
    fragment's own polyline ``sp*``), the graph-cut weights of the edges to the right and down
    neighbours (the colour difference new/old at both ends, 0 where nothing is placed, +
    ``eps``), the Poisson boundary values (log ratio old / new where there is old content, else
    0), whether they hold, and the number of taken and of free pixels.

    ``layers = (canvas, content, coverage)``, ``cracks = (tgt_cracks, src_cracks)``, ``disk =
    (cx, cy, radius, clear)``, ``own_target = (tdist, tthick)`` (:func:`own_distance`),
    ``own_source = (spx, spy, spt, sok)``, ``margins = (own_margin, other_margin, eps)``.
    """
    x0, y0 = corner
    mapx, mapy = maps
    canvas, content, coverage = layers
    tgt_cracks, src_cracks = cracks
    cx, cy, radius, clear = disk
    tdist, tthick = own_target
    spx, spy, spt, sok = own_source
    own_margin, other_margin, eps = margins
    h, w, c = new.shape
    take = np.zeros((h, w), np.bool_)
    keep = np.zeros((h, w), np.bool_)
    diff = np.zeros((h, w), np.float64)
    boundary = np.zeros((h, w, c), np.float32)
    fixed = np.ones((h, w), np.bool_)
    hs, ws = src_cracks.shape
    r2 = radius * radius
    rim = (radius - 1.0) * (radius - 1.0)
    for i in range(h):
        y = y0 + i
        for j in range(w):
            x = x0 + j
            has = content[y, x]
            dd = (x - cx) * (x - cx) + (y - cy) * (y - cy)
            disk = dd <= r2
            sx = min(max(int(np.floor(mapx[i, j] + 0.5)), 0), ws - 1)
            sy = min(max(int(np.floor(mapy[i, j] + 0.5)), 0), hs - 1)
            foreign = False
            if src_cracks[sy, sx]:
                foreign = _poly_distance(mapx[i, j], mapy[i, j], spx, spy, spt, sok) > other_margin + 1
            t_own = tdist[i, j] - tthick[i, j]
            other = tgt_cracks[y, x] and t_own > other_margin + 1
            tk = disk and (t_own <= own_margin or (not has and not foreign))
            if disk and not tk and clear > 0 and dd <= clear * clear and not foreign and not other:
                tk = True
            take[i, j] = tk
            keep[i, j] = has and not tk and ((not disk) or dd > rim or other or foreign)
            # the seam difference does not hold across the edge of another crack (old and new
            # differ by design) nor on cracks that only the fill has painted so far (lighter
            # than the photo's: they would lift the new crack)
            fixed[i, j] = not (has and (other or foreign or (tgt_cracks[y, x] and not coverage[y, x])))
            if has:
                s = 0.0
                for ch in range(c):
                    e = canvas[y, x, ch] - new[i, j, ch]
                    boundary[i, j, ch] = np.log((canvas[y, x, ch] + LOG_BIAS) / (new[i, j, ch] + LOG_BIAS))
                    s += e * e
                diff[i, j] = np.sqrt(s)
    # graph-cut edge weights (Kwatra et al. 2003): |new - old| at both ends, + eps
    right = np.full((h, w), eps)
    down = np.full((h, w), eps)
    n_take = 0
    n_free = 0
    for i in range(h):
        for j in range(w):
            if j + 1 < w:
                right[i, j] += diff[i, j] + diff[i, j + 1]
            if i + 1 < h:
                down[i, j] += diff[i, j] + diff[i + 1, j]
            if take[i, j]:
                n_take += 1
            elif not keep[i, j]:
                n_free += 1
    return take, keep, right, down, boundary, fixed, n_take, n_free


@nb.njit(cache=True)
def blend(corner, newmask, new, fixed, boundary, layers, fragment_map, index, poisson):
    """Poisson photometric correction of the new pixels (harmonic offset of the log values, see
    :func:`harmonic_offset`: a smooth gain, ``poisson = (tol, max_iter, smooth)``) and their
    write into the canvas (``layers = (canvas, content, coverage)``) at ``corner = (x0, y0)``,
    ``index`` into ``fragment_map``."""
    x0, y0 = corner
    canvas, content, coverage = layers
    tol, max_iter, smooth = poisson
    off = harmonic_offset(newmask, fixed, boundary, tol, max_iter, smooth)
    h, w, c = new.shape
    for i in range(h):
        for j in range(w):
            if newmask[i, j]:
                for ch in range(c):
                    canvas[y0 + i, x0 + j, ch] = (new[i, j, ch] + LOG_BIAS) * np.exp(off[i, j, ch]) - LOG_BIAS
                content[y0 + i, x0 + j] = True
                coverage[y0 + i, x0 + j] = True
                fragment_map[y0 + i, x0 + j] = index


@nb.njit
def _apply_constraints(idx, wt, mat):
    """``B @ mat`` for the bilinear constraint matrix ``B`` (row ``l``: weights ``wt[l]`` on
    the grid nodes ``idx[l]``), as ``(k, mat.shape[1])``."""
    k = idx.shape[0]
    out = np.zeros((k, mat.shape[1]))
    for l in range(k):
        for c in range(4):
            row = idx[l, c]
            a = wt[l, c]
            for j in range(mat.shape[1]):
                out[l, j] += a * mat[row, j]
    return out


@nb.njit(cache=True)
def warp_field(green, m, half, qx, qy, vx, vy, i0, i1, j0, j1):
    """The smooth displacement of one fragment (§5.3) on rows ``i0:i1``, columns ``j0:j1`` of
    its ``(2 half + 1)^2`` box (complex128).

    ``green = (L^T L + eps I)^-1`` of the ``m x m`` grid scaled onto the box; the field on the
    grid nodes is the minimiser of ``d^T (L^T L + eps I) d`` that interpolates the vectors
    ``(vx, vy)`` at the points ``(qx, qy)`` (box pixel coordinates, bilinear constraints):
    ``d = G B^T (B G B^T)^-1 v``; it is read at the pixels bilinearly.
    """
    k = qx.shape[0]
    h = i1 - i0
    w = j1 - j0
    out = np.zeros((h, w), np.complex128)
    if k == 0:
        return out
    scale = (m - 1) / (2.0 * half)
    idx = np.empty((k, 4), np.int64)
    wt = np.empty((k, 4), np.float64)
    for l in range(k):
        gx = min(max(qx[l] * scale, 0.0), m - 1 - 1e-9)
        gy = min(max(qy[l] * scale, 0.0), m - 1 - 1e-9)
        x0 = int(np.floor(gx))
        y0 = int(np.floor(gy))
        fx = gx - x0
        fy = gy - y0
        idx[l, 0] = y0 * m + x0
        idx[l, 1] = y0 * m + x0 + 1
        idx[l, 2] = (y0 + 1) * m + x0
        idx[l, 3] = (y0 + 1) * m + x0 + 1
        wt[l, 0] = (1 - fx) * (1 - fy)
        wt[l, 1] = fx * (1 - fy)
        wt[l, 2] = (1 - fx) * fy
        wt[l, 3] = fx * fy
    gbt = np.ascontiguousarray(_apply_constraints(idx, wt, green.T).T)  # G B^T
    bgbt = _apply_constraints(idx, wt, gbt)  # B G B^T
    tr = 0.0
    for l in range(k):
        tr += bgbt[l, l]
    for l in range(k):
        bgbt[l, l] += 1e-9 * tr / k
    rhs = np.empty((k, 2))
    for l in range(k):
        rhs[l, 0] = vx[l]
        rhs[l, 1] = vy[l]
    lam = np.linalg.solve(bgbt, rhs)
    nodes = gbt @ lam
    for i in range(h):
        gy = min((i0 + i) * scale, m - 1 - 1e-9)
        y0 = int(np.floor(gy))
        fy = gy - y0
        for j in range(w):
            gx = min((j0 + j) * scale, m - 1 - 1e-9)
            x0 = int(np.floor(gx))
            fx = gx - x0
            a = y0 * m + x0
            b = (y0 + 1) * m + x0
            dx = (
                (1 - fx) * (1 - fy) * nodes[a, 0]
                + fx * (1 - fy) * nodes[a + 1, 0]
                + (1 - fx) * fy * nodes[b, 0]
                + fx * fy * nodes[b + 1, 0]
            )
            dy = (
                (1 - fx) * (1 - fy) * nodes[a, 1]
                + fx * (1 - fy) * nodes[a + 1, 1]
                + (1 - fx) * fy * nodes[b, 1]
                + fx * fy * nodes[b + 1, 1]
            )
            out[i, j] = complex(dx, dy)
    return out


@nb.njit(cache=True)
def colour_costs(src, layers, tgt_cracks, probes, placements):
    """Colour consistency of candidate placements (§5.2): mean over the probe pixels
    ``(tx, ty)`` of the canvas that hold content of the squared colour difference to the source
    pixel each candidate (centre ``(zx, zy)``, rotation ``(rc, rs)``) puts there; the probes
    are at offsets ``(ox, oy)`` from the target centre (nearest pixels, rigid placement).
    Probes on cracks that only the fill has painted do not count (its cracks are fainter than
    the photo's: they would favour fragments with faint cracks).

    ``layers = (canvas, content, coverage)``, ``probes = (tx, ty, ox, oy)``, ``placements =
    (zx, zy, rc, rs)``."""
    canvas, content, coverage = layers
    tx, ty, ox, oy = probes
    zx, zy, rc, rs = placements
    hs, ws, c = src.shape
    h, w = content.shape
    m = zx.shape[0]
    out = np.zeros(m)
    for a in range(m):
        s = 0.0
        cnt = 0
        for p in range(tx.shape[0]):
            x = tx[p]
            y = ty[p]
            if x < 0 or y < 0 or x >= w or y >= h or not content[y, x]:
                continue
            if tgt_cracks[y, x] and not coverage[y, x]:
                continue
            sx = zx[a] + rc[a] * ox[p] + rs[a] * oy[p]
            sy = zy[a] - rs[a] * ox[p] + rc[a] * oy[p]
            ix = min(max(int(np.floor(sx + 0.5)), 0), ws - 1)
            iy = min(max(int(np.floor(sy + 0.5)), 0), hs - 1)
            for ch in range(c):
                e = src[iy, ix, ch] - canvas[y, x, ch]
                s += e * e
            cnt += 1
        out[a] = s / cnt if cnt > 0 else 0.0
    return out


@nb.njit(cache=True, fastmath=True, parallel=True)
def shape_costs(pre, pim, mu, border, qre, qim, nu, weight, omega_s, limit, margin):
    """Shape cost S of eq. 1 for every source fragment row (positions ``pre + i pim``,
    half-widths ``mu``) against one target fragment (``q``, ``nu``, per-sample ``weight``),
    after the closed-form rotation about the centres (2-D Procrustes: the argument of
    ``z = sum w conj(p) q``, clamped to +-``limit`` radians). Rows whose centre is nearer than
    ``margin`` to the photo border cost +inf. Returns the costs and ``z`` (real, imaginary)."""
    n, k = pre.shape
    cost = np.empty(n)
    zre = np.empty(n)
    zim = np.empty(n)
    qq = 0.0
    for l in range(k):
        qq += weight[l] * (qre[l] * qre[l] + qim[l] * qim[l])
    cos_limit = np.cos(min(limit, np.pi))
    sin_limit = np.sin(min(limit, np.pi))
    for r in nb.prange(n):
        a = 0.0
        b = 0.0
        pp = 0.0
        tt = 0.0
        for l in range(k):
            wl = weight[l]
            x = pre[r, l]
            y = pim[r, l]
            # conj(p) q = (x q_re + y q_im) + i (x q_im - y q_re)
            a += wl * (x * qre[l] + y * qim[l])
            b += wl * (x * qim[l] - y * qre[l])
            pp += wl * (x * x + y * y)
            d = mu[r, l] - nu[l]
            tt += wl * d * d
        zre[r] = a
        zim[r] = b
        mag = np.sqrt(a * a + b * b)
        if limit < np.pi and a < mag * cos_limit:
            # the angle |arg z| exceeds the limit: mag cos(|arg z| - limit), without trigonometry
            mag = a * cos_limit + abs(b) * sin_limit
        c = max(pp + qq - 2.0 * mag, 0.0) + omega_s * tt
        cost[r] = c if border[r] >= margin else np.inf
    return cost, zre, zim


@nb.njit(cache=True)
def arc_setup(points):
    """A polyline's arc-length parametrisation: the arc position of every vertex; the first
    vertex and every vertex more than 1e-9 px from the one before as ``s, x, y, half-width``;
    the unit tangents at both ends (``(1, 0)`` for a single vertex)."""
    n = points.shape[0]
    vertex_arc = np.zeros(n)
    keep = np.ones(n, np.bool_)
    for i in range(1, n):
        seg = np.hypot(points[i, 0] - points[i - 1, 0], points[i, 1] - points[i - 1, 1])
        vertex_arc[i] = vertex_arc[i - 1] + seg
        keep[i] = seg > 1e-9
    m = 0
    for i in range(n):
        m += keep[i]
    s = np.empty(m)
    px = np.empty(m)
    py = np.empty(m)
    pt = np.empty(m)
    m = 0
    for i in range(n):
        if keep[i]:
            s[m] = vertex_arc[i]
            px[m] = points[i, 0]
            py[m] = points[i, 1]
            pt[m] = points[i, 2]
            m += 1
    t0 = np.array([1.0, 0.0])
    t1 = np.array([1.0, 0.0])
    if m >= 2:
        dx = px[1] - px[0]
        dy = py[1] - py[0]
        d = np.hypot(dx, dy)
        t0[0] = dx / d
        t0[1] = dy / d
        dx = px[m - 1] - px[m - 2]
        dy = py[m - 1] - py[m - 2]
        d = np.hypot(dx, dy)
        t1[0] = dx / d
        t1[1] = dy / d
    return vertex_arc, s, px, py, pt, t0, t1


@nb.njit(cache=True)
def arc_sample(arc, t):
    """A branch at arc positions ``t``: ``x, y, half-width, on-branch`` (beyond an end it goes on
    along the end tangent ``t0`` / ``t1``, half-width 0 at a free end, the end's where the end is
    connected). ``arc`` is ``(s, px, py, pt, t0, t1, start_connected, end_connected)``: the arc
    position, x, y and half-width of the vertices, the unit end tangents and the end links."""
    s, px, py, pt, t0, t1, start_connected, end_connected = arc
    t0x, t0y, t1x, t1y = t0[0], t0[1], t1[0], t1[1]
    n = t.shape[0]
    x = np.interp(t, s, px)
    y = np.interp(t, s, py)
    th = np.interp(t, s, pt)
    real = np.ones(n, np.bool_)
    length = s[-1]
    last = s.shape[0] - 1
    for i in range(n):
        if t[i] < 0.0:
            x[i] = px[0] + t[i] * t0x
            y[i] = py[0] + t[i] * t0y
            if not start_connected:
                th[i] = 0.0
            real[i] = False
        elif t[i] > length:
            x[i] = px[last] + (t[i] - length) * t1x
            y[i] = py[last] + (t[i] - length) * t1y
            if not end_connected:
                th[i] = 0.0
            real[i] = False
    return x, y, th, real


@nb.njit(cache=True)
def fragment_centres(s, pt, t0, r_before, lam, radius_rule):
    """Arc positions of fragment centres along a branch (§5.1): from ``t0`` (or one spacing
    after a fragment of radius ``r_before`` at ``t0`` when it is > 0), ``lam (s_i + s_{i+1})``
    apart with ``s = clip(factor x half-width, rmin, rmax)`` (``radius_rule = (factor, rmin,
    rmax)``), the last at the end when the one before leaves the tail uncovered."""
    factor, rmin, rmax = radius_rule
    length = s[-1]
    out = np.empty(int(length / (2 * lam * rmin)) + 4)
    n = 0
    t = t0
    if r_before > 0.0:
        r = r_before
    else:
        r = min(max(factor * np.interp(t, s, pt), rmin), rmax)
        out[n] = t
        n += 1
    while True:
        nxt = t + 2 * lam * r
        for _ in range(2):
            rn = min(max(factor * np.interp(min(nxt, length), s, pt), rmin), rmax)
            nxt = t + lam * (r + rn)
        if nxt >= length:
            if length - t > 0.5 * lam * r or n == 0:
                out[n] = length
                n += 1
            break
        t = nxt
        r = min(max(factor * np.interp(t, s, pt), rmin), rmax)
        if n >= out.shape[0]:
            break
        out[n] = t
        n += 1
    return out[:n]


@nb.njit(cache=True)
def regular_samples(arc, t, k, radius_rule):
    """Regular fragments (§5.1) centred at arc positions ``t`` of one branch (``arc``, see
    :func:`arc_sample`): their radii (``factor`` x the half-width, clamped to ``[rmin, rmax]``;
    ``radius_rule = (factor, rmin, rmax)``), centres and ``k`` skeleton samples at arc offsets
    ``-r .. r``. Returns ``r, cx, cy`` (n,) and ``x, y, half-width, on-branch`` (n, k)."""
    factor, rmin, rmax = radius_rule
    s = arc[0]
    pt = arc[3]
    n = t.shape[0]
    r = np.empty(n)
    q = np.empty(n * (k + 1))
    for i in range(n):
        r[i] = min(max(factor * np.interp(t[i], s, pt), rmin), rmax)
        q[i] = t[i]
        for j in range(k):
            q[n + i * k + j] = t[i] + r[i] * (-1.0 + 2.0 * j / (k - 1))
    x, y, th, real = arc_sample(arc, q)
    return (
        r,
        x[:n].copy(),
        y[:n].copy(),
        x[n:].reshape(n, k),
        y[n:].reshape(n, k),
        th[n:].reshape(n, k),
        real[n:].reshape(n, k),
    )


@nb.njit(cache=True)
def junction_samples(parent, a, child, child_reversed, k, radius_rule):
    """A junction fragment (§5.1) at arc position ``a`` of a ``parent`` branch: its radius (the
    larger of the parent's and the child's regular radius there; ``radius_rule = (factor, rmin,
    rmax)``), centre, the ``k`` parent samples at offsets ``-r .. r`` and ``k`` samples along the
    ``child`` going away from the junction (from the child's end when ``child_reversed``); both
    branches as in :func:`arc_sample`. Returns ``r, cx, cy`` and the parent's and the child's
    ``x, y, half-width, on-branch``."""
    factor, rmin, rmax = radius_rule
    ps = parent[0]
    ppt = parent[3]
    cs = child[0]
    cpt = child[3]
    c_len = cs[-1]
    rp = min(max(factor * np.interp(a, ps, ppt), rmin), rmax)
    rc = min(max(factor * np.interp(c_len if child_reversed else 0.0, cs, cpt), rmin), rmax)
    r = max(rp, rc)
    q = np.empty(k + 1)
    q[0] = a
    for j in range(k):
        q[j + 1] = a + r * (-1.0 + 2.0 * j / (k - 1))
    px, py, pth, preal = arc_sample(parent, q)
    steps = np.empty(k)
    for j in range(k):
        steps[j] = r * (j + 1) / k
        if child_reversed:
            steps[j] = c_len - steps[j]
    qx, qy, qth, qreal = arc_sample(child, steps)
    return r, px[0], py[0], px[1:], py[1:], pth[1:], preal[1:], qx, qy, qth, qreal


@nb.njit(cache=True)
def compose_setup(src, maps, given, use_given, corner, layers, cracks, disk, own_target, own_source, margins):
    """Everything of one fragment's composition before the graph cut: the distances to its
    target skeleton ``own_target = (tpx, tpy, tpt, tok)`` (:func:`own_distance`), its pixels
    (``given``, or read by :func:`sample_nearest` at ``maps = (mapx, mapy)``), the set-up of
    :func:`seam_setup` (which explains ``corner``, ``layers``, ``cracks``, ``disk``,
    ``own_source`` and ``margins``) and the cut's graph on the free pixels
    (:func:`seam_graph`)."""
    x0, y0 = corner
    mapx, mapy = maps
    tpx, tpy, tpt, tok = own_target
    spx, spy, spt, sok = own_source
    own_margin = margins[0]
    h, w = mapx.shape
    tdist, tthick = own_distance(x0, y0, h, w, tpx, tpy, tpt, tok)
    if use_given:
        new = given
    else:
        new = sample_nearest(src, mapx, mapy, tdist, tthick, spx, spy, spt, sok, own_margin)
    take, keep, right, down, boundary, fixed, n_take, n_free = seam_setup(
        corner, new, maps, layers, cracks, disk, (tdist, tthick), own_source, margins
    )
    free, ei, ej, cap, src_caps, sink_caps = seam_graph(take, keep, right, down, n_free)
    return new, take, free, ei, ej, cap, src_caps, sink_caps, boundary, fixed, n_take


@nb.njit(cache=True)
def seam_graph(take, keep, right, down, n_free):
    """The graph cut of one fragment reduced to its free pixels (neither ``take`` nor
    ``keep``): their flat indices, the edges between two free pixels (node pairs and
    capacity, the same both ways) and each node's terminal capacities, the summed weights of
    its edges to pixels tied to the new fragment (source) or to the old content (sink). The
    minimum cut is that of the whole grid with the tied pixels as terminals."""
    h, w = take.shape
    node = np.full((h, w), -1, np.int64)
    free = np.empty(n_free, np.int64)
    n = 0
    for i in range(h):
        for j in range(w):
            if not take[i, j] and not keep[i, j]:
                node[i, j] = n
                free[n] = i * w + j
                n += 1
    src_caps = np.zeros(n)
    sink_caps = np.zeros(n)
    ei = np.empty(2 * n, np.int64)
    ej = np.empty(2 * n, np.int64)
    cap = np.empty(2 * n)
    m = 0
    for i in range(h):
        for j in range(w):
            for d in range(2):  # the edge to the right, then the one down
                i2 = i + d
                j2 = j + 1 - d
                if i2 >= h or j2 >= w:
                    continue
                c = right[i, j] if d == 0 else down[i, j]
                a = node[i, j]
                b = node[i2, j2]
                if a >= 0 and b >= 0:
                    ei[m] = a
                    ej[m] = b
                    cap[m] = c
                    m += 1
                elif a >= 0 or b >= 0:
                    u = a if a >= 0 else b
                    other_i = i2 if a >= 0 else i
                    other_j = j2 if a >= 0 else j
                    if take[other_i, other_j]:
                        src_caps[u] += c
                    else:
                        sink_caps[u] += c
    return free, ei[:m], ej[:m], cap[:m], src_caps, sink_caps


@nb.njit(cache=True)
def select_candidates(bank, target, weights, margin, m, src, layers, tgt_cracks, disk, ring):
    """§5.2 for one target fragment: the ``m`` source rows (forward rows, then reversed ones,
    of ``n`` fragments) of lowest shape cost S (:func:`shape_costs`), their rotation (clamped
    to ``limit``) and their total cost ``S + omega_c C`` (:func:`colour_costs` on the probe
    rings ``radius x ring`` around the target centre ``(cx, cy)``; ``omega_c`` already holds the
    colour normalisation). Returns rows, totals and rotations (re, im); no
    rows when no source fragment is farther than ``margin`` from the border.

    ``bank = (pre, pim, mu, border, cre, cim)``: the source rows' sample positions and
    half-widths, their centres' distance to the border (per row) and the fragments' centres
    (per fragment); ``target = (qre, qim, nu, weight)``; ``weights = (omega_s, limit,
    omega_c)``; ``layers = (canvas, content, coverage)``; ``disk = (cx, cy, radius)``; ``ring
    = (ring_re, ring_im)``."""
    pre, pim, mu, border, cre, cim = bank
    qre, qim, nu, weight = target
    omega_s, limit, omega_c = weights
    cx, cy, radius = disk
    ring_re, ring_im = ring
    cost, zre, zim = shape_costs(pre, pim, mu, border, qre, qim, nu, weight, omega_s, limit, margin)
    n_rows = cost.shape[0]
    n = n_rows // 2
    m = min(m, n_rows)
    best = np.full(m, np.inf)
    rows = np.full(m, -1, np.int64)
    for r in range(n_rows):
        c = cost[r]
        if c < best[m - 1]:
            k = m - 1
            while k > 0 and best[k - 1] > c:
                best[k] = best[k - 1]
                rows[k] = rows[k - 1]
                k -= 1
            best[k] = c
            rows[k] = r
    cnt = 0
    for k in range(m):
        if rows[k] >= 0:
            cnt += 1
    rows = rows[:cnt]
    best = best[:cnt]
    rc = np.empty(cnt)
    rs = np.empty(cnt)
    zx = np.empty(cnt)
    zy = np.empty(cnt)
    for k in range(cnt):
        r = rows[k]
        ang = np.arctan2(zim[r], zre[r]) if (zre[r] != 0.0 or zim[r] != 0.0) else 0.0
        ang = min(max(ang, -limit), limit)
        rc[k] = np.cos(ang)
        rs[k] = np.sin(ang)
        zx[k] = cre[r % n]
        zy[k] = cim[r % n]
    ox = radius * ring_re
    oy = radius * ring_im
    tx = np.empty(ox.shape[0], np.int64)
    ty = np.empty(ox.shape[0], np.int64)
    for p in range(ox.shape[0]):
        tx[p] = int(np.floor(cx + ox[p] + 0.5))
        ty[p] = int(np.floor(cy + oy[p] + 0.5))
    colour = colour_costs(src, layers, tgt_cracks, (tx, ty, ox, oy), (zx, zy, rc, rs))
    total = best + omega_c * colour
    return rows, total, rc, rs


@nb.njit(cache=True)
def draw_candidate(total, c, u):
    """§5.2's random choice among the ``c`` lowest ``total`` costs (ties: the lower index),
    with probability proportional to ``1 / cost`` (regularised by 1e-6 of the best cost + 1),
    from the uniform number ``u``. Returns the index into ``total``; -1 when it is empty or
    holds a non-finite cost."""
    n = total.shape[0]
    if n == 0:
        return -1
    for i in range(n):
        if not np.isfinite(total[i]):
            return -1
    order = np.arange(n)
    for i in range(1, n):  # stable insertion sort (n <= shortlist)
        j = i
        while j > 0 and total[order[j - 1]] > total[order[j]]:
            order[j - 1], order[j] = order[j], order[j - 1]
            j -= 1
    c = min(c, n)
    reg = 1e-6 * (1.0 + total[order[0]])
    acc = np.empty(c)
    s = 0.0
    for i in range(c):
        s += 1.0 / (total[order[i]] + reg)
        acc[i] = s
    target = u * s
    for i in range(c):
        if acc[i] > target:
            return order[i]
    return order[c - 1]


@nb.njit(cache=True)
def fragment_maps(warp, disk, canvas_size, target_samples, source_samples, placement):
    """Where one target fragment reads the source (§5.3): the box around the fragment centre
    ``disk = (cx, cy, radius)`` (clipped to the ``canvas_size = (w_out, h_out)`` canvas), the
    smooth displacement (``warp = (green, m)``, :func:`warp_field`) that moves the rotated
    source samples ``f`` onto the target samples ``g`` (``target_samples = (gre, gim, greal)``,
    ``source_samples = (fre, fim, freal)``: positions relative to their centres and on-branch
    flags; only samples on both branches are constraints) and the source coordinates of every
    box pixel (:func:`source_map`, ``placement = (zx, zy, rc, rs)``: the source centre and the
    rotation). Returns ``x0, y0, mapx, mapy`` (empty maps when the box misses the canvas)."""
    green, m = warp
    cx, cy, radius = disk
    w_out, h_out = canvas_size
    gre, gim, greal = target_samples
    fre, fim, freal = source_samples
    zx, zy, rc, rs = placement
    half = int(np.ceil(radius)) + 1
    icx = int(np.floor(cx + 0.5))
    icy = int(np.floor(cy + 0.5))
    x0 = max(icx - half, 0)
    x1 = min(icx + half + 1, w_out)
    y0 = max(icy - half, 0)
    y1 = min(icy + half + 1, h_out)
    if x0 >= x1 or y0 >= y1:
        return x0, y0, np.zeros((0, 0), np.float32), np.zeros((0, 0), np.float32)
    k = 0
    for l in range(gre.shape[0]):
        if greal[l] and freal[l]:
            k += 1
    qx = np.empty(k)
    qy = np.empty(k)
    vx = np.empty(k)
    vy = np.empty(k)
    k = 0
    for l in range(gre.shape[0]):
        if greal[l] and freal[l]:
            # box pixel coordinates of the target sample; rotated source sample minus it
            qx[k] = gre[l] + cx - (icx - half)
            qy[k] = gim[l] + cy - (icy - half)
            vx[k] = rc * fre[l] - rs * fim[l] - gre[l]
            vy[k] = rs * fre[l] + rc * fim[l] - gim[l]
            k += 1
    field = warp_field(
        green, m, half, qx, qy, vx, vy, y0 - icy + half, y1 - icy + half, x0 - icx + half, x1 - icx + half
    )
    mapx, mapy = source_map(x0, y0, y1 - y0, x1 - x0, cx, cy, zx, zy, rc, rs, field)
    return x0, y0, mapx, mapy
