"""Checks of the values every package takes: photos, label counts, seeds and output sizes.

Each raises :class:`barkgen.errors.InvalidInputError` with one line that names the value, so
every front end reports the same words.
"""

from __future__ import annotations

import re
from contextvars import ContextVar

import numpy as np

from barkgen.errors import InvalidInputError

#: most labels a label map may ask for
MAX_K = 16
#: smallest photo side accepted
MIN_SIDE = 16
#: the largest photo barkgen analyses (generate, the web app's uploads, every CLI input): the
#: analysis grows with the photo's pixels (5.3 s for 1 megapixel, 2026-12-02; its estimated
#: memory 10 GiB at 50), so a larger photo is refused before any work
MAX_PHOTO_PIXELS = 50_000_000


def check_image(
    image: np.ndarray, *, min_side: int = MIN_SIDE, what: str = "photo", purpose: str = "label maps need"
) -> np.ndarray:
    """An ``(h, w)`` or ``(h, w, C)`` photo (uint8, uint16 or float in [0, 1]) as float32 RGB in
    [0, 1]; alpha is dropped, grey is repeated to three channels. ``what`` and ``purpose``
    word the errors (e.g. "exemplar", "the bi-layer analysis needs")."""
    img = np.asarray(image)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3 or img.shape[2] not in (1, 2, 3, 4):
        raise InvalidInputError(f"{what} must be an (H, W) or (H, W, C) image, not shape {img.shape}")
    if min(img.shape[:2]) < min_side:
        raise InvalidInputError(
            f"{what} is {img.shape[1]}x{img.shape[0]} px; {purpose} at least {min_side} px on each side"
        )
    if img.shape[2] in (2, 4):
        img = img[:, :, :-1]
    if img.dtype == np.uint8:
        f = img.astype(np.float32) / 255.0
    elif img.dtype == np.uint16:
        f = img.astype(np.float32) / 65535.0
    elif img.dtype.kind == "f":
        f = np.clip(np.nan_to_num(img.astype(np.float32)), 0.0, 1.0)
    else:
        raise InvalidInputError(f"{what} has unsupported dtype {img.dtype}")
    if f.shape[2] == 1:
        f = np.repeat(f, 3, axis=2)
    return np.ascontiguousarray(f)


def check_k(k: int, name: str = "k") -> int:
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= MAX_K:
        raise InvalidInputError(f"{name} must be an integer from 1 to {MAX_K}, not {k!r}")
    return int(k)


#: the largest seed (it is recorded as a 64-bit integer: report.json, batch's manifest)
MAX_SEED = 2**63 - 1


def check_seed(seed: int) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= MAX_SEED:
        shown = repr(seed) if len(repr(seed)) <= 40 else repr(seed)[:37] + "..."
        raise InvalidInputError(f"seed must be an integer from 0 to 2**63 - 1, not {shown}")
    return int(seed)


def parse_output_shape(size: int | tuple[int, int]) -> tuple[int, int]:
    """``size`` as ``(height, width)``; an int is a square."""
    if isinstance(size, (int, np.integer)):
        shape = (int(size), int(size))
    else:
        try:
            h, w = size
            shape = (int(h), int(w))
        except (TypeError, ValueError):
            raise InvalidInputError(f"size must be an int or (height, width), not {size!r}") from None
    if shape[0] < 1 or shape[1] < 1:
        raise InvalidInputError(f"output size must be positive, not {shape[1]}x{shape[0]}")
    return shape


_SIZE_RE = re.compile(r"^\s*(-?\d{1,12})\s*[xX×]\s*(-?\d{1,12})\s*$")
#: the largest output (pixels) a size may ask for unless the limit is raised (8192²)
MAX_OUTPUT_PIXELS = 8192 * 8192
#: the limit in force when raised or lowered (the CLI's ``barkgen --max-pixels N``)
OUTPUT_PIXEL_LIMIT: ContextVar[int | None] = ContextVar("barkgen_output_pixels", default=None)


def parse_size(text: str) -> tuple[int, int]:
    """``"WxH"`` -> ``(height, width)``; raises :class:`InvalidInputError` with a clear message."""
    m = _SIZE_RE.match(text if isinstance(text, str) else "")
    if not m:
        shown = repr(text) if len(repr(text)) <= 40 else repr(text)[:37] + "..."
        raise InvalidInputError(f"invalid size {shown}: expected WIDTHxHEIGHT, e.g. 1024x1024 (at most 12 digits each)")
    w, h = int(m.group(1)), int(m.group(2))
    if w <= 0 or h <= 0:
        raise InvalidInputError(f"invalid size {text!r}: width and height must be positive")
    limit = OUTPUT_PIXEL_LIMIT.get() or MAX_OUTPUT_PIXELS
    if w * h > limit:
        raise InvalidInputError(
            f"size {w}x{h} is {w * h / 1e6:.3g} megapixels, more than the limit "
            f"of {limit / 1e6:.3g} (raise it: barkgen --max-pixels N COMMAND ...)"
        )
    return h, w
