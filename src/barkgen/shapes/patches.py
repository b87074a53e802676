"""Boundary patches of binary shapes and the shape similarity measure (laitoch2018 §3.6.1,
Rosenberger et al. 2009).

A boundary patch is the ``n x n`` binary neighbourhood of a pixel on a shape boundary. Two
patches are compared by the number of differing pixels (the squared L2 norm of eq. 3.7), taking
the best of the allowed 90° rotations of the second one. Patches are packed into bit strings and
searched with faiss' exact binary (Hamming) index, so the sums of eq. 3.8–3.9 never loop in
Python.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.arrays import NO_WRAP, Boundary
from barkgen.errors import InvalidInputError

#: allowed rotations of boundary patches, in quarter turns: bark is vertical, so by default a
#: patch may be turned upside down (180°) but not on its side
ROTATIONS = {"none": (0,), "vertical": (0, 2), "all": (0, 1, 2, 3)}


def check_rotations(rotations: str) -> tuple[int, ...]:
    """The quarter turns of a rotation mode (``none``, ``vertical`` or ``all``)."""
    try:
        return ROTATIONS[rotations]
    except (KeyError, TypeError):
        raise InvalidInputError(f"rotations must be one of {', '.join(ROTATIONS)}, not {rotations!r}") from None


def boundary_pixels(shape: np.ndarray, edges: Boundary = NO_WRAP) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates ``(ys, xs)`` of the boundary pixels of a binary ``shape``: pixels with a
    4-neighbour of the other value (across its ``edges`` where they wrap)."""
    import barkgen.shapes._kernels as K

    s = np.ascontiguousarray(shape, dtype=np.uint8)
    out = np.empty_like(s)
    K.boundary_mask(s, edges.wrap, out)
    ys, xs = np.nonzero(out)
    return ys.astype(np.int32), xs.astype(np.int32)


def extract_patches(
    shape: np.ndarray, ys: np.ndarray, xs: np.ndarray, size: int, edges: Boundary = NO_WRAP
) -> np.ndarray:
    """The ``size x size`` neighbourhoods ``(m, size, size)`` uint8 of a binary ``shape`` at
    ``(ys, xs)``: wrapped where its ``edges`` wrap, else the border pixels are repeated."""
    r = size // 2
    padded = edges.pad(np.asarray(shape, dtype=np.uint8), r, other="edge")
    off = np.arange(size)
    return padded[ys[:, None, None] + off[None, :, None], xs[:, None, None] + off[None, None, :]]


def pack(patches: np.ndarray) -> np.ndarray:
    """Patches ``(m, n, n)`` of 0/1 as bit strings ``(m, ceil(n*n / 8))`` uint8 (faiss' binary
    layout; the padding bits are zero in every code, so they never count)."""
    m = patches.shape[0]
    return np.packbits(patches.reshape(m, -1).astype(np.uint8), axis=1, bitorder="little")


def rotated(patches: np.ndarray, quarter_turns: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """All allowed rotations of ``patches``: ``(len(turns) * m, n, n)`` and the turn of each."""
    stacks = [np.rot90(patches, k=t, axes=(1, 2)) for t in quarter_turns]
    turns = np.repeat(np.asarray(quarter_turns, np.int32), patches.shape[0])
    return np.ascontiguousarray(np.concatenate(stacks)), turns


def binary_index(codes: np.ndarray):
    """An exact faiss Hamming index over packed ``codes``."""
    import faiss

    index = faiss.IndexBinaryFlat(codes.shape[1] * 8)
    index.add(np.ascontiguousarray(codes))
    return index


def subsample(ys: np.ndarray, xs: np.ndarray, limit: int, rng: np.random.Generator):
    """At most ``limit`` of the points ``(ys, xs)``, a seeded random subset in their order."""
    if limit and len(ys) > limit:
        pick = np.sort(rng.choice(len(ys), size=limit, replace=False))
        return ys[pick], xs[pick]
    return ys, xs


def _one_sided(
    a: np.ndarray,
    b: np.ndarray,
    size: int,
    turns: tuple[int, ...],
    edges: Boundary,
    max_samples: int,
    rng: np.random.Generator,
) -> tuple[float, int]:
    """Sum over (sampled) boundary pixels x1 of ``a`` of D(x1, b) (eq. 3.8), and their count."""
    ay, ax = boundary_pixels(a, edges)
    by, bx = boundary_pixels(b, edges)
    if len(ay) == 0:
        return 0.0, 0
    if len(by) == 0:  # b has no boundary: nothing to match, every pixel of the patch differs
        return float(size * size) * len(ay), len(ay)
    n_a = len(ay)
    ay, ax = subsample(ay, ax, max_samples, rng)
    by, bx = subsample(by, bx, max_samples, rng)
    db, _ = rotated(extract_patches(b, by, bx, size, edges), turns)
    index = binary_index(pack(db))
    dist, _ = index.search(pack(extract_patches(a, ay, ax, size, edges)), 1)
    # the sampled mean stands for all of a's boundary pixels
    return float(dist[:, 0].mean()) * n_a, n_a


def shape_dissimilarity(
    shape_a: np.ndarray,
    shape_b: np.ndarray,
    *,
    patch: int = 9,
    rotations: str = "vertical",
    edges: Boundary = NO_WRAP,
    max_samples: int = 20000,
    seed: int = 0,
) -> float:
    """``D(S1, S2)`` of laitoch2018 eq. 3.9: how much two shapes' boundaries differ.

    The sum, over the boundary pixels of each shape, of the number of differing pixels to the
    most similar boundary patch of the other shape (eq. 3.7-3.8, best allowed rotation),
    divided by the number of boundary pixels of both. 0 for shapes whose boundaries are made of
    the same patches; grows as they differ. Shapes of different sizes may be compared.

    Parameters
    ----------
    shape_a, shape_b : ndarray of bool, shape (h, w)
        The shapes.
    patch : int, default 9
        Side of the boundary patches.
    rotations : {"none", "vertical", "all"}, default "vertical"
        Turns a patch may match in.
    edges : Boundary, default: no wrap
        Where the shapes wrap (``Boundary(True)``: both are tiles).
    max_samples : int, default 20000
        With more boundary pixels, a seeded random subset estimates the sums.
    seed : int, default 0
        Seeds that subset.

    Returns
    -------
    float

    References
    ----------
    .. [1] laitoch2018, eq. 3.7-3.9 (boundary patch dissimilarity).

    Examples
    --------
    >>> import numpy as np
    >>> disc = np.hypot(*np.mgrid[-16:16, -16:16]) < 10
    >>> shape_dissimilarity(disc, disc)
    0.0
    """
    turns = check_rotations(rotations)
    rng = np.random.default_rng(seed)
    a = np.asarray(shape_a).astype(bool)
    b = np.asarray(shape_b).astype(bool)
    sa, na = _one_sided(a, b, patch, turns, edges, max_samples, rng)
    sb, nb = _one_sided(b, a, patch, turns, edges, max_samples, rng)
    if na + nb == 0:
        return 0.0
    return (sa + sb) / (na + nb)


def label_dissimilarity(
    labels_a: np.ndarray,
    labels_b: np.ndarray,
    *,
    patch: int = 9,
    rotations: str = "vertical",
    edges: Boundary = NO_WRAP,
    max_samples: int = 20000,
    seed: int = 0,
) -> dict[int, float]:
    """laitoch2018 eq. 3.9 per label: ``{label value: D(A == label, B == label)}``.

    Parameters
    ----------
    labels_a, labels_b : ndarray, shape (h, w)
        Grey label maps; the labels of ``labels_a`` are compared.
    patch, rotations, edges, max_samples, seed
        As for :func:`shape_dissimilarity`.

    Returns
    -------
    dict of int to float

    Raises
    ------
    InvalidInputError
        Label maps that are not 2-D.

    References
    ----------
    .. [1] laitoch2018, eq. 3.9.
    """
    a = np.asarray(labels_a)
    b = np.asarray(labels_b)
    if a.ndim != 2 or b.ndim != 2:
        raise InvalidInputError("label dissimilarity needs 2-D (grey) label maps")
    return {
        int(v): shape_dissimilarity(
            a == v, b == v, patch=patch, rotations=rotations, edges=edges, max_samples=max_samples, seed=seed
        )
        for v in np.unique(a)
    }
