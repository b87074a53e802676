"""A scanned set's maps brought to its colour: resampled to its size, each map's own wrap, its
normals' green convention told from its height, and a specular map read as roughness.

Game and scan sets often ship maps of different sizes (a 2048 px colour, a 512 px normal, a 256 px
height). :func:`resample_map` brings each to the colour's size: area-averaged down
(``cv2.INTER_AREA``), bicubic up (a cubic spline); along an axis where that map tiles itself (:func:`own_wraps`,
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
#: a map wraps along an axis where its mean step from last row to first is at most this many
#: times its mean step between neighbouring rows (or as :func:`barkgen.synth.exemplar_wraps`
#: says): a small or noise-like map, whose rows half the map apart are hardly further apart than
#: neighbours, gives that test no span to judge by (the team's scans at 128 px: edge / inner step
#: 0.75-1.3 on every map; at 1024 px their normal and roughness maps, which do not tile, 2.6-4.5)
EDGE_STEP_RATIO = 1.5
#: the least |correlation| between a normal map's red channel and its height's x slope, and
#: between its green and the y slope, for the height to tell the green's convention
CONVENTION_EVIDENCE = 0.1
#: the roughness range a specular map's level is spread over (bark is never mirror-like)
SPECULAR_ROUGHNESS = (0.4, 1.0)


def own_wraps(image: np.ndarray) -> tuple[bool, bool]:
    """``(rows, columns)``: the axes along which a map tiles itself, from its own pixels: its
    step from last row to first is at most :data:`EDGE_STEP_RATIO` times its step between
    neighbouring rows, or :func:`barkgen.synth.exemplar_wraps` (the colour's test: the edge
    step against the neighbours' and far rows') says it wraps. Judged per map, never from the
    colour: a scan's height may not tile where its colour does."""
    from barkgen.synth import exemplar_wraps

    img = np.asarray(image, np.float32)
    by_shares = exemplar_wraps(img)
    wraps = []
    for axis in (0, 1):
        if img.shape[axis] < 4:
            wraps.append(False)
            continue
        inner = float(np.abs(np.diff(img, axis=axis)).mean())
        edge = float(np.abs(np.take(img, 0, axis=axis) - np.take(img, -1, axis=axis)).mean())
        wraps.append(bool(by_shares[axis] or edge <= EDGE_STEP_RATIO * inner))
    return wraps[0], wraps[1]


def fits_aspect(shape: tuple[int, int], target: tuple[int, int]) -> bool:
    """A map of ``shape`` ``(h, w)`` covers the colour's ``target`` (same aspect ratio within
    :data:`ASPECT_TOLERANCE`), so it can be resampled onto it."""
    (h, w), (th, tw) = shape[:2], target[:2]
    return abs((th / h) / (tw / w) - 1.0) <= ASPECT_TOLERANCE


def _wrap_pad(n: int, m: int, least: int = 4) -> int:
    """Pixels to pad a wrapping axis of ``n`` px resized to ``m`` px by: a multiple of
    ``n / gcd(n, m)`` (so the pad is a whole number of pixels at both sizes and the crop lands
    exactly) of at least ``least`` px and a target pixel, at most ``n``."""
    unit = n // math.gcd(n, m)
    need = max(least, math.ceil(n / m) + 2)
    return min(n, unit * max(1, math.ceil(need / unit)))


def _cubic_up(image: np.ndarray, size: tuple[int, int], wraps: tuple[bool, bool]) -> np.ndarray:
    """``(h, w, C)`` float32 enlarged to ``size`` by cubic-spline interpolation (pixel areas
    aligned as OpenCV's are), on the torus along both axes when it wraps along both, else
    padded by wrapping along a wrapping axis (and mirrored at the others') and cropped."""
    from scipy import ndimage

    h, w = image.shape[:2]
    th, tw = size
    if wraps[0] and wraps[1]:
        pads, mode = [0, 0], "grid-wrap"
    else:
        pads, mode = [_wrap_pad(n, m, least=8) if wrap else 0 for n, m, wrap in zip((h, w), (th, tw), wraps)], "mirror"
    src = np.pad(image, [(pads[0], pads[0]), (pads[1], pads[1]), (0, 0)], mode="wrap") if any(pads) else image
    out_pads = [p * m // n for p, n, m in zip(pads, (h, w), (th, tw))]
    shape = (th + 2 * out_pads[0], tw + 2 * out_pads[1])
    zoom = (shape[0] / src.shape[0], shape[1] / src.shape[1])
    channels = [
        ndimage.zoom(src[..., c], zoom, order=3, mode=mode, grid_mode=True, output=np.float32)
        for c in range(src.shape[2])
    ]
    out = np.stack(channels, axis=2)
    return out[out_pads[0] : out_pads[0] + th, out_pads[1] : out_pads[1] + tw]


def resample_map(
    image: np.ndarray, size: tuple[int, int], *, wraps: tuple[bool, bool] = (False, False), normals: bool = False
) -> np.ndarray:
    """A map resampled to ``size`` ``(h, w)``: area-averaged down (``cv2.INTER_AREA``),
    bicubic up (cubic-spline interpolation, ``scipy.ndimage.zoom(order=3)``), wrapping along
    the axes it tiles along (``wraps``); float32 out.

    Up, the cubic spline rather than OpenCV's bicubic (Keys' kernel): the latter's slopes kink
    at every source pixel, the same in every row, so an 8x enlarged height carries its source
    grid as straight lines across the whole map (256 px at 256 px, by
    :func:`barkgen.evaluate.longest_line`; the spline's: 73 px, as the map at full size).

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
        Same channels; a level map clipped to [0, 1] (the cubic overshoots).

    References
    ----------
    .. [1] wang2003 §3.3 (the material's maps aligned pixel for pixel with its colour).
    """
    import cv2

    src = np.asarray(image, np.float32)
    flat = src.ndim == 2
    src = src[:, :, None] if flat else src
    h, w = src.shape[:2]
    th, tw = int(size[0]), int(size[1])
    out: np.ndarray
    if (h, w) == (th, tw):
        out = src.copy()
    elif th <= h and tw <= w:
        pads = [_wrap_pad(n, m) if wrap else 0 for n, m, wrap in zip((h, w), (th, tw), wraps)]
        padded = np.pad(src, [(pads[0], pads[0]), (pads[1], pads[1]), (0, 0)], mode="wrap") if any(pads) else src
        out_pads = [p * m // n for p, n, m in zip(pads, (h, w), (th, tw))]
        dsize = (tw + 2 * out_pads[1], th + 2 * out_pads[0])
        out = cv2.resize(padded, dsize, interpolation=cv2.INTER_AREA).reshape(dsize[1], dsize[0], -1)
        out = out[out_pads[0] : out_pads[0] + th, out_pads[1] : out_pads[1] + tw]
    else:
        out = _cubic_up(src, (th, tw), wraps)
    if normals:
        out = out / np.maximum(np.linalg.norm(out, axis=2, keepdims=True), 1e-6)
    else:
        out = np.clip(out, 0.0, 1.0)
    out = np.ascontiguousarray(out, dtype=np.float32)
    return out[:, :, 0] if flat else out


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
    slope_rows, slope_cols = (np.asarray(g) for g in np.gradient(h))

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
