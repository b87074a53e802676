"""A scanned set's maps brought to its colour: resampled to its size, each map's own wrap, its
normals' green convention told from its height, and a specular map read as roughness.

Game and scan sets often ship maps of different sizes (a 2048 px colour, a 512 px normal, a 256 px
height). :func:`resample_map` brings each to the colour's size: area-averaged down
(``cv2.INTER_AREA``), bicubic up; along an axis where that map tiles itself (:func:`own_wraps`,
judged per map, never from the colour) it is padded by wrapping before resizing and cropped
after, so its edges still meet; normals are resampled as vectors and renormalised; every map is
resampled in float, so a 16-bit map keeps its precision.

A normal map's green channel is +Y up in OpenGL (glTF, Blender, Poly Haven, ambientCG's
``NormalGL``) and +Y down in DirectX (Unreal, ambientCG's ``NormalDX``); the names often do not
say which. Where the set has a height too, :func:`normal_convention_evidence` tells it from the
relief itself (see there).
"""

from __future__ import annotations

import math

import numpy as np

#: the largest difference of aspect ratio (relative) a map may have from the colour's and still
#: be resampled onto it
ASPECT_TOLERANCE = 0.02
#: the least |correlation| between a normal map's red channel and its height's x slope, and
#: between its green and the y slope, for the height to tell the green's convention
CONVENTION_EVIDENCE = 0.1
#: the roughness range a specular map's level is spread over (bark is never mirror-like)
SPECULAR_ROUGHNESS = (0.4, 1.0)


def own_wraps(image: np.ndarray) -> tuple[bool, bool]:
    """``(rows, columns)``: the axes along which a map tiles itself, from its own pixels
    (:func:`barkgen.synth.exemplar_wraps`: its edge step against its neighbour and far steps)."""
    from barkgen.synth import exemplar_wraps

    return exemplar_wraps(np.asarray(image, np.float32))


def fits_aspect(shape: tuple[int, int], target: tuple[int, int]) -> bool:
    """A map of ``shape`` ``(h, w)`` covers the colour's ``target`` (same aspect ratio within
    :data:`ASPECT_TOLERANCE`), so it can be resampled onto it."""
    (h, w), (th, tw) = shape[:2], target[:2]
    return abs((th / h) / (tw / w) - 1.0) <= ASPECT_TOLERANCE


def _wrap_pad(n: int, m: int) -> int:
    """Pixels to pad a wrapping axis of ``n`` px resized to ``m`` px by: a multiple of
    ``n / gcd(n, m)`` (so the pad is a whole number of pixels at both sizes and the crop lands
    exactly) of at least 4 px and a target pixel, at most ``n``."""
    unit = n // math.gcd(n, m)
    need = max(4, math.ceil(n / m) + 2)
    return min(n, unit * max(1, math.ceil(need / unit)))


def resample_map(
    image: np.ndarray, size: tuple[int, int], *, wraps: tuple[bool, bool] = (False, False), normals: bool = False
) -> np.ndarray:
    """A map resampled to ``size`` ``(h, w)``: area-averaged down, bicubic up, wrapping along
    the axes it tiles along (``wraps``); float32 out.

    Parameters
    ----------
    image : ndarray, shape (h, w[, C])
        Float map (values in [0, 1], or unit normals when ``normals``).
    size : (int, int)
        The colour's ``(h, w)``.
    wraps : (bool, bool)
        ``(rows, columns)``: the map tiles along that axis (:func:`own_wraps`); it is padded by
        wrapping there before resizing and cropped after, so its edges still meet.
    normals : bool
        The map holds unit vectors: each component resampled, then renormalised.

    Returns
    -------
    ndarray of float32, shape (size[0], size[1][, C])
        Same channels; a level map clipped to [0, 1] (bicubic overshoots).

    References
    ----------
    .. [1] wang2003 §3.3 (the material's maps aligned pixel for pixel with its colour).
    """
    import cv2

    src = np.asarray(image, np.float32)
    h, w = src.shape[:2]
    th, tw = int(size[0]), int(size[1])
    if (h, w) == (th, tw):
        return src.copy()
    interpolation = cv2.INTER_AREA if th <= h and tw <= w else cv2.INTER_CUBIC
    pads = [_wrap_pad(n, m) if wrap else 0 for n, m, wrap in zip((h, w), (th, tw), wraps)]
    if any(pads):
        widths = [(pads[0], pads[0]), (pads[1], pads[1])] + [(0, 0)] * (src.ndim - 2)
        src = np.pad(src, widths, mode="wrap")
    out_pads = [p * m // n for p, n, m in zip(pads, (h, w), (th, tw))]
    dsize = (tw + 2 * out_pads[1], th + 2 * out_pads[0])
    out = cv2.resize(src, dsize, interpolation=interpolation)
    if src.ndim == 3 and out.ndim == 2:  # OpenCV drops a single channel's axis
        out = out[:, :, None]
    out = out[out_pads[0] : out_pads[0] + th, out_pads[1] : out_pads[1] + tw]
    if normals:
        out = out / np.maximum(np.linalg.norm(out, axis=2, keepdims=True), 1e-6)
    else:
        out = np.clip(out, 0.0, 1.0)
    return np.ascontiguousarray(out, dtype=np.float32)


def normal_convention_evidence(normals: np.ndarray, height: np.ndarray) -> tuple[str | None, float]:
    """Which green convention a normal map follows, told from a height map of the same set.

    The normal of a height field ``h`` (rows going down the image, OpenGL's +Y up) is along
    ``(-dh/dx, +dh/drow, 1)``: OpenGL's green (+Y up) rises where the height rises *down* the
    rows; DirectX's (+Y down) falls there. Decoded as OpenGL, a DirectX map's ``ny`` thus
    correlates negatively with ``dh/drow``. The red channel is the same in both conventions, so
    its correlation with ``-dh/dx`` fixes the height's sign (a map stored as depth, white =
    deep, flips both): the convention is OpenGL where the two correlations have one sign.

    Parameters
    ----------
    normals : ndarray, shape (h, w, 3)
        Unit normals decoded as OpenGL (green = +Y up).
    height : ndarray, shape (h, w)
        The set's height, same size.

    Returns
    -------
    convention : {"gl", "dx"} or None
        ``None`` when the evidence is too weak (|correlation| below
        :data:`CONVENTION_EVIDENCE` on either axis: a flat map, or a height of another relief).
    correlation : float
        The green's correlation with the height's slope down the rows, signed by the red's.
    """
    h = np.asarray(height, np.float64)
    n = np.asarray(normals, np.float64)
    nz = np.maximum(n[..., 2], 0.05)
    slope_rows, slope_cols = np.gradient(h)

    def correlation(a: np.ndarray, b: np.ndarray) -> float:
        a, b = a.ravel() - a.mean(), b.ravel() - b.mean()
        den = math.sqrt(float((a * a).sum()) * float((b * b).sum()))
        return float((a * b).sum() / den) if den > 0 else 0.0

    along_x = correlation(-n[..., 0] / nz, slope_cols)
    along_y = correlation(n[..., 1] / nz, slope_rows)
    signed = along_y * (1.0 if along_x >= 0 else -1.0)
    if min(abs(along_x), abs(along_y)) < CONVENTION_EVIDENCE:
        return None, signed
    return ("gl" if signed > 0 else "dx"), signed


def specular_roughness(specular: np.ndarray) -> np.ndarray:
    """A roughness map from a specular map, for a set that has no roughness (or gloss) map.

    Assumes what game packs' ``_sc`` / ``_spec`` maps and Megascans' ``Specular`` mean for a
    dielectric such as bark: a brighter specular level is a shinier, smoother spot (wet or
    polished plates), a darker one a rougher, duller spot; the map's absolute level (an F0 or an
    artist's intensity) carries no roughness of its own. So the level (the mean of its channels
    for a coloured specular map) is spread over its own 1st-99th percentile and inverted, into
    :data:`SPECULAR_ROUGHNESS` (0.4 at the shiniest, 1.0 at the dullest); a flat map gives the
    middle of that range.

    Parameters
    ----------
    specular : ndarray, shape (h, w[, C])
        The specular map in [0, 1].

    Returns
    -------
    ndarray of float32, shape (h, w)
    """
    level = np.asarray(specular, np.float32)
    if level.ndim == 3:
        level = level.mean(axis=2)
    low, high = np.percentile(level, (1.0, 99.0))
    lo, hi = SPECULAR_ROUGHNESS
    if high - low <= 1e-6:
        return np.full(level.shape, 0.5 * (lo + hi), np.float32)
    shine = np.clip((level - low) / (high - low), 0.0, 1.0)
    return (hi - (hi - lo) * shine).astype(np.float32)
