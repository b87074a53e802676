"""The exemplar's edges: an exemplar that tiles is a torus, one that does not has a border where
pieces end.

A discrete solver copies pieces of the exemplar (mazzolini2012 §4.1, laitoch2018 §3.3). Where a
piece reaches the exemplar's edge it cannot continue, so it ends there, and every piece that
reaches that edge ends along the same straight line: the most visible seam of a synthesis,
worst where a strip of the exemplar runs all the way round a tiled output. Two answers:

* most scanned bark and game textures already tile: their last row continues into their first,
  so the solver treats them as a torus (neighbourhoods, shifted references, k-coherence sets and
  up-sampling all wrap) and a piece simply runs on across the edge (:func:`exemplar_wraps`
  decides it from the exemplar itself, per axis);
* along an axis that does not wrap, a piece that reaches the border ends there, and its seam
  is re-cut like any other straight seam (:mod:`barkgen.synth.seams.cuts`): the piece below it is
  continued upwards, so the border follows a low-error path instead of the border's line; a seam
  where both pieces end at the border (no cut can move it) makes the solver put other pieces
  there (:func:`barkgen.synth.seams.pieces.unstick_border_seams`). An earlier soft cost on the border pixels kept pieces
  away from them, but left the border's content out of the output (completeness) and did not
  keep the seams shorter once the cuts were there.
"""

from __future__ import annotations

import numpy as np

from barkgen.errors import InvalidInputError

#: ``exemplar_wrap`` values of the API and of ``--exemplar-wraps``
WRAP_MODES = ("auto", "yes", "no")

#: an axis wraps when the mean step from the exemplar's last row (column) to its first lies at
#: most this far from its mean step between neighbouring rows towards its mean step between
#: rows half the exemplar apart (unrelated rows): 0 = as seamless as any two neighbours, 1 = as
#: unrelated as any two rows. The bundled sample and the shared game textures that tile sit at
#: -0.07 to 0.22 on both axes, the other shared photos at 0.38 to 1.14 on at least one, a photo
#: cut anywhere at 0.59 to 1.43
WRAP_EDGE_SHARE = 0.3


def edge_step_shares(image: np.ndarray) -> tuple[float, float]:
    """``(rows, columns)``: where the mean step across the exemplar's edge (last row to first,
    last column to first) lies between its mean step between neighbouring rows (0) and its mean
    step between rows half the exemplar apart (1); likewise for columns."""
    img = np.asarray(image)
    if img.ndim == 2:
        img = img[:, :, None]
    f = img.astype(np.float32)
    shares = []
    for axis in (0, 1):
        n = f.shape[axis]
        if n < 4:
            shares.append(np.inf)
            continue
        inner = float(np.abs(np.diff(f, axis=axis)).mean())
        edge = float(np.abs(np.take(f, 0, axis=axis) - np.take(f, -1, axis=axis)).mean())
        far = float(np.abs(f - np.roll(f, n // 2, axis=axis)).mean())
        span = far - inner
        # a texture whose unrelated rows are no further apart than neighbours (noise) has no
        # edge to see: it wraps
        shares.append((edge - inner) / span if span > 1e-6 * max(far, 1e-12) else 0.0)
    return shares[0], shares[1]


def exemplar_wraps(image: np.ndarray) -> tuple[bool, bool]:
    """``(rows, columns)``: whether the exemplar tiles itself along each axis: its edge step
    (:func:`edge_step_shares`) is at most :data:`WRAP_EDGE_SHARE` of the way from a neighbour's
    step to an unrelated row's."""
    sy, sx = edge_step_shares(image)
    return bool(sy <= WRAP_EDGE_SHARE), bool(sx <= WRAP_EDGE_SHARE)


def map_wraps(image: np.ndarray, wrap: tuple[bool, bool]) -> tuple[bool, bool]:
    """``(rows, columns)``: the axes along which a map aligned with the exemplar (an extra map:
    height, normals, ...) is taken as a torus: those the exemplar wraps along (``wrap``) where
    the map's own edges meet too (:func:`exemplar_wraps`). A map made from the photo as a
    rectangle (its mirrored borders) has a cliff from its last column to its first even where
    the photo has none; carried across that edge it would draw a straight line through the
    output, so along such an axis it is not wrapped: a piece that runs on across the photo's
    edge takes the map's last step there instead (:func:`barkgen.synth.seams.gradient.exemplar_steps`)."""
    own = exemplar_wraps(image)
    return bool(wrap[0] and own[0]), bool(wrap[1] and own[1])


def check_wrap_mode(mode: str | bool | tuple[bool, bool]) -> None:
    """Raise :class:`InvalidInputError` unless ``mode`` is an ``exemplar_wrap`` setting:
    ``"auto"``, ``"yes"``, ``"no"``, a bool (both axes) or a ``(rows, columns)`` pair of bools."""
    if isinstance(mode, (bool, np.bool_)):
        return
    if isinstance(mode, tuple):
        if len(mode) != 2 or not all(isinstance(v, (bool, np.bool_)) for v in mode):
            raise InvalidInputError(f"exemplar_wrap must be a (rows, columns) pair of bools, not {mode!r}")
        return
    if mode not in WRAP_MODES:
        raise InvalidInputError(f"exemplar_wrap must be one of {', '.join(WRAP_MODES)}, not {mode!r}")


def resolve_exemplar_wrap(mode: str | bool | tuple[bool, bool], image: np.ndarray) -> tuple[bool, bool]:
    """``(rows, columns)`` from an ``exemplar_wrap`` setting: ``"auto"`` (:func:`exemplar_wraps`
    of ``image``), ``"yes"``/``True`` (both axes), ``"no"``/``False`` (neither) or a pair."""
    check_wrap_mode(mode)
    if isinstance(mode, (bool, np.bool_)):
        return bool(mode), bool(mode)
    if isinstance(mode, tuple):
        return bool(mode[0]), bool(mode[1])
    if mode == "auto":
        return exemplar_wraps(image)
    return (True, True) if mode == "yes" else (False, False)
