"""Graph-cut seam optimisation of a reference map (Kwatra et al. 2003, "Graphcut textures", §3).

The discrete solver (mazzolini2012 §4.1) lets two copied pieces meet wherever its votes switch
from one to the other; when both pieces are long and run in step, they meet along a straight
line, which the eye finds at once. Each such straight stretch of seam is re-cut here: inside a
band around it, every pixel that belongs to one of the two pieces may take either piece (each
continued across the seam), and a minimum cut (PyMaxflow) chooses the border of least seam cost
``||A(p) - B(p)|| + ||A(q) - B(q)||`` over neighbouring pixels ``p``, ``q`` on either side
(Kwatra eq. 1), so the border follows the texture's own low-error paths. The pixels around the
band keep their references and enter as fixed neighbours, so the cut joins the seams there.

A minimum cut of even costs is the shortest path, and that is the straight line: where the two
pieces match equally well everywhere (a flat stretch of bark), the first cut leaves the seam
where it was. A seam still straight over ``MEANDER_MIN_RUN`` pixels after that is re-cut with a
small pull towards a meander (a sinusoid of random period and phase, ``MEANDER_AMPLITUDE`` rows
either side), weak enough that the texture's own low-error paths still win where they exist.

Arrays in, arrays out: reference maps as exemplar ``(row, col)`` coordinates.
"""

from __future__ import annotations

import cv2
import numpy as np

from barkgen._shared.canvas import Canvas

#: straight seam runs at least this long are re-cut
MIN_RUN = 24
#: half-width of the band (pixels on each side of the seam) a cut may move the border in
BAND = 16
#: straight seams still at least this long after a first cut are cut again along a meander
MEANDER_MIN_RUN = 32
#: rows either side of the seam the meander of a second cut swings
MEANDER_AMPLITUDE = 6.0
#: shortest period of the meander, in pixels along the seam (the longest is twice this)
MEANDER_PERIOD = 40.0
#: pull towards the meander, per pixel on its wrong side, in units of the band's median pair
#: weight (the cost of a unit of seam)
MEANDER_WEIGHT = 0.5
#: cost of a forbidden choice (a piece that cannot continue, a wrong label)
_HARD = 1e9
#: PyMaxflow grid structures: an edge to the pixel below, to the pixel on the right
_BELOW = np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0]])
_RIGHT = np.array([[0, 0, 0], [0, 0, 1], [0, 0, 0]])


class _Frame:
    """What the seams are cut in: one exemplar level's features ``(h, w, C)`` and the output's
    ``canvas`` (whether it tiles, the exemplar's wrap), in the frame of the seams being cut (the
    transposed frame for seams between columns)."""

    def __init__(self, features: np.ndarray, canvas: Canvas) -> None:
        self.features = np.ascontiguousarray(features, dtype=np.float32)
        self.shape = self.features.shape[:2]
        self.canvas = canvas
        wrap = canvas.exemplar_wrap or (False, False)
        self.wrap = (bool(wrap[0]), bool(wrap[1]))
        self.tile = canvas.tile

    def transposed(self) -> _Frame:
        turned = self.canvas.replace(shape=self.canvas.shape[::-1], exemplar_wrap=(self.wrap[1], self.wrap[0]))
        return _Frame(self.features.transpose(1, 0, 2), turned)


def _meander_cost(
    cost: np.ndarray, member: np.ndarray, w_down: np.ndarray, w_right: np.ndarray, rng: np.random.Generator
) -> None:
    """Add, in place, the pull of a random meander to the unary ``cost`` ``(2, 2 * BAND, L)``
    of one seam's band: a pixel above the meander pays for taking the lower piece (choice 1),
    one below it for the upper piece."""
    pair = np.concatenate([w_down[member], w_right[member]])
    pair = pair[pair > 0]
    if pair.size == 0:
        return
    weight = MEANDER_WEIGHT * float(np.median(pair))
    period = MEANDER_PERIOD * (1.0 + rng.random())
    phase = 2 * np.pi * rng.random()
    line = MEANDER_AMPLITUDE * np.sin(2 * np.pi * np.arange(cost.shape[2]) / period + phase)
    offset = np.arange(cost.shape[1])[:, None] - (BAND - 0.5)  # the seam lies at 0
    cost[1] += np.where(offset < line[None, :], weight, 0.0)
    cost[0] += np.where(offset > line[None, :], weight, 0.0)


def _cut_run(
    ry: np.ndarray,
    rx: np.ndarray,
    i: int,
    cols: np.ndarray,
    ex: _Frame,
    allowed=None,
    meander: np.random.Generator | None = None,
) -> int:
    """Re-cut the straight seam between output rows ``i`` and ``i + 1`` along ``cols``, in place:
    each column's pixel of row ``i`` continued up and down is its choice A, that of row ``i + 1``
    its choice B (several pieces may stand along the seam); the graph is built by
    ``_kernels.seam_band``. ``allowed(ys, xs, ey, ex)`` says which references each output pixel
    may take (labels); with a generator ``meander``, the cut is pulled towards a random meander
    (:func:`_meander_cost`). Returns the pixels changed."""
    import maxflow

    import barkgen.synth.seams._kernels as K

    H, W = ry.shape
    shape = (2 * BAND, cols.size)
    cand_y = np.empty((2,) + shape, np.int64)
    cand_x = np.empty((2,) + shape, np.int64)
    valid = np.empty((2,) + shape, np.bool_)
    member = np.empty(shape, np.bool_)
    cost = np.empty((2,) + shape)
    w_down = np.empty(shape)
    w_right = np.empty(shape)
    if (
        K.seam_band(
            (ry, rx, ex.tile),
            ex.features,
            ex.wrap[0],
            ex.wrap[1],
            i,
            np.ascontiguousarray(cols, dtype=np.int64),
            BAND,
            (cand_y, cand_x, valid, member, cost, w_down, w_right),
        )
        < 2
    ):
        return 0
    rows = np.mod(i - BAND + 1 + np.arange(2 * BAND), H)
    ys, xs = np.broadcast_arrays(rows[:, None], cols[None, :])
    if allowed is not None:  # a pixel that has its wanted label keeps one
        ok = np.stack([allowed(ys, xs, cand_y[t], cand_x[t]) for t in (0, 1)])
        k = np.arange(2 * BAND)[:, None]
        own_ok = np.where(k < BAND, ok[0], ok[1])
        cost += np.where(ok | ~own_ok[None], 0.0, _HARD)
    if meander is not None:
        _meander_cost(cost, member, w_down, w_right, meander)
    low = np.minimum(cost[0], cost[1])
    g = maxflow.Graph[float]()
    nodes = g.add_grid_nodes(shape)
    g.add_grid_edges(nodes, weights=w_down, structure=_BELOW, symmetric=False)
    g.add_grid_edges(nodes, weights=w_right, structure=_RIGHT, symmetric=False)
    # source side = choice A: a node there pays its edge to the sink, which carries A's cost
    g.add_grid_tedges(nodes, np.where(member, cost[1] - low, 0.0), np.where(member, cost[0] - low, 0.0))
    g.maxflow()
    take_b = g.get_grid_segments(nodes)[member]
    new_y = np.where(take_b, cand_y[1][member], cand_y[0][member])
    new_x = np.where(take_b, cand_x[1][member], cand_x[0][member])
    py, px = ys[member], xs[member]
    changed = int(((ry[py, px] != new_y) | (rx[py, px] != new_x)).sum())
    ry[py, px] = new_y
    rx[py, px] = new_x
    return changed


def _cut_rows(ry, rx, ex: _Frame, min_run: int, allowed, meander: np.random.Generator | None) -> int:
    """Re-cut every straight seam between rows at least ``min_run`` long; returns pixels changed."""
    import barkgen.synth.seams._kernels as K

    W = ry.shape[1]
    runs = K.seam_runs((ry, rx, ex.tile), (ex.shape[0], ex.shape[1], ex.wrap[0], ex.wrap[1]), min_run)
    changed = 0
    for i, start, length in runs:
        cols = np.arange(start, start + length)
        cols = np.mod(cols, W) if ex.tile else cols
        changed += _cut_run(ry, rx, int(i), cols, ex, allowed, meander if length >= MEANDER_MIN_RUN else None)
    return changed


def cut_straight_seams(
    references: np.ndarray,
    features: np.ndarray,
    canvas: Canvas,
    *,
    min_run: int = MIN_RUN,
    rounds: int = 2,
    allowed=None,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    r"""Re-cut the straight seams of a reference map along minimum-cost paths (Kwatra 2003).

    Args:
        references: ``(H, W, 2)`` exemplar ``(row, col)`` per output pixel.
        features: ``(h, w, C)`` float32 features of the exemplar the seam cost compares.
        canvas: the output's: whether it ``tile``\ s (its last row meets its first) and the
            exemplar's ``exemplar_wrap``, ``(rows, columns)``, the axes it tiles along (None:
            neither).
        min_run: straight seams at least this long are re-cut.
        rounds: passes over both directions; from the second on, with ``rng``, the seams still
            straight are pulled towards random meanders.
        allowed: optional ``allowed(ys, xs, ey, ex) -> bool array``: which exemplar pixels the
            output pixels may take (texture-by-numbers keeps its labels).
        rng: draws the meanders; without it every pass is a plain minimum cut.

    Returns:
        The new ``(H, W, 2)`` reference map (int32); pixels only ever take the reference of a
        piece that borders them, continued.
    """
    refs = np.asarray(references)
    ry: np.ndarray = np.ascontiguousarray(refs[..., 0], dtype=np.int32)
    rx: np.ndarray = np.ascontiguousarray(refs[..., 1], dtype=np.int32)
    ex = _Frame(features, canvas)
    ext = ex.transposed()
    allowed_t = None if allowed is None else (lambda ys, xs, ey, exx: allowed(xs, ys, exx, ey))
    for rnd in range(rounds):
        meander = rng if rnd > 0 else None
        changed = _cut_rows(ry, rx, ex, min_run, allowed, meander)
        # seams between columns: the same on the transposed maps (cv2's blocked transpose)
        ry_t, rx_t = cv2.transpose(rx), cv2.transpose(ry)
        changed += _cut_rows(ry_t, rx_t, ext, min_run, allowed_t, meander)
        ry, rx = cv2.transpose(rx_t), cv2.transpose(ry_t)
        if changed == 0 and (rnd > 0 or rng is None):
            break
    return np.stack([ry, rx], axis=-1)
