"""Output pixels that show what other output pixels show: the gutters of a texture atlas.

A texture atlas cuts a surface into charts; the texels just outside a chart's border lie, on the
surface, inside another chart. Linking each such texel to the texel that shows its surface
point, and copying that texel's reference into it while the solver runs (after every
iteration of every level), lets the neighbourhoods of the texels along a border be matched
across it on the surface, not in the flat atlas (mazzolini2012 §4.2, synthesis on the mesh;
§3.1.4, no seams): the two sides of a chart border are synthesized as one piece of bark.

Along a flow field (:mod:`barkgen.synth._flow`) the two charts see the bark turned differently;
a reference is carried from its own copy of the exemplar to the copy the linked texel wants, at
the same exemplar point (:func:`barkgen.synth._flow.equivalent_points`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from barkgen.errors import InvalidInputError


@dataclass(frozen=True)
class OutputLinks:
    """Linked output pixels.

    Attributes
    ----------
    shape : tuple of int
        ``(H, W)`` of the output.
    target, source : ndarray of int64, shape (n,)
        Flat indices: ``target[i]`` shows what ``source[i]`` shows.
    target_copy : ndarray of int32, shape (n,), optional
        Along a flow field, the copy of the exemplar each target wants (set by the solver's
        front: :func:`barkgen.synth.texture_by_numbers`).
    oriented : OrientedExemplar, optional
        That atlas of copies.
    """

    shape: tuple[int, int]
    target: np.ndarray
    source: np.ndarray
    target_copy: np.ndarray | None = None
    oriented: Any = None

    def __post_init__(self) -> None:
        size = int(self.shape[0]) * int(self.shape[1])
        for name in ("target", "source"):
            values = np.asarray(getattr(self, name))
            if values.ndim != 1 or (values.size and (values.min() < 0 or values.max() >= size)):
                raise InvalidInputError(f"the links' {name}s must be flat indices of the output's pixels")
        if np.shape(self.target) != np.shape(self.source):
            raise InvalidInputError("the links need one source per target")
        object.__setattr__(self, "_levels", {})  # at_level's answers: asked after every iteration

    def oriented_by(self, oriented, copies: np.ndarray) -> OutputLinks:
        """These links along a flow field: ``copies`` the ``(H, W)`` copy each output pixel wants."""
        return OutputLinks(
            self.shape, self.target, self.source, np.asarray(copies).ravel()[self.target].astype(np.int32), oriented
        )

    def at_level(self, level: int, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The links of pyramid level ``level`` (output ``shape``): each pixel's block of the
        finest level, one link per target, none that links a pixel to itself."""
        key = (int(level), int(shape[0]), int(shape[1]))
        known = self._levels.get(key)  # type: ignore[attr-defined]
        if known is None:
            known = self._levels[key] = self._make_level(level, shape)  # type: ignore[attr-defined]
        return known

    def _make_level(self, level: int, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        width = int(self.shape[1])
        ty, tx = np.divmod(np.asarray(self.target, np.int64), width)
        sy, sx = np.divmod(np.asarray(self.source, np.int64), width)
        h, w = int(shape[0]), int(shape[1])
        target = np.minimum(ty >> level, h - 1) * w + np.minimum(tx >> level, w - 1)
        source = np.minimum(sy >> level, h - 1) * w + np.minimum(sx >> level, w - 1)
        keep = target != source
        target, first = np.unique(target[keep], return_index=True)
        source = source[keep][first]
        copies = None if self.target_copy is None else self.target_copy[keep][first]
        return target, source, copies

    def apply(self, refs: np.ndarray, level: int, grid: tuple) -> None:
        """Copy into every target, in place, the reference of its source (``refs``: a level's
        flat references into its exemplar ``grid``, :attr:`LevelAnalysis.grid`)."""
        coords_y, coords_x, height, width = grid[0], grid[1], int(grid[2]), int(grid[3])
        target, source, copies = self.at_level(level, refs.shape)
        if target.size == 0:
            return
        flat = refs.reshape(-1)
        taken = flat[source]
        if copies is not None and self.oriented is not None:
            from barkgen.synth._flow import equivalent_points

            block = float(1 << level)
            rows, cols = equivalent_points(
                self.oriented,
                coords_y[taken] * block + (block - 1) / 2.0,
                coords_x[taken] * block + (block - 1) / 2.0,
                copies,
            )
            ry = np.clip(np.floor(rows / block).astype(np.int64), 0, height - 1)
            rx = np.clip(np.floor(cols / block).astype(np.int64), 0, width - 1)
            taken = (ry * width + rx).astype(flat.dtype)
        flat[target] = taken
