"""Output windows: an output cut into square cores, each read with a halo round it (round the
torus when the output tiles, clipped at its edges otherwise), for the passes that are local
(issue 69, "bark at any size"): the seam blend (:func:`barkgen.synth.blend_seams_in_windows`)
and the resolve pass of :mod:`barkgen.pipeline.windowed`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from barkgen.errors import InvalidInputError


@dataclass(frozen=True)
class ResolveWindow:
    """One window of the resolve pass: the output ``rows`` and ``cols`` (int arrays, modulo
    the output's size) it reads, core and halo, and where its core lies in them (``core``).

    Attributes
    ----------
    rows, cols : ndarray of int
        The output rows and columns read, in order.
    core : (slice, slice)
        The core within the window.
    target : (slice, slice)
        The core in the output.
    """

    rows: np.ndarray
    cols: np.ndarray
    core: tuple[slice, slice]
    target: tuple[slice, slice]

    @property
    def shape(self) -> tuple[int, int]:
        """``(h, w)`` of the window read."""
        return (int(self.rows.size), int(self.cols.size))

    def inner(self, halo: int) -> tuple[slice, slice]:
        """The part of the window within ``halo`` px of its core (clipped at the window's
        edges): a smaller halo for a pass that reaches less far."""
        return tuple(
            slice(max(core.start - halo, 0), min(core.stop + halo, n))
            for core, n in zip(self.core, self.shape, strict=True)
        )  # type: ignore[return-value]


def _axis_spans(n: int, side: int, halo: int, tile: bool) -> list[tuple[np.ndarray, slice, slice]]:
    """Along one axis of ``n`` px: each core's positions with its halo (round the torus when
    ``tile``, clipped otherwise), the core within them and the core in the axis."""
    spans = []
    for start in range(0, n, side):
        stop = min(start + side, n)
        first, last = (start - halo, stop + halo) if tile else (max(start - halo, 0), min(stop + halo, n))
        spans.append((np.arange(first, last) % n, slice(start - first, stop - first), slice(start, stop)))
    return spans


def resolve_windows(shape: tuple[int, int], window: int, halo: int, tile: bool) -> list[ResolveWindow]:
    """The windows of an output of ``shape`` with square cores of ``window`` px (the last row and
    column of cores shorter) and ``halo`` px round them, in raster order.

    Parameters
    ----------
    shape : (int, int)
        The output's ``(H, W)``.
    window : int
        Side of a core in px, at least 1.
    halo : int
        Px read round a core, at least 0 (taken round the torus when ``tile``; a halo wider than
        the output reads some of it twice, as the torus repeats it).
    tile : bool
        The output tiles.

    Returns
    -------
    list of ResolveWindow
    """
    if int(window) < 1 or int(halo) < 0:
        raise InvalidInputError(
            f"a resolve window needs a core of at least 1 px and a halo of 0 or more, not {window} and {halo}"
        )
    rows = _axis_spans(int(shape[0]), int(window), int(halo), tile)
    cols = _axis_spans(int(shape[1]), int(window), int(halo), tile)
    return [ResolveWindow(r, c, (rc, cc), (rt, ct)) for r, rc, rt in rows for c, cc, ct in cols]
