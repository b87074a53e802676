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

import functools

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen._shared.canvas import Canvas
from barkgen._shared.threads import side_by_side
from barkgen.errors import InvalidInputError

#: lambda of the screened Poisson equation: a step at a seam spreads over about
#: 1 / sqrt(lambda) px (here ~30), far below the size of a copied piece
SCREENING = 1e-3

#: ``blend`` settings of the colour: ``gradient`` (:func:`blend_seams`) or ``none`` (the exact copy)
BLEND_MODES = ("none", "gradient")

#: lambda of the colour's seam blending: a colour step at a border spreads over about
#: 1 / sqrt(lambda) px (~3). Measured on a 512^2 crop of the shared peeling photo -> 1024^2
#: tiled synth (texeval): lambda 0.01 / 0.05 / 0.2 took the colour step ratio 3.01 -> 1.14 /
#: 1.17 / 1.27 and coherence 0.94 -> 1.41 / 1.08 / 0.95: a weaker anchor lets the seams'
#: mismatches add up into a drift of the colour (W1 0.47 -> 0.90), a stronger one leaves steps
BLEND_SCREENING = 0.1


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
    import scipy.fft as sfft

    tile = boundary.wraps_both
    f = np.asarray(plain, dtype=np.float64)
    H, W = f.shape[:2]
    if tile:
        div = (gx - np.roll(gx, 1, axis=1)) + (gy - np.roll(gy, 1, axis=0))
    else:
        gx = gx.copy()
        gy = gy.copy()
        gx[:, -1] = 0.0
        gy[-1, :] = 0.0
        div = gx.copy()
        div[:, 1:] -= gx[:, :-1]
        div += gy
        div[1:] -= gy[:-1]
    rhs = screening * f - div
    # eigenvalues of the 1-D negative Laplacian: periodic (FFT) or Neumann (DCT-II)
    period = 2.0 if tile else 1.0
    eig_y, eig_x = (2.0 - 2.0 * np.cos(period * np.pi * np.arange(n) / n) for n in (H, W))
    denom = (screening + eig_y[:, None] + eig_x[None, :])[:, :, None]
    if tile:
        return np.real(sfft.ifft2(sfft.fft2(rhs, axes=(0, 1)) / denom, axes=(0, 1)))
    return sfft.idctn(sfft.dctn(rhs, type=2, axes=(0, 1), norm="ortho") / denom, type=2, axes=(0, 1), norm="ortho")


def _integrate(
    source: np.ndarray, references: np.ndarray, canvas: Canvas, screening: float, smooth_slopes: bool
) -> np.ndarray:
    """The gradient-domain map ``(H, W, C)`` float64 of an ``(h, w, C)`` exemplar map, on the
    ``canvas`` (its tile, the exemplar's wrap)."""
    tile, wrap = canvas.tile, _exemplar_wrap(canvas)
    ry, rx = references[..., 0], references[..., 1]
    plain = np.asarray(source, dtype=np.float64)[ry, rx]
    if not smooth_slopes:
        gy, gx = carried_gradients(source, references, wrap)
    else:  # the slopes are continuous maps themselves: carried through their own gradients
        sy, sx = exemplar_steps(source, wrap)
        gy = _integrate(sy, references, canvas, screening, False)
        gx = _integrate(sx, references, canvas, screening, False)
    return screened_poisson(plain, gy, gx, Boundary(tile), screening=screening)


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


def blend_seams(
    source: np.ndarray, references: np.ndarray, canvas: Canvas, *, screening: float = BLEND_SCREENING
) -> np.ndarray:
    """The colour (or any local map) of the exemplar through a reference map, its seams blended
    in the gradient domain.

    The copy of every pixel's reference keeps whatever low-frequency mismatch two pieces have
    (light falloff, a shadow, a colour cast) as a step at their border. Here the texture is
    composed from the exemplar's gradients at each pixel's reference and re-integrated
    (screened Poisson, FFT on the torus when the ``canvas`` tiles; Pérez et al. 2003, as Kwatra et al.
    2003 suggest for the seams a cut leaves), anchored to the copied colour by ``screening``,
    so the step at a border spreads over a few pixels either side and nothing drifts: inside
    a piece, a few pixels from its border, the pixels are the photo's own (to rounding).
    :func:`resolve_continuous` with a strong anchor; same dtype and shape.

    References
    ----------
    .. [1] perez2003 (Poisson image editing).
    .. [2] kwatra2003, §3 (gradient-domain blending of residual seams).
    """
    src = np.asarray(source)
    if src.ndim == 2:
        return resolve_continuous(src, references, canvas, screening=screening)
    # channel by channel (the solve's float64 transforms of one channel at a time), side by side
    channels = side_by_side(
        [
            functools.partial(resolve_continuous, src[..., c], references, canvas, screening=screening)
            for c in range(src.shape[2])
        ],
        pixels=references.shape[0] * references.shape[1],
    )
    return np.stack(channels, axis=-1)


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
    u = _integrate(s3, refs, canvas, screening, smooth_slopes)
    if src.dtype.kind in "ui":
        info = np.iinfo(src.dtype)
        u = np.clip(np.rint(u), info.min, info.max).astype(src.dtype)
    else:
        lo, hi = float(src.min()), float(src.max())
        if lo >= 0.0 and hi <= 1.0:
            u = np.clip(u, 0.0, 1.0)
        u = u.astype(src.dtype)
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
