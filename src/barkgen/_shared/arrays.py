"""Array conventions shared by barkgen's packages: image shapes and dtypes, progress callbacks,
and images that wrap round (a photo that tiles along an axis is a torus along it)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np

from barkgen.errors import InvalidInputError

#: progress(done, total): called after each unit of work.
ProgressCallback = Callable[[int, int], None]
#: how an image wraps round: a bool (both axes) or ``(rows, columns)``
Wrap = bool | tuple[bool, bool]


def wrap_axes(tile: Wrap) -> tuple[bool, bool]:
    """``(rows, columns)`` of a ``tile`` setting: a bool (both axes) or a pair. A photo that
    tiles along one axis only (:func:`barkgen.synth.exemplar_wraps`) wraps along that one."""
    if isinstance(tile, (tuple, list)):
        return bool(tile[0]), bool(tile[1])
    return bool(tile), bool(tile)


def pad_wrapped(image: np.ndarray, pad: int, tile: Wrap, other: str | None = "reflect") -> np.ndarray:
    """``image`` padded by ``pad`` px on both sides of its first two axes: wrapping along an
    axis it wraps along (``tile``), ``other`` (a :func:`numpy.pad` mode, or None: not padded)
    along the others."""
    wy, wx = wrap_axes(tile)
    rest = [(0, 0)] * (np.ndim(image) - 2)
    out = np.asarray(image)
    for axis, wraps in ((0, wy), (1, wx)):
        if not wraps and other is None:
            continue
        widths = [(0, 0), (0, 0)] + rest
        widths[axis] = (pad, pad)
        out = np.pad(out, widths, mode=cast(Any, "wrap" if wraps else other))  # numpy types mode as a Literal
    return out


def on_torus(func: Callable[[np.ndarray], np.ndarray], image: np.ndarray, pad: int, tile: Wrap) -> np.ndarray:
    """``func(image)`` of a local operation (a filter, a distance transform, a denoising) whose
    reach is at most ``pad`` px, computed as if ``image`` wrapped round along the axes ``tile``
    wraps along: padded there with its own opposite edge, then cropped back. Along the other
    axes ``func`` sees the image as it is, so an image that wraps nowhere gives ``func(image)``
    itself, to the byte. ``func`` keeps the first two axes' size."""
    wy, wx = wrap_axes(tile)
    if not (wy or wx):
        return func(image)
    h, w = np.shape(image)[:2]
    py, px = (pad if wy else 0), (pad if wx else 0)
    out = func(pad_wrapped(image, pad, (wy, wx), other=None))
    return out[py : py + h, px : px + w]


def as_hw_c(name: str, array: np.ndarray) -> np.ndarray:
    """``array`` as ``(H, W, C)`` (a 2-D array gains one channel); ``name`` words the error."""
    arr = np.asarray(array)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3 or arr.shape[2] < 1:
        raise InvalidInputError(f"{name} must be an (H, W) or (H, W, C) array, not {arr.shape}")
    if arr.dtype.kind not in "uif" or arr.dtype == np.bool_:
        raise InvalidInputError(f"{name} has unsupported dtype {arr.dtype}")
    return arr


def unit_float(arr: np.ndarray) -> np.ndarray:
    """An image of any integer or float dtype as float32 in its unit range (uint8 / 255, ...)."""
    if arr.dtype == np.uint8:
        return arr.astype(np.float32) / 255.0
    if arr.dtype == np.uint16:
        return arr.astype(np.float32) / 65535.0
    if arr.dtype.kind == "f":
        return arr.astype(np.float32)
    info = np.iinfo(arr.dtype)
    return (arr.astype(np.float64) / max(info.max, 1)).astype(np.float32)


def as_uint8(img: np.ndarray) -> np.ndarray:
    """An image as uint8 for previews (16-bit and float scaled); one channel becomes 2-D."""
    img = np.asarray(img)
    if img.dtype == np.uint16:
        img = (img >> 8).astype(np.uint8)
    elif img.dtype != np.uint8:
        img = (np.clip(unit_float(img), 0, 1) * 255 + 0.5).astype(np.uint8)
    return img[:, :, 0] if img.ndim == 3 and img.shape[2] == 1 else img
