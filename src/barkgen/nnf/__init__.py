"""Neighbour search: appearance-space neighbourhood vectors and k-coherence sets."""

from barkgen.nnf.appearance import (
    NeighbourhoodProjection,
    neighbourhood_pca,
    project_neighbourhoods,
)
from barkgen.nnf.kcoherence import k_coherence_sets, k_coherence_sets_from_parent, knn_search

__all__ = [
    "NeighbourhoodProjection",
    "k_coherence_sets",
    "k_coherence_sets_from_parent",
    "knn_search",
    "neighbourhood_pca",
    "project_neighbourhoods",
]
