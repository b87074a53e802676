"""Array conventions shared by barkgen's packages: image shapes and dtypes, progress callbacks."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from barkgen.errors import InvalidInputError

#: progress(done, total): called after each unit of work.
ProgressCallback = Callable[[int, int], None]


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
