"""Material maps from a bark photo: height, normals, ambient occlusion, roughness and albedo
(wang2003 §3.3-3.4; laitoch2018 §3.3.1; mazzolini2012 §7.1).

Arrays in, arrays out: :func:`make_material` for a photo, :func:`scanned_material` for a
scanned set (its own maps), :func:`transfer_material` for a
texture synthesized from it, :class:`HeightEditor` for self-similarity height editing; the
files (ambientCG names) are encoded by :func:`barkgen.io.encode_material` and written by the
front ends. A run's
filters read the photo round its edges as its :class:`Boundary` says (where it wraps), built
once by :func:`make_material` (or taken from a set, :attr:`MaterialSet.boundary`).
"""

from barkgen._shared.lazy import lazy_getattr, stub_names

# the names and their modules are in __init__.pyi; each module is imported on first use (the
# CLI's start-up imports this package for its options, not its kernels)
_LAZY = stub_names(__file__)
__all__ = sorted(_LAZY)
__getattr__ = lazy_getattr(__name__, _LAZY)

# ``shading`` is also its module's name: bound now, or the module's first import (by any of the
# names above) would leave the package's ``shading`` the module, not the function
from barkgen.material.shading import shading as shading  # noqa: E402


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
