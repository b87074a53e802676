"""Numba kernels of the bi-layer model: joint bilateral filtering (analysis) and the
coordinate-hashed window synthesis (structure tiles + spatially varying noise)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_GOLD = np.uint64(0x9E3779B97F4A7C15)
_PY = np.uint64(0xC2B2AE3D27D4EB4F)
_PS = np.uint64(0x165667B19E3779F9)


@njit(cache=True)
def _mix(z):
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def lattice_hash(i: int, j: int, salt: int, seed: int) -> np.uint64:
    """A well-mixed 64-bit hash of a lattice point (any sign), a salt and the seed."""
    z = np.uint64(np.int64(i)) * _GOLD
    z = _mix(z ^ (np.uint64(np.int64(j)) * _PY))
    z = _mix(z ^ (np.uint64(np.int64(salt)) * _PS) ^ np.uint64(np.int64(seed)))
    return z


@njit(cache=True)
def _reflect(i, n):
    """Index ``i`` reflected into ``[0, n)`` (edge pixel repeated, as OpenCV's BORDER_REFLECT)."""
    if i < 0:
        i = -i - 1
    elif i >= n:
        i = 2 * n - i - 1
    return min(max(i, 0), n - 1)


@njit(parallel=True, cache=True)
def joint_bilateral(image, guide, radius, sigma_space, sigma_range, out, row_start, row_stop):
    """Rows ``row_start:row_stop`` of one pass of a joint (cross) bilateral filter, into ``out``:
    ``image`` (H, W, C) averaged over a ``2 radius + 1`` square with Gaussian weights in space
    and in the distance between the ``guide`` vectors (H, W, D); borders reflect."""
    h, w, c = image.shape
    d = guide.shape[2]
    inv_s = -0.5 / (sigma_space * sigma_space)
    inv_r = -0.5 / (sigma_range * sigma_range)
    for y in prange(row_start, row_stop):
        acc = np.zeros(c, np.float64)
        for x in range(w):
            acc[:] = 0.0
            total = 0.0
            for dy in range(-radius, radius + 1):
                yy = _reflect(y + dy, h)
                for dx in range(-radius, radius + 1):
                    xx = _reflect(x + dx, w)
                    dist = 0.0
                    for k in range(d):
                        diff = guide[y, x, k] - guide[yy, xx, k]
                        dist += diff * diff
                    wgt = math.exp(inv_s * (dy * dy + dx * dx) + inv_r * dist)
                    total += wgt
                    for k in range(c):
                        acc[k] += wgt * image[yy, xx, k]
            for k in range(c):
                out[y, x, k] = acc[k] / total


@njit(cache=True)
def _smooth(t):
    return t * t * (3.0 - 2.0 * t)


@njit(cache=True)
def _tile_index(ty, tx, seed, ucol, variants):
    """The Wang tile of lattice cell ``(ty, tx)``: its four edge colours (hashes of the edges'
    lattice coordinates, shared with the neighbours) and its content variant."""
    north = lattice_hash(ty, tx, 0, seed) % ucol
    south = lattice_hash(ty + 1, tx, 0, seed) % ucol
    west = lattice_hash(ty, tx, 1, seed) % ucol
    east = lattice_hash(ty, tx + 1, 1, seed) % ucol
    var = lattice_hash(ty, tx, 2, seed) % np.uint64(variants)
    return np.int64((((north * ucol + east) * ucol + south) * ucol + west) * np.uint64(variants) + var)


@njit(cache=True)
def _warp_corners(cyw, cxw, seed, vy, vx):
    """The displacements (in [-1, 1]) of the four corners of warp cell ``(cyw, cxw)``."""
    for q in range(4):
        hv = lattice_hash(cyw + (q >> 1), cxw + (q & 1), 5, seed)
        vy[q] = (hv & np.uint64(0xFFFFFFFF)) / 2147483647.5 - 1.0
        vx[q] = (hv >> np.uint64(32)) / 2147483647.5 - 1.0


@njit(cache=True)
def _warp_displacement(fyw, fxw, vy, vx):
    """The corners' displacements blended at the smooth position ``(fyw, fxw)`` in the cell."""
    dy = 0.0
    dx = 0.0
    for q in range(4):
        wq = (fyw if (q >> 1) else 1.0 - fyw) * (fxw if (q & 1) else 1.0 - fxw)
        dy += wq * vy[q]
        dx += wq * vx[q]
    return dy, dx


@njit(cache=True)
def _noise_corners(cy, cx, seed, wrap, offy, offx):
    """The hashed offsets into the periodic noise tiles of the four corners of noise cell
    ``(cy, cx)``."""
    for q in range(4):
        hv = lattice_hash(cy + (q >> 1), cx + (q & 1), 3, seed)
        offy[q] = np.int64(hv & np.uint64(wrap))
        offx[q] = np.int64((hv >> np.uint64(32)) & np.uint64(wrap))


@njit(cache=True)
def _noise_colour(texel, noise_tiles, bases, means, quantiles, sigmas, wts, ty_idx, tx_idx, nvals, colour):
    """``sum_k M_k (mean_k + basis_k @ channels_k)`` at one pixel (guingo2017 eq. 2, 6) into
    ``colour``: per cluster ``k`` whose mask (in the pixel's ``texel``: structure, then masks)
    is not 0 there, the noise channels read at the four taps (weights ``wts`` at rows
    ``ty_idx``, columns ``tx_idx`` of the noise tiles), histogram-equalised when there are
    quantile tables; ``nvals`` is scratch. Arrays, not tuples: this runs per pixel."""
    k_noise, n_pc, _, _ = noise_tiles.shape
    n_masks = texel.shape[0] - 3
    n_q = quantiles.shape[2]
    for ch in range(3):
        colour[ch] = 0.0
    for k in range(k_noise):
        m = texel[3 + k] if n_masks > 1 else 1.0
        if m == 0.0:
            continue  # binary masks: only the pixel's own noise is computed
        for c in range(n_pc):
            v = 0.0
            for q in range(4):
                v += wts[q] * noise_tiles[k, c, ty_idx[q], tx_idx[q]]
            if n_q > 1:  # histogram equalisation: Gaussian quantile -> data quantile
                u = 0.5 * (1.0 + math.erf(v / (sigmas[k, c] * 1.4142135623730951)))
                pos = u * (n_q - 1)
                i0 = min(int(pos), n_q - 2)
                t = pos - i0
                v = quantiles[k, c, i0] * (1.0 - t) + quantiles[k, c, i0 + 1] * t
            nvals[k, c] = v
        for ch in range(3):
            s = means[k, ch]
            for c in range(n_pc):
                s += bases[k, ch, c] * nvals[k, c]
            colour[ch] += m * s


@njit(cache=True)
def _mirror(i, n):
    """Index ``i`` mirrored into ``[0, n)`` however far outside it lies (period ``2 n``)."""
    i = i % (2 * n)
    return 2 * n - 1 - i if i >= n else i


@njit(cache=True)
def _patch_jitter(ty, tx, seed, jitter):
    """The random rotation (degrees) and zoom of the content of tile cell ``(ty, tx)``: hashes
    of the cell drawn uniformly from ``jitter = (rotate, zoom_lo, zoom_hi, keep_vertical, _)``,
    half of the upright ones turned by 180°."""
    hv = lattice_hash(ty, tx, 6, seed)
    u = (hv & np.uint64(0xFFFFFF)) / 16777215.0
    v = ((hv >> np.uint64(24)) & np.uint64(0xFFFFFF)) / 16777215.0
    angle = jitter[0] * (2.0 * u - 1.0)
    if jitter[3] > 0 and (hv >> np.uint64(63)) == np.uint64(1):
        angle += 180.0
    return angle, jitter[1] + (jitter[2] - jitter[1]) * v


@njit(cache=True, inline="always")
def _deformed_texel(texel, tiles, idx, iy, ix, content, centre_y, centre_x, alpha, cos_a, sin_a, inv_zoom):
    """The pixel ``(iy, ix)`` of a tile whose exchanged content is rotated and zoomed
    (guingo2017 §4) into ``texel``: the content is read from the exemplar's layers
    (``content``, bilinear, mirrored borders) about the sample's centre ``(centre_y, centre_x)``, the
    rotation and zoom about the tile's centre, and blended over the tile's own pixel with
    the content's weight ``alpha`` there (1 inside the graph cuts, 0 on the Wang edges)."""
    h, w, n_ch = content.shape
    half = 0.5 * (tiles.shape[1] - 1)
    dy = (iy - half) * inv_zoom
    dx = (ix - half) * inv_zoom
    sy = centre_y + dx * sin_a + dy * cos_a  # the content turned counter-clockwise on screen
    sx = centre_x + dx * cos_a - dy * sin_a
    fy = math.floor(sy)
    fx = math.floor(sx)
    ty = sy - fy
    tx = sx - fx
    y0 = np.int64(fy)
    x0 = np.int64(fx)
    y1 = y0 + 1
    x1 = x0 + 1
    if y0 < 0 or y1 >= h or x0 < 0 or x1 >= w:  # mirrored only near the exemplar's borders
        y0, y1 = _mirror(y0, h), _mirror(y1, h)
        x0, x1 = _mirror(x0, w), _mirror(x1, w)
    for ch in range(n_ch):
        top = content[y0, x0, ch] * (1.0 - tx) + content[y0, x1, ch] * tx
        bottom = content[y1, x0, ch] * (1.0 - tx) + content[y1, x1, ch] * tx
        v = top * (1.0 - ty) + bottom * ty
        texel[ch] = v if alpha >= 1.0 else alpha * v + (1.0 - alpha) * tiles[idx, iy, ix, ch]


@njit(cache=True)
def _column_tables(x0, w, cell, wcell):
    """Everything of the window that depends on the column alone: per column, its noise cell
    and smooth position in it, its warp cell and position, and 1 / sqrt of the column part
    of the noise weights' energy."""
    col_cx = np.empty(w, np.int64)
    col_fx = np.empty(w, np.float64)
    col_cxw = np.empty(w, np.int64)
    col_fxw = np.empty(w, np.float64)
    col_nx = np.empty(w, np.float64)
    for col in range(w):
        gx = x0 + col
        col_cx[col] = gx // cell
        col_fx[col] = _smooth((gx - col_cx[col] * cell) / cell)
        col_cxw[col] = gx // wcell
        col_fxw[col] = _smooth((gx - col_cxw[col] * wcell) / wcell)
        col_nx[col] = 1.0 / math.sqrt(col_fx[col] ** 2 + (1.0 - col_fx[col]) ** 2)
    return col_cx, col_fx, col_cxw, col_fxw, col_nx


@njit(cache=True)
def _cell_rotation(ty, tx, seed, jitter, rotation):
    """``rotation = (angle, zoom, cos, sin)`` of tile cell ``(ty, tx)``'s content."""
    angle, zoom = _patch_jitter(ty, tx, seed, jitter)
    rotation[0] = angle
    rotation[1] = zoom
    rotation[2] = math.cos(math.radians(angle))
    rotation[3] = math.sin(math.radians(angle))


@njit(cache=True, inline="always")
def _deformed_content(texel, tiles, idx, iy, ix, deform, rotation, r, col, alpha):
    """The structure and masks of one pixel of a deformed cell's content into ``texel``:
    the content turned by the cell's ``rotation`` and the fields at window pixel
    ``(r, col)``, blended over the tile's pixel with weight ``alpha`` (see
    :func:`render_window`)."""
    content, centres, _, _, angle_field, zoom_field = deform
    cos_a = rotation[2]
    sin_a = rotation[3]
    if angle_field.shape[0] > 0:  # the field varies per pixel
        rad = math.radians(rotation[0] + angle_field[r, col])
        cos_a = math.cos(rad)
        sin_a = math.sin(rad)
    zoom = rotation[1] * zoom_field[r, col] if zoom_field.shape[0] > 0 else rotation[1]
    _deformed_texel(
        texel, tiles, idx, iy, ix, content, centres[idx, 0], centres[idx, 1], alpha, cos_a, sin_a, 1.0 / zoom
    )


@njit
def _row_weights(fy, wy):
    """The row parts ``wy`` of a noise cell's four corner weights at fraction ``fy`` down the
    cell; returns the row part of their unit-energy norm (the weights are separable: their
    energy is (row part) x (column part))."""
    for q in range(4):
        wy[q] = fy if (q >> 1) else 1.0 - fy
    return 1.0 / math.sqrt(fy * fy + (1.0 - fy) * (1.0 - fy))


@njit
def _write_pixel(out, layers, r, col, texel, colour, want_layers, want_noise):
    """Pixel ``(r, col)`` of the window: the structure ``texel`` plus the noise ``colour``,
    clipped to [0, 1], into ``out``, and the two layers into ``layers = (structure_out,
    noise_out)`` when they are wanted."""
    structure_out, noise_out = layers
    for ch in range(3):
        out[r, col, ch] = min(max(texel[ch] + colour[ch], 0.0), 1.0)
        if want_noise:
            noise_out[r, col, ch] = colour[ch]
    if want_layers:
        for ch in range(texel.shape[0]):
            structure_out[r, col, ch] = texel[ch]


@njit(parallel=True, cache=True)
def render_window(y0, x0, out, layers, tiles, lattice, noise, deform):
    """Pixels ``[y0, y0 + H) x [x0, x0 + W)`` of the unbounded bi-layer texture into ``out``.

    Structure + masks: Wang tiles (Cohen 2003) laid on a lattice of ``tile`` px cells; the
    colour of each edge and the content variant of each cell are hashes of their lattice
    coordinates, so neighbouring cells agree on their shared edge and any window gives the
    same pixels wherever it overlaps another (guingo2017 §4).

    Noise: per cluster ``k`` and PCA channel ``c``, a periodic tile of random-phase noise
    (phases shared across clusters, §3.2) read at four hashed offsets, one per corner of a
    lattice of ``cell`` px, with smooth weights normalised to unit energy, so the noise is
    Gaussian of the same spectrum everywhere but never periodic. Optional per-(k, c)
    quantile tables equalise its histogram (§6). Colour = mean_k + basis_k @ channels
    (per-cluster PCA, §6), blended by the synthesized masks (eq. 2, 6).

    ``layers = (structure_out, noise_out)`` receive the two layers when they have the window's
    size (pass ``(0, 0, C)`` arrays to skip them). ``tiles`` (n, size, size, 3 + masks) are the
    tile set; ``lattice = (colours, variants, seed, warp)`` the edge colours and variants per
    tile, the hash seed and the warp amplitude in px; ``noise = (noise_tiles, cell, bases,
    means, quantiles, sigmas)`` the (K, PC, period, period) noise tiles (the period a power of
    two), the noise cell and the per-cluster PCA and equalisation tables.

    Deformation (guingo2017 §4, Fig. 9-10), per patch and on the fly: ``deform = (content,
    centres, interior, jitter, angle, zoom)``. Each cell's exchanged content (where the
    tile's ``interior`` weight is > 0) is read anew from the exemplar's ``content`` layers
    about its sample's centre (``centres``, per tile), rotated by the cell's hashed angle
    plus the ``angle`` field (degrees, counter-clockwise on screen) at the pixel and zoomed
    by the cell's hashed zoom times the ``zoom`` field; the Wang edges stay as they are, so
    cells still join. ``jitter = (rotate, zoom_lo, zoom_hi, keep_vertical, active)``; the
    fields are the window's size, or ``(0, 0)`` for none. Inactive: the tiles as built.
    """
    structure_out, noise_out = layers
    colours, variants, seed, warp = lattice
    noise_tiles, cell, bases, means, quantiles, sigmas = noise
    interior, jitter = deform[2], deform[3]
    deformed = jitter[4] > 0
    h, w, _ = out.shape
    n_tiles, size, _, n_ch = tiles.shape
    k_noise, n_pc, period, _ = noise_tiles.shape
    wrap = period - 1
    # (both sides: a one-row window with (1, 1, C) placeholders must not write past them)
    want_layers = structure_out.shape[0] == h and structure_out.shape[1] == w
    want_noise = noise_out.shape[0] == h and noise_out.shape[1] == w
    ucol = np.uint64(colours)
    wcell = 2 * size
    col_cx, col_fx, col_cxw, col_fxw, col_nx = _column_tables(x0, w, cell, wcell)
    for r in prange(h):
        gy = y0 + r
        cy = gy // cell
        fy = _smooth((gy - cy * cell) / cell)
        nvals = np.empty((k_noise, n_pc), np.float64)
        colour = np.empty(3, np.float64)
        deformed_texel = np.empty(n_ch, np.float32)
        rotation = np.array([0.0, 1.0, 1.0, 0.0])  # the cell's content: angle, zoom, cos, sin
        offy = np.empty(4, np.int64)
        offx = np.empty(4, np.int64)
        wy = np.empty(4, np.float64)
        wts = np.empty(4, np.float64)
        ny = _row_weights(fy, wy)
        ty_idx = np.empty(4, np.int64)
        tx_idx = np.empty(4, np.int64)
        idx = np.int64(0)
        tx = np.int64(0)
        ty = np.int64(0)
        tx_lo = np.int64(-(1 << 62))
        ty_lo = np.int64(-(1 << 62))
        cx_cur = -(1 << 62)
        wx_cur = -(1 << 62)
        py = gy & wrap
        cyw = gy // wcell
        fyw = _smooth((gy - cyw * wcell) / wcell)
        vy = np.zeros(4, np.float64)
        vx = np.zeros(4, np.float64)
        for col in range(w):
            gx = x0 + col
            sy = gy
            sx = gx
            if warp > 0:
                cxw = col_cxw[col]
                if cxw != wx_cur:  # a new warp cell: its corners' displacements
                    wx_cur = cxw
                    _warp_corners(cyw, cxw, seed, vy, vx)
                dy, dx = _warp_displacement(fyw, col_fxw[col], vy, vx)
                sy = gy + np.int64(math.floor(warp * dy + 0.5))
                sx = gx + np.int64(math.floor(warp * dx + 0.5))
            moved = False
            if sy < ty_lo or sy >= ty_lo + size:  # divisions only when the tile changes
                ty = sy // size
                ty_lo = ty * size
                moved = True
            if sx < tx_lo or sx >= tx_lo + size:
                tx = sx // size
                tx_lo = tx * size
                moved = True
            iy = sy - ty_lo
            ix = sx - tx_lo
            if moved:  # a new tile: its edge colours and content variant
                idx = _tile_index(ty, tx, seed, ucol, variants)
                if deformed:
                    _cell_rotation(ty, tx, seed, jitter, rotation)
            texel = tiles[idx, iy, ix]  # the tile's pixel, or its deformed content's
            alpha = interior[idx, iy, ix] if deformed else 0.0
            if alpha > 0.0:
                texel = deformed_texel
                _deformed_content(texel, tiles, idx, iy, ix, deform, rotation, r, col, alpha)
            cx = col_cx[col]
            if cx != cx_cur:  # a new noise cell: the offsets of its four corners
                cx_cur = cx
                _noise_corners(cy, cx, seed, wrap, offy, offx)
            fx = col_fx[col]
            norm = ny * col_nx[col]
            px = gx & wrap
            for q in range(4):  # unit-energy weights and the taps, shared by every noise
                wts[q] = wy[q] * (fx if (q & 1) else 1.0 - fx) * norm
                ty_idx[q] = (py + offy[q]) & wrap
                tx_idx[q] = (px + offx[q]) & wrap
            _noise_colour(texel, noise_tiles, bases, means, quantiles, sigmas, wts, ty_idx, tx_idx, nvals, colour)
            _write_pixel(out, layers, r, col, texel, colour, want_layers, want_noise)
