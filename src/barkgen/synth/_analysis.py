"""The analysis phase of the discrete solver: what it matches and what it precomputes per
exemplar (mazzolini2012 §4.1.2, laitoch2018 §3.3.1).

:func:`matching_features` turns an exemplar (and its extra maps) into the per-pixel features
that are compared; :func:`analyse_exemplar` builds, on every pyramid level, the appearance-space
projections of the neighbourhoods (Lefebvre & Hoppe 2006) and the k-coherence sets (Tong et al.
2002); :class:`AnalysisCache` keeps those analyses for reuse across seeds.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from barkgen._shared.arrays import as_hw_c, unit_float
from barkgen.color import rgb_to_lab
from barkgen.nnf import (
    NeighbourhoodProjection,
    k_coherence_sets,
    k_coherence_sets_from_parent,
    neighbourhood_pca,
)
from barkgen.nnf.kcoherence import propagate_k_coherence
from barkgen.pyramid import gaussian_pyramid
from barkgen.synth._config import SynthesisConfig

#: exemplar levels with at most this many pixels get an exact k-NN search (faiss); larger
#: ones refine their parent's k-coherence sets
DIRECT_SEARCH_LIMIT = 2048
#: a coarsest level larger than this (a thin or tiny output of a large photo: few levels) is
#: not searched directly either (a million-pixel k-NN search took 14 s): its sets come from a
#: coarser level's, searched for that alone (:func:`_guide_sets`), refined and propagated
GUIDED_SEARCH_LIMIT = 262_144


@dataclass
class LevelAnalysis:
    """The k-coherence analysis of one exemplar pyramid level (mazzolini2012 §4.1.2)."""

    height: int
    width: int
    features: np.ndarray  # (h * w, C) float32 per-pixel matching features
    coords_y: np.ndarray  # (h * w,) int32 row of each flat index (division-free decoding)
    coords_x: np.ndarray  # (h * w,) int32 column of each flat index
    projections: dict[int, NeighbourhoodProjection]
    kernel_weights: dict[int, np.ndarray]  # projection weights laid out [dy, dx, c, d] for m_step
    ksets: np.ndarray  # (h * w, k) int32
    scale: float  # typical squared appearance distance to the nearest distinct neighbour
    wrap: tuple[bool, bool] = (False, False)  # the exemplar tiles along (rows, columns)

    @property
    def grid(self) -> tuple:
        """``(coords_y, coords_x, height, width, wrap_rows, wrap_columns)``: the level's exemplar
        grid as the kernels take it (``exemplar`` in :mod:`barkgen.synth._kernels`)."""
        return (self.coords_y, self.coords_x, int(self.height), int(self.width), bool(self.wrap[0]), bool(self.wrap[1]))


def matching_features(exemplar: np.ndarray, extras: Mapping[str, np.ndarray] | None, extra_weight: float) -> np.ndarray:
    """Per-pixel features used for matching: CIELAB (L in 0..100) or L alone for grey images,
    plus each extra channel scaled to 0..100 and weighted (laitoch2018 §3.3.1, extra channels).
    """
    ex = unit_float(as_hw_c("exemplar", exemplar))
    if ex.shape[2] >= 3:
        feats = [rgb_to_lab(ex[:, :, :3])]
    else:
        feats = [ex[:, :, :1] * 100.0]
    for name, arr in (extras or {}).items():
        e = unit_float(as_hw_c(f"extra map {name!r}", arr))
        feats.append(e * (100.0 * extra_weight / np.sqrt(e.shape[2])))
    return np.ascontiguousarray(np.concatenate(feats, axis=2), dtype=np.float32)


def schedule_sizes(config: SynthesisConfig, level: int, n_levels: int) -> list[int]:
    return sorted({s for s, _ in config.schedule_for(level, n_levels)}, reverse=True)


def analyse_exemplar(
    features: np.ndarray,
    n_levels: int,
    config: SynthesisConfig,
    progress: Callable[[], None] | None = None,
    wrap: tuple[bool, bool] = (False, False),
    *,
    finest: int = 0,
    known: list[LevelAnalysis | None] | None = None,
) -> list[LevelAnalysis | None]:
    """k-coherence analysis phase on the pyramid levels ``finest`` to ``n_levels - 1`` of the
    exemplar features (the finer ones are ``None``: a solve that stops above them never reads
    them); ``wrap`` ``(rows, columns)``: the exemplar tiles along that axis
    (:mod:`barkgen.synth._edges`), so its pyramid and neighbourhoods run round its edges.
    ``known``: levels analysed before, from the coarsest down (each level depends only on the
    coarser ones, so they are taken as they are and the analysis goes on below them)."""
    wrap = (bool(wrap[0]), bool(wrap[1]))
    pyramid = gaussian_pyramid(features, n_levels, wrap)
    levels: list[LevelAnalysis | None] = list(known) if known is not None else [None] * n_levels
    parent: LevelAnalysis | None = None
    coarsest = pyramid[-1]
    if levels[-1] is None and coarsest.shape[0] * coarsest.shape[1] > GUIDED_SEARCH_LIMIT:
        parent = _guide_sets(coarsest, max(schedule_sizes(config, n_levels - 1, n_levels)), config, wrap)
    for lvl in reversed(range(finest, n_levels)):
        if levels[lvl] is not None:
            parent = levels[lvl]
            if progress:
                progress()
            continue
        img = pyramid[lvl]
        h, w, c = img.shape
        projections = {
            s: neighbourhood_pca(img, s, config.pca_components, wrap=wrap)
            for s in schedule_sizes(config, lvl, n_levels)
        }
        largest = projections[max(projections)]
        if parent is None or h * w <= DIRECT_SEARCH_LIMIT:
            ksets, scale = k_coherence_sets(largest.features, w, config.k, radius=2)
        else:
            ksets, scale = k_coherence_sets_from_parent(
                parent.ksets, (parent.height, parent.width), largest.features, (h, w), config.k, radius=2
            )
            if parent.features is None:  # seeded by _guide_sets: no solve checks these sets
                ksets, scale = propagate_k_coherence(ksets, largest.features, (h, w))
        cy, cx = np.divmod(np.arange(h * w, dtype=np.int32), np.int32(w))
        kernel_weights = {
            size: np.ascontiguousarray(p.weights.transpose(1, 2, 3, 0)) for size, p in projections.items()
        }
        parent = LevelAnalysis(h, w, img.reshape(h * w, c), cy, cx, projections, kernel_weights, ksets, scale, wrap)
        levels[lvl] = parent
        if progress:
            progress()
    return levels


def _guide_sets(image: np.ndarray, size: int, config: SynthesisConfig, wrap: tuple[bool, bool]) -> LevelAnalysis:
    """The k-coherence sets of the first level coarser than ``image`` with at most
    :data:`GUIDED_SEARCH_LIMIT` pixels, by a direct search: the parent from which ``image``'s
    own sets are refined (and then propagated). Only the sets and the shape are filled in: no
    solver reads this level."""
    level = image
    while level.shape[0] * level.shape[1] > GUIDED_SEARCH_LIMIT and min(level.shape[:2]) > 8:
        level = gaussian_pyramid(level, 2, wrap)[1]
    h, w = level.shape[:2]
    features = neighbourhood_pca(level, size, config.pca_components, wrap=wrap).features
    ksets, scale = k_coherence_sets(features, w, config.k, radius=2)
    # (a guide level has no features or coordinates: nothing reads them)
    return LevelAnalysis(h, w, None, None, None, {}, {}, ksets, scale, wrap)  # type: ignore[arg-type]


class AnalysisCache:
    """Exemplar analyses (:func:`analyse_exemplar`) kept for reuse.

    The k-coherence analysis phase (mazzolini2012 §4.1.2) depends on the exemplar alone, not on
    the seed, so one analysis serves every variant synthesized from one photo. Entries are keyed
    by what the analysis depends on (the matching features' bytes, the pyramid depth and the
    config's analysis fields), so a cache can never hand back the analysis of other inputs: a
    changed photo, label map or option is a miss and is analysed afresh. Plain data, so it can
    be pickled and shipped to other processes (:mod:`barkgen.batch`).
    """

    def __init__(self) -> None:
        self._entries: dict[str, list[LevelAnalysis | None]] = {}
        # the seed-independent matching features made through :meth:`features`, by their
        # inputs' digest; and the digest of each such array's bytes, by its identity
        self._features: dict[str, Any] = {}
        self._digests: dict[int, tuple[np.ndarray, str]] = {}

    def __getstate__(self) -> dict:
        return {"_entries": self._entries, "_features": self._features}

    def __setstate__(self, state: dict) -> None:
        self._entries, self._features, self._digests = state["_entries"], state.get("_features", {}), {}
        for value in self._features.values():
            self._remember(value)

    def features(self, name: str, inputs: tuple, make: Callable[[], Any]) -> Any:
        """``make()``, made once for these ``inputs`` (arrays and plain values) and kept: the
        matching features of an exemplar (and what comes with them) depend on the exemplar
        alone, not on the seed, so every variant of one photo shares them. The arrays made are
        read-only and their bytes' digest is kept with them, so :meth:`analyse` does not hash
        them again on every solve."""
        digest = hashlib.sha256(repr((name, _plain(inputs))).encode())
        for value in inputs:
            if isinstance(value, np.ndarray):
                digest.update(np.ascontiguousarray(value).data.cast("B"))
        key = digest.hexdigest()
        if key not in self._features:
            value = make()
            for array in _arrays(value):
                array.flags.writeable = False
            self._features[key] = value
            self._remember(value)
        return self._features[key]

    def _remember(self, value: Any) -> None:
        for array in _arrays(value):
            self._digests[id(array)] = (array, _bytes_digest(array))

    def key(
        self, features: np.ndarray, n_levels: int, config: SynthesisConfig, wrap: tuple[bool, bool] = (False, False)
    ) -> str:
        """What an analysis of ``features`` depends on, as a digest: the features' bytes and
        shape, the pyramid depth, the config's analysis fields and the exemplar's wrap."""
        # the schedules' neighbourhood sizes, not their iteration counts: those are all the
        # analysis depends on
        sizes = tuple(tuple(schedule_sizes(config, lvl, n_levels)) for lvl in range(n_levels))
        key: tuple = (features.shape, features.dtype.str, int(n_levels), config.k, config.pca_components, sizes)
        if any(wrap):
            key += (bool(wrap[0]), bool(wrap[1]))
        known = self._digests.get(id(features))
        data = known[1] if known is not None and known[0] is features else _bytes_digest(features)
        return hashlib.sha256((repr(key) + data).encode()).hexdigest()

    def analyse(
        self,
        features: np.ndarray,
        n_levels: int,
        config: SynthesisConfig,
        progress: Callable[[], None] | None = None,
        wrap: tuple[bool, bool] = (False, False),
        *,
        finest: int = 0,
    ) -> list[LevelAnalysis | None]:
        """:func:`analyse_exemplar` of the levels ``finest`` and coarser, each computed on the
        first call that needs it for these inputs only."""
        key = self.key(features, n_levels, config, wrap)
        levels = self._entries.get(key)
        if levels is None or levels[finest] is None:
            levels = self._entries[key] = analyse_exemplar(
                features, n_levels, config, progress, wrap, finest=finest, known=levels
            )
        elif progress is not None:
            for _ in range(n_levels - finest):
                progress()
        return levels

    def __len__(self) -> int:
        return len(self._entries)

    @property
    def nbytes(self) -> int:
        """Bytes held by the cached arrays."""
        total = 0
        for levels in self._entries.values():
            for la in filter(None, levels):
                total += la.features.nbytes + la.coords_y.nbytes + la.coords_x.nbytes + la.ksets.nbytes
                total += sum(w.nbytes for w in la.kernel_weights.values())
                total += sum(p.features.nbytes for p in la.projections.values())
        return total


def _bytes_digest(array: np.ndarray) -> str:
    """SHA-256 of an array's bytes (OpenSSL's SHA-256: 2.3x blake2b's speed on SHA-NI CPUs)."""
    return hashlib.sha256(np.ascontiguousarray(array).data.cast("B")).hexdigest()


def _arrays(value: Any) -> list[np.ndarray]:
    """The arrays ``value`` is or holds (a tuple's items)."""
    items = value if isinstance(value, tuple) else (value,)
    return [item for item in items if isinstance(item, np.ndarray)]


def _plain(inputs: tuple) -> tuple:
    """``inputs`` with each array replaced by its shape and type (its bytes are hashed apart)."""
    return tuple(("array", v.shape, v.dtype.str) if isinstance(v, np.ndarray) else v for v in inputs)
