"""Initial reference maps for texture-by-numbers (laitoch2018 §3.4).

Both functions work on one (the coarsest) pyramid level: ``exemplar_labels`` ``(h, w)`` and
``target_labels`` ``(H, W)`` are integer label codes; they return an ``(H, W)`` int32 image of
references (flat exemplar indices ``y * w + x``) whose labels agree with the target.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.canvas import Canvas
from barkgen.synth.guides.channels import boundary_distance, level_guide

#: eq. 3.6's label weight (laitoch2018: w = 90)
SMART_LABEL_WEIGHT = 90.0
#: neighbourhood radius of the region-growing metric (5x5)
SMART_RADIUS = 2
#: seeds may take any exemplar pixel within this distance of the best match (the least used)
SMART_TOLERANCE = 1.0
#: exemplar pixels searched per seed (a regular subsample of the coarsest exemplar level)
SMART_CANDIDATES = 256
#: boundary distances are capped at this many pixels (deep inside regions all look alike)
SMART_DISTANCE_CLIP = 16.0


def random_initialization(
    exemplar_labels: np.ndarray, target_labels: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """laitoch2018 §3.4.1: every output pixel references a random exemplar pixel of its label."""
    n_labels = int(max(exemplar_labels.max(), target_labels.max())) + 1
    guide = level_guide(exemplar_labels, target_labels, n_labels)
    lab = guide.target_labels
    start = guide.pool_start[lab]
    count = guide.pool_start[lab + 1] - start
    pick = (rng.random(lab.shape) * count).astype(np.int64)
    return np.ascontiguousarray(guide.pool[start + np.minimum(pick, count - 1)], dtype=np.int32)


def smart_initialization(
    exemplar_labels: np.ndarray,
    target_labels: np.ndarray,
    rng: np.random.Generator,
    canvas: Canvas | None = None,
    *,
    label_weight: float = SMART_LABEL_WEIGHT,
) -> np.ndarray:
    """Texture-synthesis-based initialisation (laitoch2018 §3.4.2; the first pass of Bonneel et
    al. 2010 as Fan et al. 2012 use it).

    Label boundaries of both maps are found, their chamfer distance transforms ``DA``, ``DB``
    computed, and the output is covered by seeded flood fills: each region copies one coherent
    piece of the exemplar whose labels and boundary distances match (eq. 3.6, stop rule
    ``d < (d(pA, pB) + 5) * 1.25``). Seeds are visited in a random order drawn from ``rng``;
    among near-equal matches the least used exemplar pixel is taken, which spreads the copies
    over the whole exemplar (laitoch2018 §4.2). The distances run across the exemplar's edge
    where it wraps and across the output's where it tiles: the ``canvas``'s ``exemplar_wrap``
    (None: nowhere) and ``tile`` (its shape is not read: a level's target may be smaller);
    default: neither.
    """
    import barkgen.synth.guides._kernels as K

    tile = canvas is not None and canvas.tile
    exemplar_wrap = (canvas.exemplar_wrap if canvas is not None else None) or (False, False)
    ida = np.ascontiguousarray(exemplar_labels, dtype=np.int32)
    idb = np.ascontiguousarray(target_labels, dtype=np.int32)
    # (contiguous: a view of the torus when the exemplar wraps would be another kernel signature)
    da = np.ascontiguousarray(boundary_distance(ida, SMART_DISTANCE_CLIP, wrap=exemplar_wrap))
    db = boundary_distance(idb, SMART_DISTANCE_CLIP, wrap=tile)
    guide = level_guide(ida, idb, int(max(ida.max(), idb.max())) + 1)
    order = rng.permutation(idb.size).astype(np.int64)
    salt = np.uint64(rng.integers(0, 2**63))
    refs = np.full(idb.size, -1, np.int32)
    params = (SMART_RADIUS, float(label_weight), SMART_TOLERANCE, SMART_CANDIDATES)
    K.grow_regions((ida, da), (idb, db, bool(tile)), (guide.pool, guide.pool_start), order, params, salt, refs)
    return refs.reshape(idb.shape)
