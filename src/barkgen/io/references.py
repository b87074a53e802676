"""Reference maps on disk: 16-bit RGB PNGs whose pixels are exemplar coordinates.

Channel R holds the exemplar column (x), G the row (y), B is 0. A ``barkgen-reference`` tEXt
chunk records the exemplar size (``WxH``) so a reference map is only re-applied to maps of the
size it was made for (laitoch2018 §3.3.1, "image of references").
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from barkgen.errors import ImageReadError, InvalidInputError
from barkgen.io.images import encode_png, read_image, read_png_text
from barkgen.io.staging import write_bytes_atomic

_KEY = "barkgen-reference"
_ORIENTATION_KEY = "barkgen-orientation"


def encode_reference(
    references: np.ndarray, exemplar_shape: tuple[int, int], *, orientation: dict | None = None
) -> bytes:
    """A reference map as the bytes of a 16-bit PNG.

    Red is the column, green the row, blue 0; the exemplar's size goes into a tEXt chunk
    (``exemplar=WxH``).

    Parameters
    ----------
    references : ndarray of int, shape (H, W, 2)
        The exemplar ``(row, col)`` each output pixel copies.
    exemplar_shape : (int, int)
        ``(h, w)`` of the exemplar, at most 65535 a side.
    orientation : dict, optional
        Along a flow field, the atlas of the exemplar's turned copies the references point
        into (:meth:`barkgen.synth.OrientedExemplar.to_dict`), recorded in a
        ``barkgen-orientation`` tEXt chunk (:func:`read_reference_orientation`).

    Returns
    -------
    bytes

    Raises
    ------
    InvalidInputError
        A map of another shape, or an exemplar too large for 16 bits.

    References
    ----------
    .. [1] laitoch2018, §3.3.1 (the reference map, applied to any map of the exemplar).
    """
    refs = np.asarray(references)
    h, w = int(exemplar_shape[0]), int(exemplar_shape[1])
    if refs.ndim != 3 or refs.shape[2] != 2:
        raise InvalidInputError(f"reference map must have shape (H, W, 2), not {refs.shape}")
    if max(h, w) > 65535 or (refs.size and refs.max() > 65535):
        raise InvalidInputError("exemplars wider or taller than 65535 px cannot be saved as references")
    # made in OpenCV's channel order (blue 0, green the row, red the column): the encoder needs
    # no copy of it (a 16384² map's 1.6 GB)
    bgr = np.zeros(refs.shape[:2] + (3,), np.uint16)
    bgr[:, :, 2] = refs[:, :, 1]
    bgr[:, :, 1] = refs[:, :, 0]
    text = {_KEY: f"exemplar={w}x{h}"}
    if orientation is not None:
        text[_ORIENTATION_KEY] = json.dumps(orientation, separators=(",", ":"))
    return encode_png(bgr, text=text, channel_order="bgr")


def write_reference(path: str | os.PathLike, references: np.ndarray, exemplar_shape: tuple[int, int]) -> Path:
    """Save a reference map as a 16-bit PNG, atomically (see :func:`encode_reference`).

    Parameters
    ----------
    path : str or PathLike
        The file.
    references : ndarray of int, shape (H, W, 2)
        The exemplar ``(row, col)`` each output pixel copies.
    exemplar_shape : (int, int)
        ``(h, w)`` of the exemplar.

    Returns
    -------
    Path
        ``path``.
    """
    return write_bytes_atomic(path, encode_reference(references, exemplar_shape))


def read_reference(path: str | os.PathLike) -> tuple[np.ndarray, tuple[int, int] | None]:
    """Load a reference map written by :func:`write_reference`.

    Parameters
    ----------
    path : str or PathLike
        The 16-bit RGB PNG.

    Returns
    -------
    references : ndarray of int32, shape (H, W, 2)
        ``(row, col)`` per output pixel.
    exemplar_shape : (int, int) or None
        ``(h, w)`` of the exemplar, when the file records it.

    Raises
    ------
    ImageReadError
        Not a 16-bit RGB PNG.

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> refs = np.zeros((2, 3, 2), np.int32)
    >>> path = write_reference(os.path.join(tempfile.mkdtemp(), "ref.png"), refs, (16, 32))
    >>> read_reference(path)[1]
    (16, 32)
    """
    path = Path(path)
    image = read_image(path)
    if image.dtype != np.uint16 or image.shape[2] != 3:
        raise ImageReadError(f"{path}: not a barkgen reference map (expected a 16-bit RGB PNG)")
    refs = np.stack([image[:, :, 1], image[:, :, 0]], axis=-1).astype(np.int32)
    shape = None
    meta = read_png_text(path).get(_KEY, "")
    if meta.startswith("exemplar="):
        try:
            w, h = (int(v) for v in meta[len("exemplar=") :].split("x"))
            shape = (h, w)
        except ValueError:
            shape = None
    return refs, shape


def read_reference_orientation(path: str | os.PathLike) -> dict | None:
    """The atlas of turned copies a reference map made along a flow field points into (what
    :func:`encode_reference` recorded; :meth:`barkgen.synth.OrientedExemplar.from_dict` reads
    it), or None for a plain reference map.

    Raises
    ------
    ImageReadError
        A record that is not JSON.
    """
    text = read_png_text(Path(path)).get(_ORIENTATION_KEY)
    if text is None:
        return None
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        raise ImageReadError(f"{path}: its orientation record is damaged") from None
