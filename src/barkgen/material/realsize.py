"""The real-world size of a material set: how many metres its pixels are, so that its width and
its displacement's depth can be given in metres (NAME.json, NAME.mtlx, NAME_blender.py, the
glb), as artists' libraries (ambientCG, Poly Haven) state them."""

from __future__ import annotations

import numpy as np

from barkgen.errors import InvalidInputError

#: the real-world width of a bark photo when nobody says it (a close-up of a trunk: fissures
#: and plates a few centimetres apart, a few dozen of them across the frame)
ASSUMED_PHOTO_WIDTH_M = 0.5
#: the widths a set may be said to have, in metres
WIDTH_M_RANGE = (1e-3, 1e3)


def check_width_m(width_m: float | None) -> float | None:
    """A set's real-world width in metres (``None``: assumed), within :data:`WIDTH_M_RANGE`."""
    if width_m is None:
        return None
    lo, hi = WIDTH_M_RANGE
    if isinstance(width_m, bool) or not isinstance(width_m, (int, float, np.floating, np.integer)):
        raise InvalidInputError(f"the width in metres must be a number, not {width_m!r}")
    if not (np.isfinite(width_m) and lo <= width_m <= hi):
        raise InvalidInputError(f"the width in metres must be in [{lo:g}, {hi:g}], not {width_m:g}")
    return float(width_m)


def physical_size(shape: tuple[int, int], depth_px: float, pixel_size_m: float, given: bool) -> dict:
    """``width_m``, ``height_m``, ``real_size`` (``given`` or ``assumed ...``) and
    ``displacement_depth_m`` of a set of ``shape`` ``(h, w)`` whose height spans ``depth_px``
    pixels and whose pixels are ``pixel_size_m`` metres."""
    px = float(pixel_size_m)
    return {
        "width_m": round(shape[1] * px, 6),
        "height_m": round(shape[0] * px, 6),
        "real_size": "given" if given else f"assumed (a bark photo {ASSUMED_PHOTO_WIDTH_M:g} m wide)",
        "displacement_depth_m": round(depth_px * px, 8),
    }
