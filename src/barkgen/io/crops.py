"""Photos of the team's data folder read as the team's referee reads them: a centre crop."""

from __future__ import annotations

import os

import numpy as np


def read_centre_crop(path: str | os.PathLike, size: int) -> np.ndarray:
    """The ``size x size`` RGB centre crop of an image file, its short side resized to ``size`` first.

    Lanczos resampling, decoded by Pillow, as the team's compare.py prepares exemplars: the
    benchmarks' and tests' way of reading a photo of the team's data folder (``BARKGEN_SHARED``).

    Parameters
    ----------
    path : str or PathLike
        The image file.
    size : int
        Side of the crop in pixels.

    Returns
    -------
    ndarray of uint8, shape (size, size, 3)

    Examples
    --------
    >>> import barkgen
    >>> read_centre_crop(barkgen.sample_exemplar_path(), 128).shape
    (128, 128, 3)
    """
    from PIL import Image

    im = Image.open(path).convert("RGB")
    w, h = im.size
    s = size / min(w, h)
    im = im.resize((max(size, round(w * s)), max(size, round(h * s))), Image.Resampling.LANCZOS)
    w, h = im.size
    left, top = (w - size) // 2, (h - size) // 2
    return np.asarray(im.crop((left, top, left + size, top + size)))
