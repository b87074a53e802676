"""Array conventions shared by barkgen's packages: image shapes and dtypes, progress callbacks,
and images that wrap round (a photo that tiles along an axis is a torus along it)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from barkgen.errors import InvalidInputError

#: progress(done, total): called after each unit of work.
ProgressCallback = Callable[[int, int], None]
#: how an image wraps round: a bool (both axes) or ``(rows, columns)``
Wrap = bool | tuple[bool, bool]


@dataclass(frozen=True)
class Boundary:
    """How a run's filters read an image at its edges: round the torus along the axes it wraps
    along (a photo that tiles, a tileable texture; mazzolini2012 §4.1), mirrored (or one-sided)
    at the others. Built once per run from its wrap and handed to the filters, whose edge
    handling is its methods.

    Parameters
    ----------
    wrap : bool or (bool, bool), default (False, False)
        ``(rows, columns)``, or a bool for both axes.

    Examples
    --------
    >>> Boundary(True).wrap, Boundary().wraps_any
    ((True, True), False)
    """

    wrap: Any = (False, False)

    def __post_init__(self) -> None:
        wrap = self.wrap
        axes = (bool(wrap[0]), bool(wrap[1])) if isinstance(wrap, (tuple, list)) else (bool(wrap), bool(wrap))
        object.__setattr__(self, "wrap", axes)

    @property
    def wraps_any(self) -> bool:
        """The image wraps along some axis."""
        return self.wrap[0] or self.wrap[1]

    @property
    def wraps_both(self) -> bool:
        """The image wraps along both axes (it tiles)."""
        return self.wrap[0] and self.wrap[1]

    def pad(self, image: np.ndarray, pad: int, other: str | None = "reflect") -> np.ndarray:
        """``image`` padded by ``pad`` px on both sides of its first two axes: wrapping along an
        axis it wraps along, ``other`` (a :func:`numpy.pad` mode, or None: not padded) along the
        others."""
        rest = [(0, 0)] * (np.ndim(image) - 2)
        out = np.asarray(image)
        for axis, wraps in ((0, self.wrap[0]), (1, self.wrap[1])):
            if not wraps and other is None:
                continue
            widths = [(0, 0), (0, 0)] + rest
            widths[axis] = (pad, pad)
            out = np.pad(out, widths, mode=cast(Any, "wrap" if wraps else other))  # numpy types mode as a Literal
        return out

    def torus(self, func: Callable[[np.ndarray], np.ndarray], image: np.ndarray, pad: int) -> np.ndarray:
        """``func(image)`` of a local operation (a filter, a distance transform, a denoising)
        whose reach is at most ``pad`` px, computed as if ``image`` wrapped round along the axes
        it wraps along: padded there with its own opposite edge, then cropped back. Along the
        other axes ``func`` sees the image as it is, so an image that wraps nowhere gives
        ``func(image)`` itself, to the byte. ``func`` keeps the first two axes' size."""
        wy, wx = self.wrap
        if not (wy or wx):
            return func(image)
        h, w = np.shape(image)[:2]
        py, px = (pad if wy else 0), (pad if wx else 0)
        out = func(self.pad(image, pad, other=None))
        return out[py : py + h, px : px + w]

    def blur(self, image: np.ndarray, sigma: float) -> np.ndarray:
        """Gaussian blur (float32, OpenCV), wrapping along the axes that wrap, mirrored at the
        other borders."""
        import cv2

        from barkgen._shared.threads import ONE_THREAD_BLUR_SIGMA, opencv_one_thread

        image = np.asarray(image, np.float32)
        pad = int(np.ceil(4 * sigma)) + 1  # (numpy wraps again when the pad exceeds the image)
        with opencv_one_thread() if sigma > ONE_THREAD_BLUR_SIGMA else contextlib.nullcontext():
            return self.torus(lambda im: cv2.GaussianBlur(im, (0, 0), sigma, borderType=cv2.BORDER_REFLECT), image, pad)

    def gradient(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Central differences ``(d/dx, d/drow)`` float32: wrapping along the axes that wrap,
        one-sided at the other borders; zero along an axis one pixel long."""
        img = np.asarray(image, np.float32)
        grads = []
        for axis in (1, 0):
            if img.shape[axis] < 2:
                grads.append(np.zeros_like(img))
            elif self.wrap[axis]:
                grads.append((np.roll(img, -1, axis) - np.roll(img, 1, axis)) * np.float32(0.5))
            else:
                grads.append(np.gradient(img, axis=axis).astype(np.float32))
        return grads[0], grads[1]


#: a boundary that wraps nowhere (the filters mirror or clamp at every edge)
NO_WRAP = Boundary()


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
