"""Branching structures (sibbing2010): extract crack networks, grow new ones, render them."""

from barkgen.branching.structure import (
    STRUCTURE_VERSION,
    Branch,
    Structure,
    rasterize,
    resample_polyline,
    turning_angles,
)

__all__ = [
    "STRUCTURE_VERSION",
    "Branch",
    "Structure",
    "rasterize",
    "resample_polyline",
    "turning_angles",
]
