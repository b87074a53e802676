"""What the solver does with the pieces it copies, between its iterations: offsets as codes,
the copy-size control that cuts pieces larger than allowed, border seams handed back to the
solver, the toroidal shift of the state, and the graph cuts of straight seams
(:mod:`barkgen.synth.seams.cuts`, Kwatra et al. 2003).

A piece is a verbatim copy of the exemplar: a connected set of output pixels whose references
keep one offset (reference - position). The kernels mark a forbidden offset per output pixel
(``forbid``), which the M- and E-steps never take there.
"""

from __future__ import annotations

import cv2
import numpy as np

from barkgen._shared.canvas import Canvas


def offset_codes(dy: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """Offsets (reference - position) as the int64 codes the kernels compare
    (``barkgen.synth._kernels.offset_code``)."""
    import barkgen.synth._kernels as K

    bias = K.OFFSET_BIAS
    return (np.asarray(dy, np.int64) + bias) * (2 * bias) + (np.asarray(dx, np.int64) + bias)


def offset_parts(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`offset_codes`: ``(dy, dx)``."""
    import barkgen.synth._kernels as K

    bias = K.OFFSET_BIAS
    dy, dx = np.divmod(codes, 2 * bias)
    return dy - bias, dx - bias


#: swing of the copy-size control's meandering cut lines, as a fraction of the side of a
#: square piece of the largest area allowed
CUT_MEANDER_AMPLITUDE = 0.05
#: their shortest period, in the same unit (the longest is twice this)
CUT_MEANDER_PERIOD = 0.4


def limit_copies(refs: np.ndarray, ctx, forbid: np.ndarray) -> int:
    """Copy-size control: find the pieces copied verbatim (``seams._kernels.label_pieces``: a piece that
    runs round a tiled output or across a wrapping exemplar's edge is one) larger than
    ``config.max_copy`` of the level's exemplar and forbid their offsets on a cross-shaped band
    through each one's centroid, so the next iterations cut it in up to four. The band's two
    lines meander (random phase and period per piece, drawn from the solve's generator):
    straight, they would leave two straight seams, which the seam cuts would close again.
    ``ctx``: the solver's level (:class:`barkgen.synth._level.LevelContext`: its analysis,
    config, generator and tile). Returns the number of regions cut.

    The discrete solver left alone grows whole-exemplar copies wherever nothing stops coherence
    (G'MIC's results copy 64 % of the exemplar in one piece); this keeps the coherence bias while
    bounding the largest verbatim piece.
    """
    import barkgen.synth.seams._kernels as K

    level, tile, rng = ctx.analysis, ctx.tile, ctx.rng
    max_area = ctx.config.max_copy * level.height * level.width
    labels = np.empty(refs.shape, np.int32)
    sizes = K.label_pieces((refs, tile), level.grid, labels)
    big = sizes > max_area
    if not big.any():
        return 0
    ys, xs = np.nonzero(big[labels])
    lab = labels[ys, xs]
    n = np.bincount(lab, minlength=sizes.size).astype(np.float64)
    side = np.sqrt(max_area)
    which = np.cumsum(big) - 1  # a big piece's row in the draws
    phase = 2 * np.pi * rng.random((2, int(big.sum())))
    period = CUT_MEANDER_PERIOD * side * (1.0 + rng.random(phase.shape))
    k = which[lab]
    swing_y = CUT_MEANDER_AMPLITUDE * side * np.sin(2 * np.pi * xs / period[0, k] + phase[0, k])
    swing_x = CUT_MEANDER_AMPLITUDE * side * np.sin(2 * np.pi * ys / period[1, k] + phase[1, k])
    if tile:  # a piece round the torus: its centre is the circular mean, the band wraps
        H, W = refs.shape
        cy = _circular_centre(lab, ys, H, n)
        cx = _circular_centre(lab, xs, W, n)
        band = (_circular_gap(ys, cy[lab] + swing_y, H) <= 1.0) | (_circular_gap(xs, cx[lab] + swing_x, W) <= 1.0)
    else:
        cy = np.bincount(lab, ys, minlength=sizes.size) / np.maximum(n, 1)
        cx = np.bincount(lab, xs, minlength=sizes.size) / np.maximum(n, 1)
        band = (np.abs(ys - cy[lab] - swing_y) <= 1.0) | (np.abs(xs - cx[lab] - swing_x) <= 1.0)
    ys, xs = ys[band], xs[band]
    e = refs[ys, xs]
    forbid[ys, xs] = offset_codes(level.coords_y[e] - ys, level.coords_x[e] - xs)
    return int(big.sum())


#: rows (or columns) of the lower piece that a straight seam stuck at the exemplar's border
#: forbids (:func:`unstick_border_seams`)
UNSTICK_DEPTH = 4


def unstick_border_seams(refs: np.ndarray, ctx, forbid: np.ndarray, min_run: int) -> int:
    """Where a straight seam joins two pieces that both end at the exemplar's border there
    (the upper one on its last row, the lower one on its first, along an axis that does not
    wrap), no cut can move it: neither piece continues past the border. The lower piece's offset
    is forbidden on the ``UNSTICK_DEPTH`` rows below the seam, so the next iterations put
    other pieces there, which can be cut. The same for seams between columns. ``ctx``: the
    solver's level (:func:`limit_copies`). Returns the number of seams treated."""
    import barkgen.synth.seams._kernels as K

    level, tile = ctx.analysis, ctx.tile
    ry = np.ascontiguousarray(level.coords_y[refs], dtype=np.int32)
    rx = np.ascontiguousarray(level.coords_x[refs], dtype=np.int32)
    h, w = level.height, level.width
    treated = 0
    a: np.ndarray  # (cv2.transpose is typed as any numeric array)
    b: np.ndarray
    for axis in (0, 1):
        if level.wrap[axis]:
            continue
        if axis == 0:
            a, b, n_ex, wy, wx, fb = ry, rx, (h, w), level.wrap[0], level.wrap[1], forbid
        else:
            a, b, n_ex, wy, wx, fb = (
                cv2.transpose(rx),
                cv2.transpose(ry),
                (w, h),
                level.wrap[1],
                level.wrap[0],
                forbid.T,
            )
        H, W = a.shape
        runs = K.seam_runs((a, b, tile), (n_ex[0], n_ex[1], wy, wx), min_run)
        for i, start, length in runs:
            cols = np.arange(start, start + length)
            cols = np.mod(cols, W) if tile else cols
            j = (i + 1) % H
            stuck = (a[i, cols] == n_ex[0] - 1) & (a[j, cols] == 0)
            if stuck.mean() < 0.5:
                continue
            rows = j + np.arange(UNSTICK_DEPTH)
            if tile:
                rows = np.mod(rows, H)
            else:
                rows = rows[rows < H]
            yy, xx = np.meshgrid(rows, cols, indexing="ij")
            dy = (rows - j)[:, None] if not tile else np.mod(rows - j, H)[:, None]
            same = (a[yy, xx] == a[j, cols][None, :] + dy) & (b[yy, xx] == b[j, cols][None, :])
            yy, xx = yy[same], xx[same]
            ey, ex = a[yy, xx], b[yy, xx]
            if axis == 0:
                fb[yy, xx] = offset_codes(ey - yy, ex - xx)
            else:  # transposed frame: output (xx, yy), exemplar (ex, ey)
                fb[yy, xx] = offset_codes(ex - xx, ey - yy)
            treated += 1
    return treated


def _circular_centre(lab: np.ndarray, pos: np.ndarray, period: int, n: np.ndarray) -> np.ndarray:
    """Per label, the circular mean of the positions ``pos`` on a circle of ``period`` pixels."""
    angle = pos * (2 * np.pi / period)
    c = np.bincount(lab, np.cos(angle), minlength=n.size)
    s = np.bincount(lab, np.sin(angle), minlength=n.size)
    return np.mod(np.arctan2(s, c) * (period / (2 * np.pi)), period)


def _circular_gap(pos: np.ndarray, centre: np.ndarray, period: int) -> np.ndarray:
    d = np.abs(pos - centre) % period
    return np.minimum(d, period - d)


def roll_state(refs: np.ndarray, forbid: np.ndarray, shift: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Toroidal shift of the output state; forbidden offsets are re-expressed for the pixels'
    new positions."""
    H, W = refs.shape
    ys, xs = np.arange(H), np.arange(W)
    # an offset is relative to the position; after the shift the position is (y + sy) mod H
    moved = moved_offsets(forbid, (ys + shift[0]) % H - ys, (xs + shift[1]) % W - xs)
    return (
        np.ascontiguousarray(np.roll(refs, shift, axis=(0, 1))),
        np.ascontiguousarray(np.roll(moved, shift, axis=(0, 1))),
    )


def moved_offsets(forbid: np.ndarray, row_moves: np.ndarray, col_moves: np.ndarray) -> np.ndarray:
    """Forbidden offset codes (reference - position; -1: none) re-expressed for pixels whose
    row moves by ``row_moves[i]`` (one per row) and column by ``col_moves[j]`` (one per column):
    the same exemplar pixel, seen from the new position."""
    dy, dx = offset_parts(forbid)
    moved = offset_codes(dy - np.asarray(row_moves)[:, None], dx - np.asarray(col_moves)[None, :])
    return np.where(forbid >= 0, moved, -1)


def cut_seams(refs: np.ndarray, ctx, min_run: int) -> np.ndarray:
    """The level's reference map with its straight seams re-cut (:mod:`barkgen.synth.seams.cuts`);
    ``ctx``: the solver's level (:func:`limit_copies`): its seam image (what the seam cost
    compares), its guide (texture-by-numbers' labels are kept) and its generator (the
    meanders)."""
    from barkgen.synth.seams.cuts import cut_straight_seams

    level, guide = ctx.analysis, ctx.guide
    allowed = None
    if guide.guided:
        ex_labels, target = guide.ex_labels, guide.target

        def allowed(ys, xs, ey, ex):
            return ex_labels[ey * level.width + ex] == target[ys, xs]

    coords = np.stack([level.coords_y[refs], level.coords_x[refs]], axis=-1)
    canvas = Canvas(coords.shape[:2], tile=ctx.tile, exemplar_wrap=level.wrap)
    cut = cut_straight_seams(coords, ctx.seam_image, canvas, min_run=min_run, allowed=allowed, rng=ctx.rng)
    return np.ascontiguousarray(cut[..., 0] * level.width + cut[..., 1], dtype=np.int32)
