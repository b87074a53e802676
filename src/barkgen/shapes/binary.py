"""Binary shape synthesis by boundary-patch optimisation (Rosenberger et al. 2009,
laitoch2018 §3.6.2–3.6.3).

One iteration matches every boundary patch of the synthesized shape ``S`` to an exemplar
boundary patch (greedy, closest pairs first, each exemplar patch used ``Q`` or ``Q + 1`` times),
superimposes the matched exemplar patches on ``S`` with Gaussian falloff and weight
``1 / (1 + D)`` (eq. 3.10), and re-thresholds the pixels next to the boundary by the sign of the
summed weights, with a threshold shifted (a little) so that the shape keeps the exemplar's area.
Only pixels next to the boundary may change, so the boundary moves and no holes or specks open
inside regions (which superimposed whole patches otherwise seed and grow into lattices).
Coarse-to-fine over a Gaussian pyramid, see :mod:`barkgen.shapes.layered`.

Beyond the thesis: each round of the matching takes the closest pairs first over each
synthesized patch's nearest candidates among the exemplar patches with uses left (a few rounds
use every exemplar patch its ``Q`` or ``Q + 1`` times), and the threshold range is relative to
the weights (half their mean magnitude) instead of fixed at 1e-7..1e-2. :func:`next_layer_mask`
is §3.6.4's mask shrinking for the layer above.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen.errors import InvalidInputError
from barkgen.shapes.patches import (
    binary_index,
    boundary_pixels,
    extract_patches,
    pack,
    rotated,
    subsample,
)

#: weight of an edited level's guide in the shape optimisation (:func:`adjust_shape`), in units of
#: the matched boundary patches' mean weight
GUIDE_WEIGHT = 1.0


@dataclass(frozen=True)
class ShapeConfig:
    """Parameters of the boundary-patch shape optimisation (laitoch2018 §3.6, layered strategy).

    Parameters
    ----------
    patch : int, default 9
        Side of the boundary patches (odd, >= 3).
    iterations_coarsest, iterations_finest : int, default 8, 2
        Optimisation iterations at the coarsest and the finest pyramid level (linear in
        between; fine levels only refine boundaries).
    candidates : int, default 8
        Nearest exemplar patches considered per synthesized patch by the greedy matching.
    max_exemplar_patches : int, default 20000
        Exemplar boundary patches kept per level (a seeded random subset beyond that).
    falloff_sigma : float, optional
        The Gaussian falloff of eq. 3.10 in pixels (``patch / 4`` when None).
    tolerance : float, default 0.002
        Stop a level when fewer than this fraction of pixels change.
    coarsest_exemplar : int, default 32
        The coarsest level keeps at least this many exemplar pixels per side.
    threshold_shift : float, default 0.5
        How far the dynamic threshold may move from 0 to keep the exemplar's area, in units of
        the mean absolute weight near the boundary.
    shrink_masks : bool, default False
        §3.6.4: each layer's mask is the layer below shrunk where the exemplar patches matched
        to that layer's boundary say the next layer does not reach (:func:`next_layer_mask`),
        so successive layers stay correlated as in the exemplar; False: the layer below as it
        is. Off by default: on nested shapes with margins (cores inside discs) it keeps the
        cores off the edges (5 % of their pixels within 3 px, against 17-20 %), but on bark's
        label maps, whose layers touch, it thins the upper layers at the coarse levels, where
        they are a few pixels wide, and eq. 3.9's dissimilarity grows (up to 7x the halves' on
        four of eight maps measured).

    Raises
    ------
    InvalidInputError
        A bad patch size, iteration count or candidate count.

    References
    ----------
    .. [1] laitoch2018, §3.6 (eq. 3.7-3.10); rosenberger2009.
    """

    patch: int = 9
    iterations_coarsest: int = 8
    iterations_finest: int = 2
    candidates: int = 8
    max_exemplar_patches: int = 20000
    falloff_sigma: float | None = None
    tolerance: float = 0.002
    coarsest_exemplar: int = 32
    threshold_shift: float = 0.5
    shrink_masks: bool = False

    def __post_init__(self) -> None:
        if self.patch < 3 or self.patch % 2 == 0:
            raise InvalidInputError(f"patch must be an odd number >= 3, not {self.patch}")
        if min(self.iterations_coarsest, self.iterations_finest) < 0:
            raise InvalidInputError("iterations must be >= 0")
        if self.candidates < 1 or self.max_exemplar_patches < 16:
            raise InvalidInputError("candidates must be >= 1 and max_exemplar_patches >= 16")

    def iterations(self, level: int, n_levels: int) -> int:
        """Iterations at ``level`` (0 = finest) of ``n_levels``."""
        if n_levels <= 1:
            return self.iterations_coarsest
        t = level / (n_levels - 1)
        return int(round(self.iterations_finest + t * (self.iterations_coarsest - self.iterations_finest)))

    def falloff(self) -> np.ndarray:
        """The Gaussian falloff of eq. 3.10, ``(patch, patch)`` float32, 1 at the centre."""
        sigma = self.falloff_sigma or self.patch / 4.0
        r = np.arange(self.patch) - self.patch // 2
        g = np.exp(-(r**2) / (2 * sigma**2))
        return np.ascontiguousarray(np.outer(g, g), dtype=np.float32)


class ExemplarBoundary:
    """The boundary patches of one binary exemplar shape (one pyramid level of one layer), with
    the allowed rotations, packed for faiss and as +1/-1 patches for the weights of eq. 3.10."""

    def __init__(
        self,
        shape: np.ndarray,
        quarter_turns: tuple[int, ...],
        config: ShapeConfig,
        rng: np.random.Generator,
        next_layer: np.ndarray | None = None,
    ) -> None:
        ys, xs = subsample(*boundary_pixels(shape), config.max_exemplar_patches, rng)
        self.count = len(ys)
        self.fraction = float(np.mean(shape))
        #: the next layer (nested in ``shape``) around each patch, +1/-1, rows as ``signed``'s
        self.next_signed: np.ndarray | None = None
        if self.count == 0:
            self.index = None
            return
        if next_layer is not None:
            above, _ = rotated(extract_patches(next_layer, ys, xs, config.patch), quarter_turns)
            self.next_signed = above.astype(np.float32) * 2 - 1
        patches, _ = rotated(extract_patches(shape, ys, xs, config.patch), quarter_turns)
        self.signed = patches.astype(np.float32) * 2 - 1
        self.packed = pack(patches)  # every row: a patch (row % count) in one of its turns
        self.index = binary_index(self.packed)


#: rounds of §3.6.2's greedy matching after the first (each matches the synthesized patches left
#: against the exemplar patches with uses left), and how many times the first round's
#: ``candidates`` they visit (a flat Hamming search costs about the same for any number kept:
#: more candidates, fewer rounds)
MATCH_ROUNDS = 3
LATER_CANDIDATES = 8


def match_boundary(
    codes: np.ndarray, exemplar: ExemplarBoundary, candidates: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Greedy boundary-patch matching (laitoch2018 §3.6.2) of the packed synthesized patches
    ``codes``: returns, per synthesized patch, the exemplar row (patch and rotation) and its
    distance ``D`` (differing pixels).

    |B_S| = Q |B_E| + R: every exemplar patch is used Q times, R random ones Q + 1 times (every
    one at most once when Q = 0). Each round visits the ``candidates`` nearest exemplar patches
    with uses left of every synthesized patch still unmatched, closest pair first (random order
    among equal distances); the patches matched are removed and the next round matches the rest
    against the exemplar patches with uses left (§3.6.2's "repeat until all patches have been
    matched"), so every exemplar patch is used its Q or Q + 1 times: the completeness half of
    eq. 3.9. After :data:`MATCH_ROUNDS` more rounds a patch still unmatched takes its nearest.
    """
    import barkgen.shapes._kernels as K

    assert exemplar.index is not None  # an exemplar without boundary is never matched (adjust_shape)
    n_s, n_e = codes.shape[0], exemplar.count
    codes = np.ascontiguousarray(codes)
    q, r = divmod(n_s, n_e)
    capacity = np.full(n_e, max(q, 1), np.int64)
    if q > 0 and r > 0:
        capacity[rng.choice(n_e, size=r, replace=False)] += 1
    chosen_row = np.full(n_s, -1, np.int64)
    chosen_dist = np.zeros(n_s, np.float32)
    nearest_row, nearest_dist = None, None
    left = np.arange(n_s)
    for round_ in range(MATCH_ROUNDS + 1):
        if round_ == 0:
            index, open_rows = exemplar.index, None
        else:
            open_rows = np.flatnonzero(capacity[np.arange(exemplar.index.ntotal) % n_e] > 0)
            if open_rows.size == 0:
                break
            index = binary_index(exemplar.packed[open_rows])
        k = min(candidates * (1 if round_ == 0 else LATER_CANDIDATES), index.ntotal)
        dist, rows = index.search(codes[left], k)
        if open_rows is not None:
            rows = open_rows[rows]
        if round_ == 0:
            nearest_row, nearest_dist = rows[:, 0].copy(), dist[:, 0].astype(np.float32)
        flat_dist = dist.ravel()
        order = np.lexsort((rng.random(flat_dist.size), flat_dist)).astype(np.int64)
        query = np.repeat(np.arange(left.size, dtype=np.int64), k)
        chosen = np.full(left.size, -1, np.int64)
        K.assign_with_capacity(order, query, (rows.ravel() % n_e).astype(np.int64), capacity, chosen)
        done = chosen >= 0
        chosen_row[left[done]] = rows.ravel()[chosen[done]]
        chosen_dist[left[done]] = flat_dist[chosen[done]]
        left = left[~done]
        if left.size == 0:
            break
    assert nearest_row is not None and nearest_dist is not None
    chosen_row[left] = nearest_row[left]  # no uses left anywhere near: the nearest
    chosen_dist[left] = nearest_dist[left]
    return chosen_row, chosen_dist


def next_layer_mask(
    shape: np.ndarray, exemplar: ExemplarBoundary, *, config: ShapeConfig, edges: Boundary, rng: np.random.Generator
) -> np.ndarray:
    """The mask of the layer above ``shape`` (laitoch2018 §3.6.4), read round its ``edges``:
    ``shape`` shrunk where the
    exemplar patches matched to its boundary, superimposed as in eq. 3.10 but with the
    exemplar's *next* layer as their indicator, predict that the next layer does not reach: the
    band of pixels along the boundary (the boundary and its 8-neighbours) leaves the mask where
    the weights are negative. Repeated at every level, the mask keeps the next layer off the
    edges the exemplar keeps it off."""
    import barkgen.shapes._kernels as K

    s = np.ascontiguousarray(shape, dtype=np.uint8)
    if exemplar.index is None or exemplar.next_signed is None:
        return s
    ys, xs = boundary_pixels(s, edges)
    if len(ys) == 0:
        return s
    rows, dist = match_boundary(pack(extract_patches(s, ys, xs, config.patch, edges)), exemplar, config.candidates, rng)
    w = np.zeros(s.shape, np.float32)
    K.accumulate_weights(ys, xs, exemplar.next_signed[rows], 1.0 / (1.0 + dist), config.falloff(), edges.wrap, w)
    # only the band along the boundary may leave the mask: where the next layer should keep off
    # the edge; inside, the next layer's own optimisation places it
    off = (w < 0) & _band(ys, xs, s.shape, edges)
    return s & ~off


def _band(ys: np.ndarray, xs: np.ndarray, shape: tuple[int, int], edges: Boundary) -> np.ndarray:
    """Boundary pixels and their 8-neighbours as a boolean image (round the ``edges`` that wrap)."""
    band = np.zeros(shape, bool)
    h, w = shape
    wrap_y, wrap_x = edges.wrap
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            y, x = ys + dy, xs + dx
            y = y % h if wrap_y else np.clip(y, 0, h - 1)
            x = x % w if wrap_x else np.clip(x, 0, w - 1)
            band[y, x] = True
    return band


def dynamic_threshold(weights: np.ndarray, need: int, limit: float) -> float:
    """The threshold ``t`` in ``[-limit, limit]`` for which ``weights > t`` selects the number of
    pixels closest to ``need`` (laitoch2018 §3.6.3's dynamic threshold: the sign of the
    superimposed weights decides, shifted at most by ``limit`` to match the exemplar's area)."""
    if weights.size == 0:
        return 0.0
    need = min(max(need, 0), weights.size)
    ordered = np.sort(weights)[::-1]
    if need == 0:
        exact = float(ordered[0])
    elif need == weights.size:
        exact = float(ordered[-1]) - 1e-6
    else:  # halfway between the need-th largest and the next
        exact = 0.5 * float(ordered[need - 1] + ordered[need])
    return float(np.clip(exact, -limit, limit))


def adjust_shape(
    shape: np.ndarray,
    exemplar: ExemplarBoundary,
    *,
    mask: np.ndarray | None,
    iterations: int,
    config: ShapeConfig,
    edges: Boundary,
    rng: np.random.Generator,
    fraction: float | None = None,
    guide: np.ndarray | None = None,
) -> np.ndarray:
    """Optimise the binary ``shape`` towards the exemplar's boundary patches (§3.6.2–3.6.3).

    Each iteration superimposes the matched exemplar patches on the boundary (eq. 3.10) into a
    weight matrix ``W``; near the boundary a pixel is then in the shape when its ``W`` is above a
    threshold near 0, set so that the shape comes as close as it may to the exemplar's area
    fraction (of the whole image).
    ``mask`` (nested layers) bounds where the shape may be; ``fraction`` overrides the area
    fraction to keep (an edited level keeps its own). Stops early when fewer than
    ``config.tolerance`` of the pixels change. The shape is read round its ``edges`` (a map
    that tiles wraps).
    """
    import barkgen.shapes._kernels as K

    s = np.ascontiguousarray(shape, dtype=np.uint8)
    if mask is not None:
        s &= mask
    if exemplar.index is None:
        return s
    target = int(round((exemplar.fraction if fraction is None else fraction) * s.size))
    falloff = config.falloff()
    for _ in range(iterations):
        ys, xs = boundary_pixels(s, edges)
        if len(ys) == 0:
            break
        rows, dist = match_boundary(
            pack(extract_patches(s, ys, xs, config.patch, edges)), exemplar, config.candidates, rng
        )
        w = np.zeros(s.shape, np.float32)
        K.accumulate_weights(ys, xs, exemplar.signed[rows], 1.0 / (1.0 + dist), falloff, edges.wrap, w)
        # only pixels next to the boundary may change: the boundary moves, no holes or specks
        # open up away from it
        near = (w != 0) & _band(ys, xs, s.shape, edges)
        if mask is not None:
            near &= mask.astype(bool)
        need = target - int(np.count_nonzero(s[~near]))
        values = w[near]
        if guide is not None and values.size:
            values = values + GUIDE_WEIGHT * float(np.mean(np.abs(values))) * guide[near]
        limit = config.threshold_shift * float(np.mean(np.abs(values))) if values.size else 0.0
        new = s.copy()
        new[near] = values > dynamic_threshold(values, need, limit)
        if mask is not None:
            new &= mask
        changed = int(np.count_nonzero(new != s))
        s = new
        if changed < config.tolerance * s.size:
            break
    return s
