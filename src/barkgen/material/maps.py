"""Normal, ambient-occlusion and roughness maps from a height field (mazzolini2012 §7.1's future
work, in ambientCG's conventions: OpenGL normals, AO and roughness in [0, 1]).

Heights are in pixels (a unit slope is 45°). Normals are tangent-space unit vectors
``(x right, y up, z out)`` — the OpenGL / glTF convention; :func:`to_directx` flips green for
Unreal and Substance. Every map honours its ``boundary``: a tileable height gives tileable maps.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.arrays import Boundary

#: directions and reach (px) of the horizon-based ambient occlusion
AO_DIRECTIONS = 8
AO_RADIUS = 32
#: the photo's own cavities in the AO (:func:`photo_cavities`): how much (in units of the
#: height AO's spread) and below which scale (px), as fitted on the scanned AO of four barks
CAVITY_WEIGHT = 1.0
CAVITY_SCALE = 32
#: roughness model: bark is rough; cavities (occluded) rougher, exposed ridges a little smoother
ROUGHNESS_BASE = 0.8
ROUGHNESS_CAVITY = 0.6
ROUGHNESS_RIDGE = 0.05


def normal_map(height: np.ndarray, *, strength: float = 1.0, boundary: Boundary | None = None) -> np.ndarray:
    """Unit normals of a height field, OpenGL convention.

    Parameters
    ----------
    height : ndarray, shape (h, w)
        Height in pixels.
    strength : float, default 1.0
        Multiplies the slopes.
    boundary : Boundary, optional
        Where the height wraps (both axes, or ``(rows, columns)``): slopes are taken across those
        edges (default: nowhere).

    Returns
    -------
    ndarray of float32, shape (h, w, 3)
        Unit normals, +Y up: green is high where the surface faces the top of the image.

    References
    ----------
    .. [1] wang2003, §3.4 (normals of the height field, for the shading).

    Examples
    --------
    >>> import numpy as np
    >>> normal_map(np.zeros((4, 4)))[0, 0].tolist() == [0.0, 0.0, 1.0]
    True
    """
    gx, gy = (boundary or Boundary()).gradient(height)
    normals = np.empty(gx.shape + (3,), np.float32)
    normals[..., 0] = -strength * gx
    normals[..., 1] = strength * gy  # rows run down, +Y runs up
    normals[..., 2] = 1.0
    normals /= np.linalg.norm(normals, axis=2, keepdims=True)
    return normals


def to_directx(normals: np.ndarray) -> np.ndarray:
    """The DirectX convention (+Y down) of OpenGL normals, and back: green flipped.

    Parameters
    ----------
    normals : ndarray, shape (..., 3)
        Unit normals (float).

    Returns
    -------
    ndarray
        A copy with ``y`` negated.
    """
    out = np.array(normals, copy=True)
    out[..., 1] = -out[..., 1]
    return out


def encode_normals(normals: np.ndarray, bits: int = 8) -> np.ndarray:
    """Unit normals as the usual normal-map pixels, ``round((n + 1) * 127.5)`` (8-bit) or
    ``round((n + 1) * 32767.5)`` (16-bit).

    Parameters
    ----------
    normals : ndarray, shape (h, w, 3)
        Unit normals (float, clipped to [-1, 1]).
    bits : {8, 16}, default 8
        Bits per channel.

    Returns
    -------
    ndarray of uint8 or uint16, shape (h, w, 3)
        RGB normal-map pixels.

    Examples
    --------
    >>> import numpy as np
    >>> encode_normals(np.array([[[0.0, 0.0, 1.0]]])).tolist()
    [[[128, 128, 255]]]
    """
    n = np.clip(np.asarray(normals, np.float32), -1.0, 1.0)
    if bits == 16:
        return np.floor((n.astype(np.float64) + 1.0) * 32767.5 + 0.5).astype(np.uint16)
    return np.floor((n + 1.0) * 127.5 + 0.5).astype(np.uint8)


def flip_green(rgb: np.ndarray) -> np.ndarray:
    """An encoded normal map in the other convention (OpenGL <-> DirectX): ``255 - green``
    (``65535 - green`` for 16-bit).

    Every other byte is unchanged; decoding the result gives exactly the normals with ``y``
    negated.

    Parameters
    ----------
    rgb : ndarray of uint8 or uint16, shape (h, w, 3)
        Encoded normals (:func:`encode_normals`).

    Returns
    -------
    ndarray, shape (h, w, 3)
        The same normals in the other convention, same dtype.
    """
    out = np.array(rgb, copy=True)
    out[..., 1] = np.iinfo(out.dtype).max - out[..., 1]
    return out


def decode_normals(rgb: np.ndarray) -> np.ndarray:
    """Normal-map pixels as unit normals.

    Parameters
    ----------
    rgb : ndarray of uint8 or uint16, shape (h, w, C), C >= 3
        Encoded normals (the first three channels are used).

    Returns
    -------
    ndarray of float32, shape (h, w, 3)
        Unit normals.
    """
    arr = np.asarray(rgb)
    scale = 65535.0 if arr.dtype == np.uint16 else 255.0
    n = arr[..., :3].astype(np.float32) / scale * 2.0 - 1.0
    return n / np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-6)


def ambient_occlusion(
    height: np.ndarray,
    *,
    radius: int = AO_RADIUS,
    directions: int = AO_DIRECTIONS,
    boundary: Boundary | None = None,
) -> np.ndarray:
    """Horizon-based ambient occlusion of a height field.

    Parameters
    ----------
    height : ndarray, shape (h, w)
        Height in pixels.
    radius : int, default AO_RADIUS
        Reach of the horizon search, in pixels.
    directions : int, default AO_DIRECTIONS
        Directions searched, evenly spaced.
    boundary : Boundary, optional
        Where the height wraps (both axes, or ``(rows, columns)``) (default: nowhere).

    Returns
    -------
    ndarray of float32, shape (h, w)
        Occlusion in [0, 1], 1 = open sky.

    References
    ----------
    .. [1] bavoil2008 (horizon-based ambient occlusion).
    """
    angles = np.arange(directions) * (2 * np.pi / directions)
    dirs = np.stack([np.sin(angles), np.cos(angles)], axis=1).astype(np.float64)
    wy, wx = (boundary or Boundary()).wrap
    from barkgen._shared.bands import row_bands
    from barkgen.material._kernels import horizon_occlusion  # (numba loads with the first map made)

    height = np.ascontiguousarray(height, dtype=np.float32)
    out = np.empty(height.shape, np.float32)
    for start, stop in row_bands(height.shape[0], height.shape[1] * directions * radius):
        horizon_occlusion(height, dirs, int(radius), wy, wx, out, start, stop)  # Ctrl-C between bands
    return out


def photo_cavities(
    ao: np.ndarray,
    lum: np.ndarray,
    *,
    weight: float = CAVITY_WEIGHT,
    scale: float = CAVITY_SCALE,
    boundary: Boundary | None = None,
) -> np.ndarray:
    """The photo's cavity term of the ambient occlusion, to add to the height's AO ``ao``.

    Where the photo is darker than its surroundings (its luminance ``lum`` minus a Gaussian blur
    of ``scale``, in units of its std) the AO is lower, by ``weight`` times the spread (std) of
    ``ao``, so the term scales with the relief and vanishes with it.

    The estimated height is smooth and cautious; the photo's own darkness in cracks and between
    plates is the detail it leaves out. Against the scanned AO of four barks, leave-one-out, it
    raises the correlation on all four (``benchmarks/bench_material.py``).

    Parameters
    ----------
    ao : ndarray, shape (h, w)
        The height's AO (:func:`ambient_occlusion`).
    lum : ndarray, shape (h, w)
        The photo's luminance.
    weight : float, default CAVITY_WEIGHT
        Strength of the term in spreads of ``ao``; 0 gives zeros.
    scale : float, default CAVITY_SCALE
        Sigma of the surroundings' blur, in pixels.
    boundary : Boundary, optional
        Where the photo wraps (both axes, or ``(rows, columns)``) (default: nowhere).

    Returns
    -------
    ndarray of float32, shape (h, w)
        The term (mean 0), zeros when ``weight`` is 0 or the photo is flat.
    """
    lum = np.asarray(lum, np.float32)
    detail = lum - (boundary or Boundary()).blur(lum, scale)
    spread = float(detail.std())
    if weight == 0 or spread < 1e-6:
        return np.zeros(lum.shape, np.float32)
    return (weight * float(np.std(ao)) / spread * (detail - detail.mean())).astype(np.float32)


def roughness_map(height: np.ndarray, ao: np.ndarray) -> np.ndarray:
    """Roughness of bark from its height and AO.

    Bark is rough (:data:`ROUGHNESS_BASE`), crevices rougher (dust, loose fibre: more where
    occluded), the highest ridges a little smoother (worn).

    Parameters
    ----------
    height : ndarray, shape (h, w)
        Height in pixels.
    ao : ndarray, shape (h, w)
        Ambient occlusion in [0, 1].

    Returns
    -------
    ndarray of float32, shape (h, w)
        Roughness in [0, 1].
    """
    h = np.asarray(height, np.float32)
    z = (h - h.mean()) / max(float(h.std()), 1e-6)
    rough = ROUGHNESS_BASE + ROUGHNESS_CAVITY * (1.0 - np.asarray(ao, np.float32)) - ROUGHNESS_RIDGE * z
    return np.clip(rough, 0.0, 1.0).astype(np.float32)
