"""The photo's broad light taken out before anything else learns from it (light equalisation).

A bark photo is lit: a trunk photographed round its curve is bright on one side and dark on the
other, a light falls off across the frame, leaves throw soft dappled light. That light is not
bark, yet the label map (laitoch2018 §3.5) would split the photo into "lit" and "shaded", the
synthesis would copy the bands, and a tiled set would repeat them. Substance Sampler and
Materialize equalise the light first; so does barkgen, before the label map, the synthesis and
the material maps.

The model is wang2003 §3.4's — the photo is the albedo times a shading — restricted to the
shading's lowest frequencies: ``photo = albedo x L`` in linear light, with ``L`` one grey gain
per pixel that varies slowly. ``log L`` is estimated from the log-luminance:

1. a smooth trend (a quadratic in x and y, along the axes the photo does not wrap along): a
   falloff round the trunk's curve, a gradient across the frame;
2. what remains, averaged over a Gaussian window of :data:`WINDOW` of the photo's width
   (normalised convolution): the softer blobs of dappled light.

Each part is kept only as far as it stands out of what the bark alone would give the same
estimate (its residual's block means, spread over the estimate's reach: :data:`NOISE_MARGIN`):
a bark's own plates and patches are not light, and a photo in even light is left as it is.
Both are weighted by how much a neighbourhood's colour is the bark's usual colour: white light
scales the three channels alike and leaves the chromaticity (``log R/G``, ``log B/G``) as it
is, so a patch of another hue (moss, lichen, peeled bark) is the albedo's own, not light; its
neighbourhood's weight falls, and the light there is taken from the bark around it. A patch of
the bark's own hue that is only brighter cannot be told from light and goes with it.

Estimated at about :data:`WORK_SIDE` px a side (the light is smooth), then resampled: a few
tens of milliseconds for a 1024x1024 photo.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.arrays import Boundary, unit_float
from barkgen.color import linear_to_srgb, srgb_to_linear
from barkgen.errors import InvalidInputError

#: the window of the light's local part, as a fraction of the photo's larger side (sigma)
WINDOW = 0.1
#: the neighbourhood whose colour decides whether it is bark (a fraction of the window)
CHROMA_WINDOW = 0.25
#: how far (in median absolute deviations of the chromaticity) a neighbourhood's colour may be
#: from the bark's usual before its weight falls to 1/e
CHROMA_TOLERANCE = 2.0
#: the side (px) the light is estimated at
WORK_SIDE = 256
#: floor of the linear luminance under the logarithm (a black pixel has no light to measure)
LUMINANCE_FLOOR = 1e-3
#: how many times the variance the bark alone would give the estimate (its residual's block
#: means spread over the estimate's reach) a part of the light's must exceed before any of it
#: is taken out (all of it from twice that: the bark of a photo in even light, a pine's plates or a birch's lenticels, is not light)
NOISE_MARGIN = 4.0
#: the largest gain the equalisation applies (a region the estimate says is this dark is
#: brightened no further: there is no colour left under the noise)
MAX_GAIN = 8.0

_LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)


def check_strength(strength: float) -> float:
    """A light-equalisation strength in [0, 1] (0: the photo's light kept, 1: taken out)."""
    if isinstance(strength, bool) or not isinstance(strength, (int, float, np.floating, np.integer)):
        raise InvalidInputError(f"the light equalisation's strength must be a number, not {strength!r}")
    if not (np.isfinite(strength) and 0.0 <= strength <= 1.0):
        raise InvalidInputError(f"the light equalisation's strength must be in [0, 1], not {strength:g}")
    return float(strength)


def estimate_illumination(photo: np.ndarray, *, boundary: Boundary | None = None) -> np.ndarray:
    """The photo's broad light: a grey gain per pixel, geometric mean 1 (see the module
    docstring).

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        sRGB, uint8, uint16 or float in [0, 1].
    boundary : Boundary, optional
        Where the photo wraps (both axes, or ``(rows, columns)``): so does the light, and it
        has no trend along a wrapping axis (default: nowhere).

    Returns
    -------
    ndarray of float32, shape (h, w)
        ``L``: the photo is its albedo times ``L`` in linear light.

    References
    ----------
    .. [1] wang2003, §3.4 (shading removal: photo = albedo x shading).

    Examples
    --------
    >>> import numpy as np
    >>> ramp = np.linspace(0.2, 0.8, 64, dtype=np.float32)
    >>> photo = np.dstack([np.tile(ramp, (64, 1))] * 3)
    >>> light = estimate_illumination(photo)
    >>> bool(light[:, -1].mean() > 2 * light[:, 0].mean())
    True
    """
    import cv2  # (here: the CLI's start-up imports this module, and a refusal needs no OpenCV)

    boundary = boundary or Boundary()
    linear = _linear_rgb(photo)
    h, w = linear.shape[:2]
    scale = min(1.0, WORK_SIDE / max(h, w))
    small_shape = (max(2, round(h * scale)), max(2, round(w * scale)))
    log_lum = np.log(linear @ _LUMA + LUMINANCE_FLOOR).astype(np.float32)
    green = linear[..., 1] + LUMINANCE_FLOOR
    chroma = np.dstack(
        [np.log((linear[..., 0] + LUMINANCE_FLOOR) / green), np.log((linear[..., 2] + LUMINANCE_FLOOR) / green)]
    ).astype(np.float32)
    # the light is smooth: everything below is at the working size (areas averaged)
    small_lum = cv2.resize(log_lum, small_shape[::-1], interpolation=cv2.INTER_AREA)
    small_chroma = cv2.resize(chroma, small_shape[::-1], interpolation=cv2.INTER_AREA)
    sigma = WINDOW * max(small_shape)
    weight = _bark_colour_weight(small_chroma, sigma * CHROMA_WINDOW, boundary)
    trend, local = _broad_field(small_lum, weight, sigma, boundary)
    # what the same estimate would make of the bark alone: the variance of its residual's means
    # over blocks of half the window, spread over the window's area (the local part) and over
    # the whole photo with the trend's terms (the trend); each part of the light is kept only
    # as far as it stands above that
    block = max(sigma / 2, 1.0)
    residual = small_lum - trend - local
    block_var = float(_box(residual, block, boundary).var())
    noise_local = block_var * block**2 / (4 * np.pi * sigma**2)
    noise_trend = block_var * block**2 * _trend_terms(boundary) / small_lum.size
    log_light = trend * _significance(float(trend.var()), noise_trend) + local * _significance(
        float(local.var()), noise_local
    )
    log_light -= float(log_light.mean())
    return np.exp(_resized(log_light, (h, w), boundary)).astype(np.float32)


def _broad_field(
    log_lum: np.ndarray, weight: np.ndarray, sigma: float, boundary: Boundary
) -> tuple[np.ndarray, np.ndarray]:
    """The weighted quadratic trend of ``log_lum``, and the weighted Gaussian mean (``sigma``)
    of what remains."""
    trend = _weighted_trend(log_lum, weight, boundary)
    rest = log_lum - trend
    return trend, _gaussian(weight * rest, sigma, boundary) / np.maximum(_gaussian(weight, sigma, boundary), 1e-6)


def _significance(signal_var: float, noise_var: float) -> float:
    """The share of a part of the light that is kept, by how far its variance stands above what
    the bark alone gives the estimate: none up to :data:`NOISE_MARGIN` times it, all from
    twice that, linear between."""
    ratio = signal_var / max(noise_var, 1e-12)
    return float(np.clip((ratio - NOISE_MARGIN) / NOISE_MARGIN, 0.0, 1.0))


def _box(values: np.ndarray, side: float, boundary: Boundary) -> np.ndarray:
    """The mean of ``values`` over a square of ``side`` px round each pixel (across the edges it
    wraps along, mirrored at the others): every block's mean, whatever the blocks' offset."""
    import cv2

    size = max(int(round(side)), 1)
    pad = min(size, max(values.shape))
    return boundary.torus(
        lambda im: cv2.blur(im, (size, size), borderType=cv2.BORDER_REFLECT), values.astype(np.float32), pad
    )


def _trend_terms(boundary: Boundary) -> int:
    """The non-constant terms of :func:`_weighted_trend`: a quadratic in the free axes."""
    free = 2 - sum(boundary.wrap)
    return free + free * (free + 1) // 2


def equalize_light(
    photo: np.ndarray, strength: float = 1.0, *, boundary: Boundary | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The photo with its broad light taken out, ``strength`` of the way.

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        sRGB, uint8, uint16 or float in [0, 1] (a fourth channel, alpha, is kept as it is).
    strength : float, default 1.0
        0 keeps the photo's light (the photo is returned as it is), 1 takes it all out.
    boundary : Boundary, optional
        Where the photo wraps (:func:`estimate_illumination`).

    Returns
    -------
    equalized : ndarray
        The photo divided by ``L ** strength`` in linear light, in the photo's dtype and shape.
    light : ndarray of float32, shape (h, w)
        ``L`` (:func:`estimate_illumination`), whatever the strength: the equalised photo
        times ``L ** strength`` is the photo again (where nothing clipped).

    Raises
    ------
    InvalidInputError
        A strength outside [0, 1].
    """
    strength = check_strength(strength)
    arr = np.asarray(photo)
    light = estimate_illumination(arr, boundary=boundary)
    if strength == 0.0:
        return arr, light
    return relit(arr, light, -strength), light


def relit(photo: np.ndarray, light: np.ndarray, power: float) -> np.ndarray:
    """``photo`` times ``light ** power`` in linear light (the gain capped at :data:`MAX_GAIN`
    either way), in the photo's dtype; a fourth channel is kept as it is.

    ``relit(equalized, light, strength)`` puts back what :func:`equalize_light` took out."""
    arr = np.asarray(photo)
    gain = np.clip(np.asarray(light, np.float32) ** np.float32(power), 1.0 / MAX_GAIN, MAX_GAIN)
    colour = arr if arr.ndim == 2 else arr[..., :3]
    linear = srgb_to_linear(unit_float(colour))
    out = linear_to_srgb(linear * (gain if arr.ndim == 2 else gain[..., None]))
    out = _as_dtype(out, arr.dtype)
    if arr.ndim == 3 and arr.shape[2] > 3:
        out = np.concatenate([out, arr[..., 3:]], axis=2)
    return out


#: the range of ``log2 L`` a 16-bit illumination map holds (1/16 to 16)
_LOG2_RANGE = 8.0


def encode_illumination(light: np.ndarray) -> np.ndarray:
    """A light field ``L`` as a 16-bit grey map: ``0.5 + log2(L) / 16`` of full scale (``L`` from
    1/16 to 16, 1 at mid-grey), for ``illumination.png``."""
    levels = 0.5 + np.log2(np.maximum(np.asarray(light, np.float64), 1e-9)) / (2 * _LOG2_RANGE)
    return np.floor(np.clip(levels, 0.0, 1.0) * 65535 + 0.5).astype(np.uint16)


def decode_illumination(levels: np.ndarray) -> np.ndarray:
    """``L`` of a map :func:`encode_illumination` made, float32."""
    unit = unit_float(np.asarray(levels))
    if unit.ndim == 3:
        unit = unit[..., 0]
    return np.exp2((unit.astype(np.float64) - 0.5) * 2 * _LOG2_RANGE).astype(np.float32)


def _linear_rgb(photo: np.ndarray) -> np.ndarray:
    arr = unit_float(np.asarray(photo))
    if arr.ndim == 2:
        arr = np.repeat(arr[..., None], 3, axis=2)
    elif arr.shape[2] < 3:
        arr = np.repeat(arr[..., :1], 3, axis=2)
    return srgb_to_linear(arr[..., :3])


def _as_dtype(values: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """sRGB values in [0, 1] in ``dtype`` (integers rounded)."""
    if dtype == np.uint8:
        return np.floor(values * 255 + 0.5).astype(np.uint8)
    if dtype == np.uint16:
        return np.floor(values * 65535 + 0.5).astype(np.uint16)
    return values.astype(dtype if np.dtype(dtype).kind == "f" else np.float32)


def _gaussian(image: np.ndarray, sigma: float, boundary: Boundary) -> np.ndarray:
    import cv2

    pad = min(int(np.ceil(3 * sigma)) + 1, max(image.shape[:2]))
    return boundary.torus(lambda im: cv2.GaussianBlur(im, (0, 0), sigma, borderType=cv2.BORDER_REFLECT), image, pad)


def _bark_colour_weight(chroma: np.ndarray, sigma: float, boundary: Boundary) -> np.ndarray:
    """1 where a neighbourhood's chromaticity is the photo's usual, falling off (Gaussian in
    median absolute deviations) where it is another hue."""
    local = _gaussian(chroma, sigma, boundary)
    usual = np.median(local.reshape(-1, 2), axis=0)
    distance = np.linalg.norm(local - usual, axis=2)
    spread = float(np.median(distance)) + 1e-6
    return np.exp(-((distance / (CHROMA_TOLERANCE * spread)) ** 2)).astype(np.float32)


def _weighted_trend(values: np.ndarray, weight: np.ndarray, boundary: Boundary) -> np.ndarray:
    """The weighted least-squares quadratic of ``values`` in x and y, in the variables of the
    axes that do not wrap (a wrapping axis has no trend)."""
    wrap_rows, wrap_cols = boundary.wrap
    h, w = values.shape
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    x, y = x / max(w - 1, 1) - 0.5, y / max(h - 1, 1) - 0.5
    free = ([x] if not wrap_cols else []) + ([y] if not wrap_rows else [])
    terms = [np.ones_like(x)] + free + [a * b for i, a in enumerate(free) for b in free[i:]]
    basis = np.stack([t.ravel() for t in terms], axis=1)
    root = np.sqrt(weight.ravel().astype(np.float64))
    coef = np.linalg.lstsq(basis * root[:, None], values.ravel() * root, rcond=None)[0]
    return (basis @ coef).reshape(h, w).astype(np.float32)


def _resized(values: np.ndarray, shape: tuple[int, int], boundary: Boundary) -> np.ndarray:
    """A smooth field resampled to ``shape`` (bilinear; across the edge where it wraps)."""
    import cv2

    h, w = shape
    if values.shape == (h, w):
        return values
    wrap_rows, wrap_cols = boundary.wrap
    pad_y, pad_x = int(wrap_rows), int(wrap_cols)
    padded = np.pad(values, ((pad_y, pad_y), (pad_x, pad_x)), mode="wrap")
    sy, sx = values.shape[0] / h, values.shape[1] / w
    # output pixel centres in the small field's pixel coordinates (plus the wrap padding)
    map_y = ((np.arange(h, dtype=np.float32) + 0.5) * sy - 0.5 + pad_y)[:, None]
    map_x = ((np.arange(w, dtype=np.float32) + 0.5) * sx - 0.5 + pad_x)[None, :]
    map_y, map_x = np.broadcast_to(map_y, (h, w)), np.broadcast_to(map_x, (h, w))
    return cv2.remap(
        padded,
        np.ascontiguousarray(map_x),
        np.ascontiguousarray(map_y),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )
