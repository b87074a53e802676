"""Orientation and scale fields on disk (``--flow``, ``--flow-scale``): a NumPy ``.npy`` array of
the output's height x width, or a grey image.

As ``.npy``, the values are what the engine takes: angles in degrees (counter-clockwise as seen
on screen: the exemplar's turn at each pixel) and scales (1 = the photo's). As an image (PNG,
TIFF, 8 or 16 bits, grey or the first channel), the grey value ``v`` of ``0..max`` means the
angle ``360 * v / (max + 1) - 180`` (mid-grey is 0; black -180) or the scale
``2 ** (4 * v / max - 2)`` (0.25 to 4; mid-grey about 1).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from barkgen.errors import ImageReadError, InvalidInputError

#: what a field is, as errors and the image encoding name it
FIELD_KINDS = ("flow", "flow scale")


def read_field(path: str | os.PathLike, kind: str) -> np.ndarray:
    """A flow (``kind="flow"``: angles in degrees) or scale (``"flow scale"``) field read from
    ``.npy`` or a grey image (see the module for the image encoding).

    Parameters
    ----------
    path : str or PathLike
    kind : {"flow", "flow scale"}

    Returns
    -------
    ndarray of float32, shape (H, W)

    Raises
    ------
    ImageReadError
        A missing or unreadable file.
    InvalidInputError
        Not a 2-D array of numbers.
    """
    from barkgen.io.images import read_image

    if kind not in FIELD_KINDS:
        raise InvalidInputError(f"a field is a flow or a flow scale, not {kind!r}")
    path = Path(path)
    if path.suffix.lower() == ".npy":
        try:
            array = np.load(path, allow_pickle=False)
        except FileNotFoundError:
            raise ImageReadError(f"{path}: no such file") from None
        except (OSError, ValueError) as exc:
            raise ImageReadError(f"{path}: not a NumPy array file ({exc})") from None
        if array.ndim == 3 and array.shape[2] == 1:
            array = array[..., 0]
        if array.ndim != 2 or array.dtype.kind not in "fiu":
            raise InvalidInputError(
                f"{path}: the {kind} field must be a 2-D array of numbers, not {array.dtype} {array.shape}"
            )
        return array.astype(np.float32)
    image = read_image(path)
    top = float(np.iinfo(image.dtype).max)
    value = image[..., 0].astype(np.float64)
    if kind == "flow":
        return (360.0 * value / (top + 1.0) - 180.0).astype(np.float32)
    return (2.0 ** (4.0 * value / top - 2.0)).astype(np.float32)
