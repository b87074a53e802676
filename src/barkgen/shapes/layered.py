"""Layered label-map synthesis (laitoch2018 §3.6.4, Rosenberger et al. 2009).

A label map is read as a layer map: labels are stacked in an order, and a pixel of layer ``i``
belongs to every layer below it too. Layer ``i``'s binary shape ``rank >= i`` is synthesized by
:func:`barkgen.shapes.binary.adjust_shape` inside its mask, coarse to fine over a Gaussian
pyramid from a random start. The mask is layer ``i - 1``; with ``ShapeConfig(shrink_masks=True)``
it is shrunk where the exemplar patches matched to its boundary say layer ``i`` does not reach
(§3.6.4: "each mask is initially set to the shape of the previous layer and then is shrunk
according to a weight matrix created based on the last boundary patch matching"), so successive
layers stay correlated as in the exemplar (off by default: see the option).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen._shared.canvas import Canvas
from barkgen.pyramid import level_shape
from barkgen.shapes.binary import ExemplarBoundary, ShapeConfig, adjust_shape, next_layer_mask

#: exhaustive search of layer orders up to this many labels, greedy beyond
_EXHAUSTIVE_ORDER = 7


def adjacency(codes: np.ndarray, n_labels: int) -> np.ndarray:
    """``C[a, b]``: the number of 4-neighbour pixel pairs with labels ``a`` and ``b`` (symmetric)."""
    c = np.zeros((n_labels, n_labels), np.int64)
    for a, b in ((codes[:, 1:], codes[:, :-1]), (codes[1:, :], codes[:-1, :])):
        diff = a != b
        np.add.at(c, (a[diff], b[diff]), 1)
    return c + c.T


def automatic_layer_order(codes: np.ndarray, n_labels: int) -> list[int]:
    """An automatic layer order, bottom layer first (laitoch2018 §3.6.4 left it to the user).

    Nested layers can only reproduce boundaries between successive layers, so the order is the
    one that puts the most of the exemplar's label boundaries between successive layers
    (exhaustive for up to 7 labels, greedy beyond); of an order and its reverse, the one whose
    bottom layer covers more of the exemplar (the background) is taken.

    Parameters
    ----------
    codes : ndarray of int, shape (h, w)
        The exemplar's label codes ``0 .. n_labels - 1``.
    n_labels : int
        Number of labels.

    Returns
    -------
    list of int
        Label codes, bottom layer first.

    References
    ----------
    .. [1] laitoch2018, §3.6.4 (layers); rosenberger2009 (layered shape synthesis).

    Examples
    --------
    >>> import numpy as np
    >>> codes = np.zeros((8, 8), int)
    >>> codes[2:6, 2:6] = 1
    >>> codes[3:5, 3:5] = 2
    >>> automatic_layer_order(codes, 3)
    [0, 1, 2]
    """
    adj = adjacency(codes, n_labels)
    area = np.bincount(codes.ravel(), minlength=n_labels)
    labels = list(range(n_labels))
    if n_labels <= 2:
        return sorted(labels, key=lambda lab: -area[lab])
    if n_labels <= _EXHAUSTIVE_ORDER:
        best = max(
            itertools.permutations(labels),
            key=lambda p: (sum(adj[p[i], p[i + 1]] for i in range(n_labels - 1)), area[p[0]] - area[p[-1]]),
        )
        order = list(best)
    else:
        order = [int(np.argmax(area))]
        while len(order) < n_labels:
            rest = [lab for lab in labels if lab not in order]
            order.append(max(rest, key=lambda lab: (adj[order[-1], lab], area[lab])))
    if area[order[-1]] > area[order[0]]:
        order.reverse()
    return order


def _smooth(field: np.ndarray, sigma: float, edges: Boundary) -> np.ndarray:
    import cv2

    r = int(3 * sigma) + 1
    padded = edges.pad(field.astype(np.float32), r, other="reflect")
    return cv2.GaussianBlur(padded, (0, 0), sigma)[r:-r, r:-r]


def _top_fraction(score: np.ndarray, allowed: np.ndarray, count: int) -> np.ndarray:
    """The ``count`` highest-scoring allowed pixels as a uint8 shape."""
    out = np.zeros(score.shape, np.uint8)
    idx = np.flatnonzero(allowed)
    count = min(max(count, 0), idx.size)
    if count:
        take = idx[np.argpartition(-score.ravel()[idx], count - 1)[:count]]
        out.ravel()[take] = 1
    return out


def random_layers(
    shape: tuple[int, int], fractions: list[float], edges: Boundary, rng: np.random.Generator
) -> np.ndarray:
    """Random initialisation (laitoch2018 §3.6): smooth random noise (round the ``edges`` that
    wrap), each layer the highest noise values inside the layer below, with the exemplar's area
    fraction. Returns ranks."""
    rank = np.zeros(shape, np.int32)
    allowed = np.ones(shape, bool)
    for frac in fractions[1:]:
        noise = _smooth(rng.random(shape), 1.0, edges)
        layer = _top_fraction(noise, allowed, int(round(frac * rank.size)))
        rank += layer
        allowed = layer.astype(bool)
    return rank


def upsample_ranks(rank: np.ndarray, shape: tuple[int, int], n_layers: int, edges: Boundary) -> np.ndarray:
    """Next pyramid level's ranks: each layer's shape doubled, smoothed by a 3x3 box and
    re-thresholded (round corners instead of 2x2 blocks), nesting kept."""
    h, w = shape
    out = np.zeros(shape, np.int32)
    below = np.ones(shape, bool)
    for i in range(1, n_layers):
        big = np.repeat(np.repeat((rank >= i).astype(np.float32), 2, 0), 2, 1)[:h, :w]
        padded = edges.pad(big, 1, other="edge")
        box = sum(padded[dy : dy + h, dx : dx + w] for dy in range(3) for dx in range(3)) / 9.0
        layer = (box > 0.5) & below
        out += layer
        below = layer
    return out


def edit_guide(layer: np.ndarray, shape: tuple[int, int], edges: Boundary) -> np.ndarray:
    """An edited level's layer brought to a finer level's ``shape`` as a soft guide in [-1, 1]:
    +1 inside, -1 outside, a smooth ramp across the edit's boundary (bilinear, so its steps
    do not make staircases)."""
    import cv2

    h, w = shape
    src = layer.astype(np.float32)
    if edges.wraps_both:  # the ramp runs on across the border of a map that tiles
        pad = 2
        big = cv2.resize(np.pad(src, pad, mode="wrap"), None, fx=w / src.shape[1], fy=h / src.shape[0])
        oy, ox = round(pad * h / src.shape[0]), round(pad * w / src.shape[1])
        up = big[oy : oy + h, ox : ox + w]
    else:
        up = cv2.resize(src, (w, h), interpolation=cv2.INTER_LINEAR)
    return (2.0 * up - 1.0).astype(np.float32)


def synthesize_layers(
    exemplar_levels: list[np.ndarray],
    canvas: Canvas,
    order: list[int],
    *,
    quarter_turns: tuple[int, ...],
    config: ShapeConfig,
    rng: np.random.Generator,
    start: tuple[int, np.ndarray] | None = None,
    on_level: Callable[[int, np.ndarray], None] | None = None,
    tick: Callable[[], None] | None = None,
) -> np.ndarray:
    """Layered synthesis over the pyramid of the ``canvas`` (its shape; every level tiles when
    it does). ``exemplar_levels``: the exemplar's label codes per level, finest first. ``order``: labels bottom layer first. ``start``: ``(level, codes)`` to
    resume from (an edited level), which guides every finer level (:func:`edit_guide`, as the
    engine's edits are guided); else a random start at the coarsest level. ``on_level(level,
    codes)`` receives each level's result. Returns the finest level's codes."""
    n_levels = len(exemplar_levels)
    n_layers = len(order)
    out_shape, edges = canvas.shape, Boundary(canvas.tile)
    rank_of = np.empty(n_layers, np.int32)
    rank_of[order] = np.arange(n_layers, dtype=np.int32)
    to_label = np.asarray(order, np.int32)
    first = n_levels - 1 if start is None else start[0]
    rank = None
    kept = None  # an edited level's own layer areas, kept at every finer level
    edited = None if start is None else rank_of[start[1]]  # guides every finer level
    for lvl in range(first, -1, -1):
        shape = level_shape(out_shape, lvl)
        ex_rank = rank_of[exemplar_levels[lvl]]
        if rank is None:
            if start is not None:
                rank = rank_of[start[1]]
                kept = [float(np.mean(rank >= i)) for i in range(n_layers)]
            else:
                fractions = [float(np.mean(ex_rank >= i)) for i in range(n_layers)]
                rank = random_layers(shape, fractions, edges, rng)
        else:
            rank = upsample_ranks(rank, shape, n_layers, edges)
        iterations = config.iterations(lvl, n_levels)
        below = np.ones(shape, np.uint8)
        new_rank = np.zeros(shape, np.int32)
        for i in range(1, n_layers):
            above = (ex_rank >= i + 1).astype(np.uint8) if config.shrink_masks and i + 1 < n_layers else None
            boundary = ExemplarBoundary((ex_rank >= i).astype(np.uint8), quarter_turns, config, rng, above)
            layer = adjust_shape(
                (rank >= i).astype(np.uint8),
                boundary,
                mask=below,
                iterations=iterations,
                config=config,
                edges=edges,
                rng=rng,
                fraction=None if kept is None else kept[i],
                guide=None if edited is None or lvl == first else edit_guide(edited >= i, shape, edges),
            )
            new_rank += layer
            # §3.6.4: the next layer's mask, this layer shrunk where the exemplar's next layer
            # does not reach its boundary (the layer itself without shrink_masks)
            below = (
                next_layer_mask(layer, boundary, config=config, edges=edges, rng=rng) if above is not None else layer
            )
            if tick:
                tick()
        rank = new_rank
        if on_level:
            on_level(lvl, to_label[rank])
    return to_label[rank]
