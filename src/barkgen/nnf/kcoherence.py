"""k-coherence analysis (Tong et al. 2002; mazzolini2012 §4.1.2 "k-coherence analysis phase";
laitoch2018 §3.3.6): for every exemplar pixel, the ``k`` exemplar pixels whose neighbourhoods are
most similar, found once by nearest-neighbour search on appearance vectors (faiss).

Candidates closer than ``radius`` pixels to the query, or to an already chosen candidate, are
skipped: they would only repeat what forward-shifting already proposes.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.bands import NUMPY_STEP, row_bands

_BRUTE_LIMIT = 4_096  # exact numpy search up to this many exemplar pixels
_FLAT_LIMIT = 24_000  # exact faiss search up to this many, IVF beyond


def knn_search(features: np.ndarray, n_neighbours: int) -> tuple[np.ndarray, np.ndarray]:
    """``n_neighbours`` nearest neighbours of every row of ``features`` among all rows (itself
    included), nearest first. Exact for small sets (numpy, then a faiss flat index); faiss IVF with
    4·sqrt(N) lists beyond ``_FLAT_LIMIT`` rows."""
    x = np.ascontiguousarray(features, dtype=np.float32)
    n, d = x.shape
    kk = min(n_neighbours, n)
    if n <= _BRUTE_LIMIT:
        # small sets (coarse pyramid levels): exact search by one distance matrix
        sq = np.einsum("ij,ij->i", x, x)
        dist = np.maximum(sq[:, None] + sq[None, :] - 2.0 * (x @ x.T), 0.0)
        idx = np.argpartition(dist, kk - 1, axis=1)[:, :kk] if kk < n else np.tile(np.arange(n), (n, 1))
        part = np.take_along_axis(dist, idx, axis=1)
        order = np.lexsort((idx, part), axis=1)
        return np.take_along_axis(part, order, axis=1), np.take_along_axis(idx, order, axis=1)

    import faiss

    index: faiss.Index
    if n <= _FLAT_LIMIT:
        index = faiss.IndexFlatL2(d)
    else:
        nlist = int(4 * np.sqrt(n))
        quantizer = faiss.IndexFlatL2(d)
        inverted = faiss.IndexIVFFlat(quantizer, d, nlist)
        step = max(1, n // (nlist * 48))
        inverted.train(x[::step])
        inverted.nprobe = 10
        index = inverted
    index.add(x)
    dist, idx = index.search(x, kk)
    return dist, idx


def k_coherence_sets(
    features: np.ndarray, width: int, k: int, radius: int = 2, search: int | None = None
) -> tuple[np.ndarray, float]:
    """k-coherence sets of an exemplar level.

    Returns ``(sets, scale)``: ``sets`` is ``(h * w, k)`` int32 flat exemplar indices; ``scale``
    is the median squared appearance distance from a pixel to its first kept neighbour, the
    natural unit of the synthesis costs.
    """
    from barkgen.nnf._kernels import select_spread_neighbours

    search = search or max(4 * k + 8, 32)
    dist, idx = knn_search(features, search)
    sets = select_spread_neighbours(idx.astype(np.int32), np.int32(width), np.int32(k), np.int32(radius))
    return sets, _scale(features, sets)


def _scale(features: np.ndarray, sets: np.ndarray) -> float:
    first = sets[:, 0].astype(np.int64)
    d2 = np.empty(len(features), features.dtype)
    for start, stop in row_bands(len(features), features.shape[1] * NUMPY_STEP):  # Ctrl-C between bands
        d2[start:stop] = np.sum((features[start:stop] - features[first[start:stop]]) ** 2, axis=1)
    scale = float(np.median(d2)) if d2.size else 1.0
    return max(scale, 1e-6)


def k_coherence_sets_from_parent(
    parent_sets: np.ndarray,
    parent_shape: tuple[int, int],
    features: np.ndarray,
    shape: tuple[int, int],
    k: int,
    radius: int = 2,
) -> tuple[np.ndarray, float]:
    """k-coherence sets of a level propagated from the next coarser level's sets and refined
    on this level's appearance vectors (hierarchical search: the children of the parent's
    similar pixels and their 3x3 neighbours). Far cheaper than a fresh search on large levels,
    with the same result wherever the coarse level already found the right region.
    """
    from barkgen.nnf._kernels import refine_child_sets

    parent_sets = np.ascontiguousarray(parent_sets, dtype=np.int32)
    features = np.ascontiguousarray(features, dtype=np.float32)
    sets = np.empty((shape[0] * shape[1], k), np.int32)
    # a child and its 3x3 neighbours per parent entry, one distance each
    for start, stop in row_bands(shape[0], shape[1] * parent_sets.shape[1] * 9 * features.shape[1]):
        refine_child_sets(
            parent_sets,
            np.int32(parent_shape[1]),
            np.int32(parent_shape[0]),
            features,
            np.int32(shape[0]),
            np.int32(shape[1]),
            np.int32(k),
            np.int32(radius),
            sets,
            np.int32(start),
            np.int32(stop),
        )
    return sets, _scale(features, sets)


def propagate_k_coherence(
    sets: np.ndarray, features: np.ndarray, shape: tuple[int, int], radius: int = 2, passes: int = 2
) -> tuple[np.ndarray, float]:
    """k-coherence sets improved by ``passes`` of propagation (Tong et al. 2002: a pixel's
    neighbour's similar pixels, shifted back, are candidates for the pixel): the sets of a
    level refined from a parent's come near a direct search's at a small part of its cost."""
    from barkgen.nnf._kernels import propagate_sets

    features = np.ascontiguousarray(features, dtype=np.float32)
    sets = np.ascontiguousarray(sets, dtype=np.int32)
    # the 9 sets around a pixel, one distance per entry
    bands = row_bands(shape[0], shape[1] * 9 * sets.shape[1] * features.shape[1])
    for _ in range(passes):
        propagated = np.empty_like(sets)
        for start, stop in bands:
            propagate_sets(
                sets,
                features,
                np.int32(shape[0]),
                np.int32(shape[1]),
                np.int32(radius),
                propagated,
                np.int32(start),
                np.int32(stop),
            )
        sets = propagated
    return sets, _scale(features, sets)
