"""Seams moved by expansion moves: each copied piece may grow over its neighbours' borders
wherever that lowers the seam cost (Kwatra et al. 2003, §3, minimised as Boykov, Veksler &
Zabih 2001's α-expansion).

The solver's local seam moves (``_kernels.refine_seams``) change one pixel at a time, so a
border can only slide where every single step pays; a border a few pixels off the bark's
low-error path, or a corner left by the coarse levels' up-sampling blocks, stays where it is.
An expansion move asks, for one piece ``α`` (the pixels sharing one offset, reference minus
position), which of the pixels within ``band`` of its border should take ``α`` continued to
them; a minimum cut (PyMaxflow) answers exactly for all of them at once, so whole stretches of
border move together onto the path of least seam cost ``||A(p) - B(p)|| + ||A(q) - B(q)||``
(Kwatra eq. 1). That cost is a metric on the two pieces, so each move is optimal and the total
seam cost never rises. Every piece of at least :data:`MIN_PIECE` pixels gets one move per round,
largest first, from the costlier stretches of its border (:data:`CHEAP_BORDER`). A move never
takes over a pixel whose reference the output has few copies of (:func:`rare_references`), so
no part of the exemplar drops out of the output, nor gives a pixel a forbidden offset or a wrong
label; a pair of pixels whose pieces both end at the exemplar's border between them costs extra
(``seams._kernels.STUCK_COST``), so a third piece takes such a seam over.

Arrays in, arrays out: reference maps of flat exemplar indices at one pyramid level.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.canvas import Canvas

#: pieces smaller than this (pixels) get no move of their own (their neighbours' moves may
#: still take them over)
MIN_PIECE = 64
#: the cheapest share of the border pixels (by their seam cost) that start no move
CHEAP_BORDER = 0.5
#: half-side of the exemplar square over which :func:`rare_references` counts the copies
RARE_RADIUS = 3
#: an exemplar square copied less than this share of the uniform expectation is rare
RARE_SHARE = 0.5
#: nodes a move's graph buffers hold at first; they double when a piece's move needs more (a
#: move's nodes lie within ``band`` of one piece, so the buffers follow the largest piece, not
#: the output: 72 bytes a node, 18 MB for 2^18)
FIRST_NODES = 1 << 18


#: rows of the output whose offset codes are made at once (:func:`piece_offsets`)
_BAND_ROWS = 256


class _MoveBuffers:
    """The graph buffers of one expansion move (:func:`~barkgen.synth.seams._kernels.expansion_nodes`,
    :func:`~barkgen.synth.seams._kernels.expansion_terms`): ``capacity`` nodes, twice as many
    directed edges."""

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        self.node_y, self.node_x, self.node_ref, self.touched = (np.empty(capacity, np.int32) for _ in range(4))
        self.unary = np.empty(capacity)
        self.edge_i, self.edge_j = np.empty(2 * capacity, np.int32), np.empty(2 * capacity, np.int32)
        self.edge_cap, self.partner = np.empty(2 * capacity), np.empty(2 * capacity)

    @property
    def nodes(self) -> tuple:
        return self.node_y, self.node_x, self.node_ref, self.touched

    @property
    def terms(self) -> tuple:
        return self.unary, self.edge_i, self.edge_j, self.edge_cap, self.partner


def _pieces(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(order, codes, start, count)``: the output's flat indices sorted by their offset code
    (stable), and each code's first position in that order and its number of pixels (what
    ``np.unique(codes[order], return_index=True, return_counts=True)`` gives, without its
    second sort and copies of an output-sized array)."""
    flat = codes.ravel()
    order = np.argsort(flat, kind="stable").astype(np.int32)
    in_order = flat[order]
    start = np.concatenate(([0], np.flatnonzero(in_order[1:] != in_order[:-1]) + 1))
    count = np.diff(np.append(start, flat.size))
    return order, in_order[start], start, count


def exemplar_grid(shape: tuple[int, int], wrap: tuple[bool, bool]) -> tuple:
    """The kernels' ``exemplar`` tuple (:attr:`barkgen.synth._analysis.LevelAnalysis.grid`) of an
    exemplar of ``shape`` ``(h, w)`` that tiles along ``wrap`` ``(rows, columns)``."""
    h, w = int(shape[0]), int(shape[1])
    flat = np.arange(h * w, dtype=np.int32)
    return flat // w, flat % w, h, w, bool(wrap[0]), bool(wrap[1])


def piece_offsets(refs: np.ndarray, grid: tuple) -> np.ndarray:
    """Offset code (``barkgen.synth._kernels.offset_code``) of each output pixel's reference, with the offset
    folded onto the exemplar's torus along the axes where it wraps, so a piece that runs across a
    wrapping exemplar's edge keeps one code. ``grid``: the kernels' ``exemplar`` tuple."""
    import barkgen.synth._kernels as K

    coords_y, coords_x, ex_h, ex_w, wrap_y, wrap_x = grid
    H, W = refs.shape
    bias = K.OFFSET_BIAS
    codes = np.empty((H, W), np.int64)
    columns = np.arange(W)[None, :]
    for top in range(0, H, _BAND_ROWS):  # by bands of rows: the temporaries a band's, not the output's
        band = refs[top : top + _BAND_ROWS]
        dy = coords_y[band].astype(np.int64) - np.arange(top, top + band.shape[0])[:, None]
        dx = coords_x[band].astype(np.int64) - columns
        if wrap_y:
            dy %= ex_h
        if wrap_x:
            dx %= ex_w
        codes[top : top + band.shape[0]] = (dy + bias) * (2 * bias) + (dx + bias)
    return codes


def rare_references(refs: np.ndarray, grid: tuple) -> np.ndarray:
    """Per flat exemplar index, whether the output copies the exemplar around it (a
    ``2 * RARE_RADIUS + 1`` square, on the torus where the exemplar wraps) less than
    :data:`RARE_SHARE` of the uniform share: a move that took such a pixel over would leave that
    part of the exemplar out of the output (texeval's completeness, Kaspar et al. 2015's
    occurrence)."""
    import cv2

    _, _, ex_h, ex_w, wrap_y, wrap_x = grid
    used = np.bincount(refs.ravel(), minlength=ex_h * ex_w).astype(np.float32).reshape(ex_h, ex_w)
    r = RARE_RADIUS
    padded = np.pad(used, ((r, r), (0, 0)), mode="wrap" if wrap_y else "reflect")
    padded = np.pad(padded, ((0, 0), (r, r)), mode="wrap" if wrap_x else "reflect")
    local = cv2.blur(padded, (2 * r + 1, 2 * r + 1), borderType=cv2.BORDER_REFLECT)[r:-r, r:-r]
    return np.ascontiguousarray((local < RARE_SHARE * refs.size / (ex_h * ex_w)).ravel())


def expand_pieces(
    refs: np.ndarray,
    grid: tuple,
    features: np.ndarray,
    canvas: Canvas,
    forbid: np.ndarray,
    labels: tuple[np.ndarray, np.ndarray],
    *,
    band: int,
    rounds: int,
) -> np.ndarray:
    """``refs`` ``(H, W)`` int32 with its seams moved by ``rounds`` rounds of expansion moves.

    Parameters
    ----------
    refs : ndarray of int32, shape (H, W)
        Flat exemplar indices; not modified.
    grid : tuple
        The exemplar level's grid as the kernels take it (:func:`exemplar_grid`,
        :attr:`barkgen.synth._analysis.LevelAnalysis.grid`).
    features : ndarray of float32, shape (h, w, C)
        What the seam cost compares (the exemplar's colour at this level).
    canvas : Canvas
        The output's: whether it tiles (wraps round).
    forbid : ndarray of int64, shape (H, W) or (1, 1)
        Each pixel's forbidden offset code (-1: none), which no move gives it (``(1, 1)``: the
        same for every pixel, ``[[-1]]`` none anywhere). A pixel whose
        reference the output has few copies of (:func:`rare_references`) keeps it.
    labels : (ndarray, ndarray)
        ``(exemplar labels per flat index, target labels (H, W))``; a move never gives a pixel
        of its wanted label a wrong one. One exemplar label entry means unguided.
    band : int
        How far (pixels, a square) from a piece's border its move may reach.
    rounds : int
        Moves of every piece, largest first.

    Returns
    -------
    ndarray of int32, shape (H, W)
        Every pixel keeps its reference or takes that of a piece within ``band``, continued.

    References
    ----------
    .. [1] kwatra2003, §3 (the seam cost).
    .. [2] boykov2001 (expansion moves).
    """
    import barkgen.synth.seams._kernels as XK

    tile = canvas.tile
    refs = np.ascontiguousarray(refs, dtype=np.int32).copy()
    if band <= 0 or rounds <= 0:
        return refs
    H, W = refs.shape
    feat = np.ascontiguousarray(features, dtype=np.float32)
    node_of = np.full((H, W), -1, np.int32)
    buffers = _MoveBuffers(min(FIRST_NODES, H * W))
    border_cost = np.empty((H, W))
    for _ in range(rounds):
        rare = rare_references(refs, grid)
        codes = piece_offsets(refs, grid)
        XK.border_costs((refs, tile), codes, feat, grid, border_cost)
        on_border = border_cost[border_cost > 0]
        if on_border.size == 0:
            break
        least = max(float(np.quantile(on_border, CHEAP_BORDER)), 1e-12)
        order, uniq, start, count = _pieces(codes)
        big = np.flatnonzero(count >= MIN_PIECE)
        big = big[np.lexsort((uniq[big], -count[big]))]  # largest first, ties by code
        moved = 0
        for k in big:
            alpha = uniq[k]
            members = order[start[k] : start[k] + count[k]]
            while True:
                n, n_touched = XK.expansion_nodes(
                    (refs, tile),
                    codes,
                    (alpha, members),
                    grid,
                    (forbid, rare, border_cost, least),
                    labels,
                    band,
                    node_of,
                    buffers.nodes,
                )
                if n >= 0:
                    break
                node_of.ravel()[buffers.touched[:n_touched]] = -1  # the move again, on larger buffers
                buffers = _MoveBuffers(min(2 * buffers.capacity, H * W))
            if n:
                moved += _move(refs, codes, alpha, (tile, node_of, n), feat, grid, buffers)
            node_of.ravel()[buffers.touched[:n_touched]] = -1
        if moved == 0:
            break
    return refs


def _move(refs: np.ndarray, codes: np.ndarray, alpha, move: tuple, feat: np.ndarray, grid: tuple, buffers) -> int:
    """One expansion move of the piece ``alpha`` over its ``n`` nodes (``move = (tile,
    node_of, n)``, in ``buffers``): its graph's minimum cut (PyMaxflow), the nodes on the sink
    side given the piece continued (``refs`` and ``codes`` updated). Returns how many."""
    import maxflow

    import barkgen.synth.seams._kernels as XK

    tile, node_of, n = move
    node_y, node_x, node_ref, _ = buffers.nodes
    unary, edge_i, edge_j, edge_cap, _ = buffers.terms
    m = XK.expansion_terms((refs, tile), node_of, (node_y, node_x, node_ref), n, feat, grid, buffers.terms)
    graph = maxflow.Graph[float](n, m)
    ids = graph.add_nodes(n)
    # a node on the sink side (choice 1) pays its source capacity
    graph.add_grid_tedges(ids, np.maximum(unary[:n], 0.0), np.maximum(-unary[:n], 0.0))
    if m:
        graph.add_edges(edge_i[:m], edge_j[:m], edge_cap[:m], np.zeros(m))
    graph.maxflow()
    take = np.flatnonzero(graph.get_grid_segments(ids))
    ty, tx = node_y[take], node_x[take]
    refs[ty, tx] = node_ref[take]
    codes[ty, tx] = alpha
    return int(take.size)
