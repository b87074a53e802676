"""Continuous maps through a reference map: gradients carried, then re-integrated.

A reference map copies pieces of the exemplar (laitoch2018 §3.3.1). For the colour that is what
we want: every output pixel is exactly an exemplar pixel, so the texture is as sharp as the
photo and ``apply_references`` reproduces it. A height field copied the same way is not: two
pieces meet at different heights, and the border between them becomes a cliff, in the
displacement and in every map derived from it (normals, AO).

So a continuous map (height, roughness, an extra map) goes through the gradient domain (Pérez et
al. 2003, "Poisson image editing"; the same idea as the gradient-domain seams of sibbing2010
§5): every output pixel takes the exemplar's *gradient* at its reference (the step to the next
exemplar pixel, as if its piece went on), and the map is the field whose gradients fit those
best, screened towards the plainly copied map so that its low frequencies stay the exemplar's:

    minimise  sum |grad u - g|^2 + lambda * sum (u - f)^2,

solved exactly by FFT on the torus when the output tiles (so the map still tiles) and by the
cosine transform (Neumann border) when it does not. Inside a piece the carried gradients are
the copied map's own, so nothing changes there but a slow drift; across a border the step
becomes an ordinary one.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen._shared.canvas import Canvas
from barkgen.errors import InvalidInputError

#: lambda of the screened Poisson equation: a step at a seam spreads over about
#: 1 / sqrt(lambda) px (here ~30), far below the size of a copied piece
SCREENING = 1e-3

#: ``blend`` settings of the colour: ``gradient`` (:func:`blend_seams`) or ``none`` (the exact copy)
BLEND_MODES = ("none", "gradient")

#: the colour's seam blend (:func:`blend_seams`) leaves alone the part of a step between two
#: pieces up to this share of the step the piece itself takes there, plus BLEND_FLOOR of the
#: photo's mean step. Measured on the ten shared photos (256^2 -> 1024^2 tiled, texeval, the
#: same references): 0.5 / 0.75 took the completeness median 0.0205 -> 0.019 and the border
#: step ratio of the peeling crop's synthesis (512^2 -> 1024^2) 1.16 -> 1.22 (copied exactly: 2.96)
BLEND_THRESHOLD = 0.75

#: see BLEND_THRESHOLD
BLEND_FLOOR = 0.1

#: over-relaxation factor of the seam blend's Gauss-Seidel sweeps, its stop (the largest change
#: of a sweep, a share of the photo's mean step) and its most sweeps
RELAXATION = 1.5
RELAXATION_TOLERANCE = 1e-3
MAX_SWEEPS = 500

#: screening of the seam blend's correction: only a safeguard (every correction touches the pixels
#: kept as they are, which anchor it), far below the 1-4 of a pixel's own neighbours
BLEND_ANCHOR = 1e-2

#: weight of a step across a border in the colour's seam blend against 1 for the steps beside it:
#: the border's own step is kept closer to the photo's, the steps beside it take more of the ramp
BORDER_WEIGHT = 2.0

#: the farthest (px) from a border the colour's seam blend reaches: a step of 2 x MAX_REACH of
#: the photo's own steps and more is spread over that width
MAX_REACH = 16

#: the colour's seam blend spreads a step over as many pixels as keep each of their steps under
#: this many of the photo's own mean steps
SPREAD_STEPS = 4.0

#: px of halo round a window's core for the seam blend (:func:`blend_seams_in_windows`): its
#: :data:`MAX_REACH` and the decay of its anchor's correction (about 10 px), with room to spare
BLEND_HALO = 64


def exemplar_steps(source: np.ndarray, wrap: tuple[bool, bool] = (False, False)) -> tuple[np.ndarray, np.ndarray]:
    """``(sy, sx)``, each ``(h, w, C)`` float64: the exemplar map's forward steps down and to the
    right at every pixel (from its last row or column: to the first where the exemplar wraps,
    else the step that reaches it)."""
    src = np.asarray(source, dtype=np.float64)
    if src.ndim == 2:
        src = src[:, :, None]
    steps = []
    for axis in (0, 1):
        if wrap[axis]:
            steps.append(np.roll(src, -1, axis=axis) - src)
            continue
        d = np.diff(src, axis=axis)
        last = np.take(d, [-1], axis=axis) if src.shape[axis] > 1 else np.zeros_like(np.take(src, [0], axis=axis))
        steps.append(np.concatenate([d, last], axis=axis))
    return steps[0], steps[1]


def carried_gradients(
    source: np.ndarray, references: np.ndarray, wrap: tuple[bool, bool] = (False, False)
) -> tuple[np.ndarray, np.ndarray]:
    """``(gy, gx)``, each ``(H, W, C)`` float64: the exemplar map's forward steps
    (:func:`exemplar_steps`) at each output pixel's reference: the steps its piece would take
    if it went on."""
    sy, sx = exemplar_steps(source, wrap)
    ry, rx = references[..., 0], references[..., 1]
    return sy[ry, rx], sx[ry, rx]


def screened_poisson(
    plain: np.ndarray, gy: np.ndarray, gx: np.ndarray, boundary: Boundary, *, screening: float = SCREENING
) -> np.ndarray:
    """The ``u`` minimising ``|grad u - (gy, gx)|^2 + screening * |u - plain|^2`` over an
    ``(H, W, C)`` map, forward differences; on the torus when the map's ``boundary`` wraps both
    axes (FFT), else with a Neumann border (DCT; the last row's ``gy`` and last column's ``gx``
    are not used)."""
    tile = boundary.wraps_both
    div = _divergence(np.asarray(gy, np.float64), np.asarray(gx, np.float64), tile, overwrite=False)
    rhs = np.asarray(plain, dtype=np.float64) * screening
    rhs -= div
    del div
    return _solve_screened(rhs, screening, tile)


def _divergence(gy: np.ndarray, gx: np.ndarray, tile: bool, *, overwrite: bool) -> np.ndarray:
    """The backward-difference divergence of ``(gy, gx)`` (round the torus when ``tile``, else
    the last row's ``gy`` and last column's ``gx`` taken as 0: a Neumann border); ``overwrite``:
    in ``gx``'s buffer (``gy``'s last row zeroed too)."""
    if tile:
        div = gx - np.roll(gx, 1, axis=1)
        div += gy - np.roll(gy, 1, axis=0)
        return div
    if not overwrite:
        gy, gx = gy.copy(), gx.copy()
    gx[:, -1] = 0.0
    gy[-1, :] = 0.0
    div = gx
    div[:, 1:] -= gx[:, :-1].copy()
    div += gy
    div[1:] -= gy[:-1]
    return div


def _solve_screened(rhs: np.ndarray, screening: float, tile: bool) -> np.ndarray:
    """The screened Poisson solve of :func:`screened_poisson` from its right-hand side
    ``screening * plain - div`` (overwritten)."""
    import scipy.fft as sfft

    H, W = rhs.shape[:2]
    # eigenvalues of the 1-D negative Laplacian: periodic (FFT) or Neumann (DCT-II)
    period = 2.0 if tile else 1.0
    eig_y, eig_x = (2.0 - 2.0 * np.cos(period * np.pi * np.arange(n) / n) for n in (H, W))
    denom = (screening + eig_y[:, None] + eig_x[None, :])[:, :, None]
    if tile:
        return np.real(sfft.ifft2(sfft.fft2(rhs, axes=(0, 1)) / denom, axes=(0, 1)))
    spectrum = sfft.dctn(rhs, type=2, axes=(0, 1), norm="ortho", overwrite_x=True)
    spectrum /= denom
    return sfft.idctn(spectrum, type=2, axes=(0, 1), norm="ortho", overwrite_x=True)


def _integrate(
    source: np.ndarray, references: np.ndarray, canvas: Canvas, screening: float, smooth_slopes: bool
) -> np.ndarray:
    """The gradient-domain map ``(H, W, C)`` float64 of an ``(h, w, C)`` exemplar map, on the
    ``canvas`` (its tile, the exemplar's wrap): :func:`screened_poisson`, each array of the
    output's size let go as soon as it is spent (a window of the material set holds 4 at a time,
    not 9: issue 69)."""
    tile, wrap = canvas.tile, _exemplar_wrap(canvas)
    if not smooth_slopes:
        gy, gx = carried_gradients(source, references, wrap)
    else:  # the slopes are continuous maps themselves: carried through their own gradients
        sy, sx = exemplar_steps(source, wrap)
        gy = _integrate(sy, references, canvas, screening, False)
        gx = _integrate(sx, references, canvas, screening, False)
        del sy, sx
    div = _divergence(gy, gx, tile, overwrite=True)
    del gy, gx
    ry, rx = references[..., 0], references[..., 1]
    rhs = np.asarray(source, dtype=np.float64)[ry, rx]
    rhs *= screening
    rhs -= div
    del div
    return _solve_screened(rhs, screening, tile)


def _exemplar_wrap(canvas: Canvas) -> tuple[bool, bool]:
    """The canvas's resolved exemplar wrap (None: the exemplar wraps nowhere)."""
    wrap = canvas.exemplar_wrap
    if wrap is None:
        return (False, False)
    if not isinstance(wrap, tuple):
        raise InvalidInputError(f"the canvas's exemplar wrap must be resolved to (rows, columns), not {wrap!r}")
    return wrap


def check_blend(mode: str) -> str:
    """Raise :class:`~barkgen.errors.InvalidInputError` unless ``mode`` is one of
    :data:`BLEND_MODES`; return it."""
    from barkgen.errors import InvalidInputError

    if mode not in BLEND_MODES:
        raise InvalidInputError(f"blend must be one of {', '.join(BLEND_MODES)}, not {mode!r}")
    return mode


def _length(vectors: np.ndarray) -> np.ndarray:
    """``(H, W)``: the length of each ``(H, W, C)`` vector."""
    return np.sqrt(np.einsum("...c,...c->...", vectors, vectors))


def correction_region(reach: np.ndarray, tile: bool) -> np.ndarray:
    """``(H, W)`` bool: the pixels closer than ``reach`` px (Euclidean) to a pixel of that
    ``reach`` (an ``(H, W)`` int array, 0: no seam there), the pixels with a reach included;
    across the output's edges when it tiles (``tile``)."""
    import cv2

    region = reach > 0
    for k in range(2, int(reach.max(initial=0)) + 1):
        far = (reach < k).astype(np.uint8)
        if tile:
            far = np.pad(far, k, mode="wrap")
        distance = cv2.distanceTransform(far, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        region |= (distance[k:-k, k:-k] if tile else distance) < k
    return region


def blend_seams(
    source: np.ndarray,
    references: np.ndarray,
    canvas: Canvas,
    *,
    threshold: float = BLEND_THRESHOLD,
    border_weight: float = BORDER_WEIGHT,
) -> np.ndarray:
    """The colour (or any local map) of the exemplar through a reference map, the steps between
    copied pieces corrected where they are larger than the photo's own.

    The copy of every pixel's reference keeps whatever low-frequency mismatch two pieces have
    (light falloff, a shadow, a colour cast) as a step at their border. Each step between two
    pieces is compared with the step its piece would take there; what goes beyond a step the
    photo could have taken there (``threshold`` times that step plus :data:`BLEND_FLOOR` of the
    photo's mean step) is taken out, on the pixels beside the border only: the two either side,
    more for a larger excess (:data:`SPREAD_STEPS`, :func:`correction_region`). The correction
    minimises ``sum_steps w (c_q - c_p + e_pq)^2`` (``e`` the excess, ``w`` ``border_weight``
    on a step across a border, 1 beside it) with every other pixel held: Pérez et al. 2003's
    cloning on the seams, as Kwatra et al. 2003 suggest for the seams a cut leaves, by
    red-black over-relaxation (numba). Every other pixel stays the photo's own, so the patches
    of the photo stay whole in the output, and the colour does not drift. Same dtype and shape;
    integer maps are rounded and clipped to their range, float maps in [0, 1] stay in it.

    References
    ----------
    .. [1] perez2003 (Poisson image editing, seamless cloning).
    .. [2] kwatra2003, §3 (gradient-domain blending of residual seams).
    """
    from barkgen.synth.seams import _blend_kernels as K

    src = np.asarray(source)
    refs = np.ascontiguousarray(references, dtype=np.int32)
    s3 = src[:, :, None] if src.ndim == 2 else src
    exemplar = np.ascontiguousarray(s3, dtype=np.float64)
    wrap = _exemplar_wrap(canvas)
    mean_steps = [float(np.mean(_length(s))) for s in exemplar_steps(exemplar, wrap)]
    H, W = refs.shape[:2]
    excess = (np.empty((H, W, s3.shape[2]), np.float32), np.empty((H, W, s3.shape[2]), np.float32))
    reach_y, reach_x = np.empty((H, W), np.int32), np.empty((H, W), np.int32)
    limits = (
        float(threshold),
        BLEND_FLOOR * mean_steps[0],
        BLEND_FLOOR * mean_steps[1],
        SPREAD_STEPS * max(mean_steps[0], 1e-12),
        SPREAD_STEPS * max(mean_steps[1], 1e-12),
        MAX_REACH,
    )
    K.excess_steps(exemplar, refs, (bool(wrap[0]), bool(wrap[1]), bool(canvas.tile)), limits, *excess, reach_y, reach_x)
    # a pixel's reach: the farthest of its four steps' (the steps off an untiled output's last
    # row and column have none, so the rolls bring none round)
    reach = np.maximum(
        np.maximum(reach_y, np.roll(reach_y, 1, axis=0)), np.maximum(reach_x, np.roll(reach_x, 1, axis=1))
    )
    out = s3[refs[..., 0], refs[..., 1]]
    free = correction_region(reach, canvas.tile)
    if free.any():
        ys, xs, colour_start = _red_black(free, canvas.tile)
        index = np.full((H, W), -1, np.int32)
        index[ys, xs] = np.arange(ys.size, dtype=np.int32)
        correction = np.zeros((ys.size, s3.shape[2]))
        settings = (bool(canvas.tile), float(border_weight), BLEND_ANCHOR, RELAXATION)
        stop = (RELAXATION_TOLERANCE * max(min(mean_steps), 1e-12), MAX_SWEEPS)
        K.relax_band(correction, (ys, xs, colour_start), index, excess, settings, stop)
        out[ys, xs] = _as_source_dtype(out[ys, xs].astype(np.float64) + correction, src)
    return out[:, :, 0] if src.ndim == 2 else out


def blend_seams_in_windows(source: np.ndarray, references: np.ndarray, canvas: Canvas, window: int) -> np.ndarray:
    """:func:`blend_seams` core by core: each square core of ``window`` px blended on a window
    of :data:`BLEND_HALO` px more round it (round the torus when ``canvas.tile``) that does not
    tile, and only its core kept. The blend is local (it reaches :data:`MAX_REACH` px from a
    border, its anchor's correction decays within a few more), so the result is the whole
    blend's to a last bit, and its working arrays are a window's, not the output's (issue 69;
    perez2003)."""
    from barkgen._shared.memory import give_back_freed_memory
    from barkgen._shared.windows import resolve_windows

    refs = np.asarray(references)
    out: np.ndarray | None = None
    for win in resolve_windows(refs.shape[:2], window, BLEND_HALO, canvas.tile):
        local = Canvas(win.shape, tile=False, exemplar_wrap=canvas.exemplar_wrap)
        core = blend_seams(source, refs[np.ix_(win.rows, win.cols)], local)[win.core]
        if out is None:
            out = np.empty(refs.shape[:2] + core.shape[2:], core.dtype)
        out[win.target] = core
        del core
        give_back_freed_memory()  # (the window's freed arrays not kept beside the next one's)
    assert out is not None  # (an output has a window)
    return out


def _red_black(free: np.ndarray, tile: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(ys, xs, colour_start)``: the ``free`` pixels, red (``y + x`` even) first, then black,
    then those of neither (``colour_start[2]`` on): on a tiled output of an odd side, the last
    column or row, whose wrap-round neighbour has its own colour."""
    H, W = free.shape
    yy, xx = np.nonzero(free)
    neither = np.zeros(yy.size, bool)
    if tile and W % 2:
        neither |= xx == W - 1
    if tile and H % 2:
        neither |= yy == H - 1
    colour = np.where(neither, 2, (yy + xx) % 2)
    order = np.argsort(colour, kind="stable")
    counts = np.bincount(colour, minlength=3)
    colour_start = np.array([0, counts[0], counts[0] + counts[1]], np.int64)
    return yy[order].astype(np.int64), xx[order].astype(np.int64), colour_start


def _as_source_dtype(u: np.ndarray, src: np.ndarray) -> np.ndarray:
    """``u`` in ``src``'s dtype: integers rounded and clipped to their range, floats in [0, 1]
    kept in it."""
    if src.dtype.kind in "ui":
        info = np.iinfo(src.dtype)
        return np.clip(np.rint(u), info.min, info.max).astype(src.dtype)
    lo, hi = float(src.min()), float(src.max())
    if lo >= 0.0 and hi <= 1.0:
        u = np.clip(u, 0.0, 1.0)
    return u.astype(src.dtype)


def resolve_continuous(
    source: np.ndarray,
    references: np.ndarray,
    canvas: Canvas,
    *,
    screening: float = SCREENING,
    smooth_slopes: bool = False,
) -> np.ndarray:
    """A continuous map of the exemplar (height, roughness, ...) through a reference map
    ``(H, W, 2)`` in the gradient domain (see the module): continuous across the borders of the
    copied pieces, tileable when the ``canvas`` tiles (and continued across the exemplar's
    edges along its ``exemplar_wrap``, None: neither). ``smooth_slopes``: the slopes too are continuous
    across the borders (the carried gradients go through the gradient domain first), so
    normals computed from a height resolved this way have no creases there. Same dtype and
    channels as ``source``; integer maps are rounded and clipped to their range, float maps in
    [0, 1] stay in it."""
    src = np.asarray(source)
    refs = np.asarray(references)
    flat = src.ndim == 2
    s3 = src[:, :, None] if flat else src
    u = _as_source_dtype(_integrate(s3, refs, canvas, screening, smooth_slopes), src)
    return u[:, :, 0] if flat else u


def piece_borders(references: np.ndarray, exemplar_shape: tuple[int, int], canvas: Canvas) -> np.ndarray:
    """``(H, W)`` bool: the output pixels on a border between copied pieces, those with a
    4-neighbour whose reference is not the matching neighbour of their own (modulo the exemplar
    along an axis it wraps along, the ``canvas``'s ``exemplar_wrap``; across the output's edges
    only when it tiles)."""
    tile, wrap = canvas.tile, _exemplar_wrap(canvas)
    refs = np.asarray(references).astype(np.int64)
    ry, rx = refs[..., 0], refs[..., 1]
    border = np.zeros(ry.shape, bool)
    for axis, (along, across, period) in enumerate(
        ((ry, rx, int(exemplar_shape[0])), (rx, ry, int(exemplar_shape[1])))
    ):
        step = np.roll(along, -1, axis=axis) - along - 1
        if wrap[axis]:
            step = np.mod(step + period // 2, period) - period // 2
        cut = (step != 0) | (np.roll(across, -1, axis=axis) != across)
        if not tile:
            last: list[slice | int] = [slice(None), slice(None)]
            last[axis] = -1
            cut[tuple(last)] = False
        border |= cut | np.roll(cut, 1, axis=axis)
    return border


def resolve_local(
    source: np.ndarray,
    references: np.ndarray,
    canvas: Canvas,
    *,
    band: int = 8,
    screening: float = SCREENING,
    smooth_slopes: bool = False,
) -> np.ndarray:
    """A local map (a scan's normals, AO, roughness, metalness) through a reference map.

    Exactly the exemplar's copy from ``band`` px inside each piece on; across the borders
    between pieces the gradient-domain map of :func:`resolve_continuous` (no step); the two
    blended linearly over the ``band`` px next to a border. Unlike a height, such a map has no
    level to carry across a piece, so the copy stays exact where it can (laitoch2018 §3.3.1's
    extra channels, with the seams of perez2003 only where pieces meet). Float ``(h, w[, C])``
    maps in, ``(H, W[, C])`` float32 out. ``smooth_slopes``: as :func:`resolve_continuous`'s
    (across the borders the slopes too run on; on the scans' roughness the step across borders
    fell from 1.63x to 1.44x the step inside pieces).
    """
    import cv2

    src = np.asarray(source, dtype=np.float32)
    refs = np.asarray(references)
    exact = src[refs[..., 0], refs[..., 1]]
    smooth = resolve_continuous(src, refs, canvas, screening=screening, smooth_slopes=smooth_slopes)
    inside = (~piece_borders(refs, src.shape[:2], canvas)).astype(np.uint8)
    pad = band + 1 if canvas.tile else 0
    padded = np.pad(inside, pad, mode="wrap") if pad else inside
    # the exact Euclidean distance (the 3x3 mask's falls short of ``band`` on some pixels that are
    # ``band`` px inside, and they were blended)
    distance = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    if pad:
        distance = distance[pad:-pad, pad:-pad]
    alpha = np.clip(distance / float(band), 0.0, 1.0).astype(np.float32)
    if src.ndim == 3:
        alpha = alpha[..., None]
    return (alpha * exact + (1.0 - alpha) * smooth).astype(np.float32)
