"""The crack mask's skeleton as a graph (sibbing2010 §3, automated): nodes (junctions, end
points) and edges (pixel paths with a thickness per point).

:func:`skeleton_graph` skeletonises the mask, traces the skeleton into pixel paths between
junctions and end points (numba, :func:`barkgen.branching._kernels.trace_edges`), closes small
gaps (a free end pointing at a crack close ahead is joined to it), prunes spurs and specks,
merges nearby junctions, flattens the thickness next to junctions, smooths the paths and cuts
closed loops in two (a branch plus a merge, the cells of dried mud).
"""

from __future__ import annotations

import numpy as np

#: a dangling edge (spur, lone piece) whose mean response is below WEAK * high is not a crack
WEAK = 0.6
#: gap closing: a free end is joined to a crack within max(GAP_MIN, GAP_FACTOR * half-width)
#: px ahead of it, at most GAP_ANGLE degrees off its direction
GAP_MIN = 9.0
GAP_FACTOR = 4.0
GAP_ANGLE = 40.0


def path_length(xy: np.ndarray) -> float:
    """Arc length of a pixel path."""
    from barkgen.branching._kernels import arc_length

    return float(arc_length(xy))


class SkeletonGraph:
    """Nodes (junctions, end points) and edges (pixel paths with a thickness per point)."""

    def __init__(self) -> None:
        self.pos: list[np.ndarray] = []  # node position (x, y)
        self.rad: list[float] = []  # crack half-width at the node
        self.pseudo: list[bool] = []  # a cut point of a loop: never merged nor paired
        self.inc: list[list[tuple[int, int]]] = []  # (edge, end) incident to the node
        self.ea: list[int] = []
        self.eb: list[int] = []
        self.xy: list[np.ndarray | None] = []
        self.r: list[np.ndarray | None] = []
        self.s: list[float] = []  # mean valley response along the edge
        self.len: list[float] = []  # arc length
        self.alive: list[bool] = []

    def add_node(self, pos, rad: float, pseudo: bool = False) -> int:
        self.pos.append(np.asarray(pos, np.float64))
        self.rad.append(float(rad))
        self.pseudo.append(pseudo)
        self.inc.append([])
        return len(self.pos) - 1

    def add_edge(self, a: int, b: int, xy: np.ndarray, r: np.ndarray, s: float) -> int:
        e = len(self.ea)
        self.ea.append(a)
        self.eb.append(b)
        self.xy.append(xy)
        self.r.append(r)
        self.s.append(s)
        self.len.append(path_length(xy))
        self.alive.append(True)
        self.inc[a].append((e, 0))
        self.inc[b].append((e, 1))
        return e

    def remove_edge(self, e: int) -> None:
        self.alive[e] = False
        for n in {self.ea[e], self.eb[e]}:
            self.inc[n] = [t for t in self.inc[n] if t[0] != e]
        self.xy[e] = self.r[e] = None

    def degree(self, n: int) -> int:
        return len(self.inc[n])

    def length(self, e: int) -> float:
        return self.len[e]

    def oriented(self, e: int, end: int) -> tuple[np.ndarray, np.ndarray]:
        """The edge's points and thickness running away from its end ``end``."""
        xy, r = self.points(e), self.thickness(e)
        if end == 0:
            return xy, r
        return xy[::-1], r[::-1]

    def points(self, e: int) -> np.ndarray:
        """The pixel path of edge ``e`` (alive: a removed edge has none)."""
        xy = self.xy[e]
        assert xy is not None, f"edge {e} was removed"
        return xy

    def thickness(self, e: int) -> np.ndarray:
        """The crack half-width at every point of edge ``e`` (alive: a removed edge has none)."""
        r = self.r[e]
        assert r is not None, f"edge {e} was removed"
        return r

    def edges(self) -> list[int]:
        return [e for e, ok in enumerate(self.alive) if ok]

    def merge_through(self, n: int) -> bool:
        """Join the two edges of a degree-2 node into one; False if it is a lone loop."""
        (e1, end1), (e2, end2) = self.inc[n]
        if e1 == e2:
            return False
        xy1, r1 = self.oriented(e1, end1)
        xy2, r2 = self.oriented(e2, end2)
        xy1, r1 = xy1[::-1], r1[::-1]  # now ends at n
        a = self.eb[e1] if end1 == 0 else self.ea[e1]
        b = self.eb[e2] if end2 == 0 else self.ea[e2]
        l1, l2 = self.length(e1), self.length(e2)
        s = (self.s[e1] * l1 + self.s[e2] * l2) / max(l1 + l2, 1e-9)
        self.remove_edge(e1)
        self.remove_edge(e2)
        self.add_edge(a, b, np.concatenate([xy1, xy2[1:]]), np.concatenate([r1, r2[1:]]), s)
        return True


def _build_graph(skel: np.ndarray, dist: np.ndarray, resp: np.ndarray | None) -> SkeletonGraph:
    import cv2

    from barkgen.branching._kernels import skeleton_degree, trace_edges

    sk = skel.astype(np.uint8)
    deg = skeleton_degree(sk)
    node_mask = (sk > 0) & (deg != 2)
    n_nodes, node_lab = cv2.connectedComponents(node_mask.astype(np.uint8), connectivity=8)
    node_id = (node_lab - 1).astype(np.int64)
    node_id[~node_mask] = -1
    py, px = np.nonzero(node_mask)
    ea, eb, off, pyy, pxx = trace_edges(sk, node_id, py.astype(np.int64), px.astype(np.int64))

    g = SkeletonGraph()
    radius = np.maximum(dist - 0.5, 0.5)
    ids = node_id[py, px]
    cnt = np.bincount(ids, minlength=n_nodes - 1).astype(np.float64)
    cx = np.bincount(ids, px, minlength=n_nodes - 1) / np.maximum(cnt, 1)
    cy = np.bincount(ids, py, minlength=n_nodes - 1) / np.maximum(cnt, 1)
    nrad = np.zeros(n_nodes - 1)
    np.maximum.at(nrad, ids, radius[py, px])
    for i in range(n_nodes - 1):
        g.add_node((cx[i], cy[i]), nrad[i])
    rpath = radius[pyy, pxx]
    spath = resp[pyy, pxx] if resp is not None else np.zeros(len(pyy))
    path_xy = np.stack([pxx, pyy], axis=1).astype(np.float64)
    rpath = rpath.astype(np.float64)
    ssum = np.concatenate([[0.0], np.cumsum(spath, dtype=np.float64)])
    for e in range(len(ea)):
        a, b = int(ea[e]), int(eb[e])
        o0, o1 = int(off[e]), int(off[e + 1])
        inner = path_xy[o0:o1]
        r_in = rpath[o0:o1]
        s = float((ssum[o1] - ssum[o0]) / (o1 - o0)) if o1 > o0 else 0.0
        if a < 0:  # closed loop without a node: cut it at its first pixel
            if len(inner) < 8:
                continue
            n0 = g.add_node(inner[0], r_in[0], pseudo=True)
            xy = np.concatenate([inner, inner[:1]])
            g.add_edge(n0, n0, xy, np.concatenate([r_in, r_in[:1]]), s)
            continue
        if b < 0:  # a walk that stopped without reaching a node (should not happen)
            b = g.add_node(inner[-1], r_in[-1])
            inner, r_in = inner[:-1], r_in[:-1]
        m = len(inner)
        xy = np.empty((m + 2, 2))
        xy[0], xy[1 : m + 1], xy[m + 1] = g.pos[a], inner, g.pos[b]
        r = np.empty(m + 2)
        if m:
            r[1 : m + 1] = r_in
            r[0], r[m + 1] = r_in[0], r_in[-1]
        else:
            r[0], r[1] = g.rad[a], g.rad[b]
        g.add_edge(a, b, xy, r, s)
    return g


def direction(xy: np.ndarray, reach: float) -> np.ndarray:
    """Unit vector from the first point of a path to its point ``reach`` px along it."""
    from barkgen.branching._kernels import path_direction

    # path steps are at least 1 px: the points beyond reach are not needed
    head = xy[: int(reach) + 2]
    return path_direction(np.ascontiguousarray(head, dtype=np.float64), float(reach))


def _split_edge(g: SkeletonGraph, e: int, k: int) -> int:
    """Cut edge ``e`` at its inner point ``k`` by a new node; returns the node."""
    xy, r, s, a, b = g.points(e), g.thickness(e), g.s[e], g.ea[e], g.eb[e]
    g.remove_edge(e)
    m = g.add_node(xy[k], r[k])
    g.add_edge(a, m, xy[: k + 1].copy(), r[: k + 1].copy(), s)
    g.add_edge(m, b, xy[k:].copy(), r[k:].copy(), s)
    return m


def _bridge_gaps(g: SkeletonGraph, strength: float) -> None:
    """Close small gaps: a free end that points at another crack close ahead is joined to it."""
    from scipy.spatial import cKDTree

    edges = g.edges()
    tips = [n for n in range(len(g.pos)) if g.degree(n) == 1]
    if not edges or not tips:
        return
    pts_a = np.concatenate([g.points(e) for e in edges])
    owner_a = np.concatenate([np.full(len(g.points(e)), e) for e in edges])
    index_a = np.concatenate([np.arange(len(g.points(e))) for e in edges])
    tip_edge = np.empty(len(tips), np.int64)
    p0 = np.empty((len(tips), 2))
    out_dir = np.empty((len(tips), 2))
    reach = np.empty(len(tips))
    r_tip = np.empty(len(tips))
    for t, n in enumerate(tips):
        ((f, f_end),) = g.inc[n]
        xy, r = g.oriented(f, f_end)
        tip_edge[t] = f
        p0[t] = g.pos[n]
        r_tip[t] = float(np.add.reduce(r[:8])) / min(len(r), 8)
        reach[t] = max(GAP_MIN, GAP_FACTOR * r_tip[t])
        out_dir[t] = -direction(xy, max(4.0, 2.0 * r_tip[t] + 2.0))
    k = min(32, len(pts_a))
    dist, idx = cKDTree(pts_a).query(p0, k=k, distance_upper_bound=float(reach.max()))
    dist = dist.reshape(len(tips), k)
    idx = idx.reshape(len(tips), k)
    found = idx < len(pts_a)
    idx_c = np.where(found, idx, 0)
    v = pts_a[idx_c] - p0[:, None]
    cos = (v * out_dir[:, None]).sum(axis=2) / np.maximum(dist, 1e-9)
    ok = (
        found
        & (dist <= reach[:, None])
        & (dist > 1e-6)
        & (owner_a[idx_c] != tip_edge[:, None])
        & (cos >= np.cos(np.radians(GAP_ANGLE)))
    )
    score = np.where(ok, dist * (2.0 - cos), np.inf)
    choice = np.argmin(score, axis=1)
    # an edge split by an earlier bridge: (first part, second part, split index)
    split: dict[int, tuple[int, int, int]] = {}
    for t, n in enumerate(tips):
        c = choice[t]
        if not np.isfinite(score[t, c]) or g.degree(n) != 1:
            continue
        f, kk = int(owner_a[idx[t, c]]), int(index_a[idx[t, c]])
        while f in split:  # follow earlier cuts of the target edge
            f1, f2, ks = split[f]
            f, kk = (f1, kk) if kk <= ks else (f2, kk - ks)
        if not g.alive[f] or n in (g.ea[f], g.eb[f]):
            continue
        if kk == 0:
            target = g.ea[f]
        elif kk == len(g.points(f)) - 1:
            target = g.eb[f]
        else:
            target = _split_edge(g, f, kk)
            split[f] = (len(g.ea) - 2, len(g.ea) - 1, kk)
        q = g.pos[target]
        steps = max(2, int(np.ceil(np.hypot(*(q - p0[t])))) + 1)
        w = np.linspace(0.0, 1.0, steps)[:, None]
        g.add_edge(
            n,
            target,
            p0[t][None] * (1 - w) + q[None] * w,
            np.full(steps, max(0.5, min(r_tip[t], g.rad[target]))),
            strength,
        )


def _prune(g: SkeletonGraph, high: float | None, *, isolated: bool = True) -> None:
    """Remove short spurs, specks and tiny loops; merge degree-2 nodes; contract junction pairs.

    With ``high``, dangling edges (spurs, lone pieces) weaker than ``WEAK * high`` go too;
    ``isolated=False`` keeps lone pieces and loops."""
    changed = True
    while changed:
        changed = False
        for e in g.edges():
            if not g.alive[e]:
                continue
            a, b = g.ea[e], g.eb[e]
            length = g.length(e)
            if a == b:
                if isolated and length < max(12.0, 6.0 * g.rad[a]):
                    g.remove_edge(e)
                    changed = True
                continue
            da, db = g.degree(a), g.degree(b)
            if da == 1 and db == 1:
                if not isolated:
                    continue
                rmed = float(g.thickness(e).mean())
                if length < max(10.0, 6.0 * rmed) or (high is not None and g.s[e] < WEAK * high):
                    g.remove_edge(e)
                    changed = True
            elif da == 1 or db == 1:
                j = b if da == 1 else a
                if length < 2.0 * g.rad[j] + 2.0 or (high is not None and g.s[e] < WEAK * high):
                    g.remove_edge(e)
                    changed = True
        for n in range(len(g.pos)):
            if g.degree(n) == 2 and not g.pseudo[n]:
                if g.merge_through(n):
                    changed = True
        # junctions a pixel or two apart (a crossing split in two) become one
        for e in g.edges():
            if not g.alive[e]:
                continue
            a, b = g.ea[e], g.eb[e]
            if a == b or g.pseudo[a] or g.pseudo[b] or g.degree(a) < 3 or g.degree(b) < 3:
                continue
            if g.length(e) <= max(g.rad[a], g.rad[b]) + 1.5:
                _contract(g, e)
                changed = True


def _contract(g: SkeletonGraph, e: int) -> None:
    a, b = g.ea[e], g.eb[e]
    g.remove_edge(e)
    new = 0.5 * (g.pos[a] + g.pos[b])
    g.pos[a] = new
    g.rad[a] = max(g.rad[a], g.rad[b])
    for f, end in list(g.inc[b]):
        if f == e:
            continue
        if end == 0:
            g.ea[f] = a
            g.points(f)[0] = new
        else:
            g.eb[f] = a
            g.points(f)[-1] = new
        g.inc[a].append((f, end))
    g.inc[b] = []
    for f, end in g.inc[a]:
        if end == 0:
            g.points(f)[0] = new
        else:
            g.points(f)[-1] = new
        g.len[f] = path_length(g.points(f))


def _smooth_edge(
    xy: np.ndarray, r: np.ndarray, sigma_xy: float = 1.5, sigma_r: float = 3.0
) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian smoothing along a pixel path; the end points stay where they are."""
    from barkgen.branching._kernels import smooth_path

    return smooth_path(np.ascontiguousarray(xy, np.float64), np.ascontiguousarray(r, np.float64), sigma_xy, sigma_r)


def _fix_junction_thickness(g: SkeletonGraph) -> None:
    """Near a junction the distance transform sees the junction's blob: use the value beyond."""
    from barkgen.branching._kernels import flatten_ends

    for e in g.edges():
        a, b = g.ea[e], g.eb[e]
        reach0 = g.rad[a] + 1.0 if g.degree(a) >= 3 else 0.0
        reach1 = g.rad[b] + 1.0 if g.degree(b) >= 3 else 0.0
        if reach0 > 0 or reach1 > 0:
            g.r[e] = flatten_ends(g.points(e), g.thickness(e), reach0, reach1)


def _split_loops(g: SkeletonGraph) -> None:
    """Cut every loop edge (both ends on one node) in two at its middle (a pseudo node)."""
    for e in g.edges():
        if g.ea[e] != g.eb[e]:
            continue
        xy, r, s, a = g.points(e), g.thickness(e), g.s[e], g.ea[e]
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
        m = int(np.clip(np.searchsorted(arc, arc[-1] / 2), 1, len(xy) - 2))
        g.remove_edge(e)
        mid = g.add_node(xy[m], r[m], pseudo=True)
        g.add_edge(a, mid, xy[: m + 1].copy(), r[: m + 1].copy(), s)
        g.add_edge(mid, a, xy[m:].copy(), r[m:].copy(), s)


def skeleton_graph(mask: np.ndarray, resp: np.ndarray | None, high: float | None) -> SkeletonGraph:
    """The graph of the crack mask's skeleton, cleaned (see the module docs).

    ``resp`` is the valley response of :func:`barkgen.branching.mask.auto_mask` (the strength
    of every edge) and ``high`` its high threshold: with them, gaps are bridged at that
    strength and dangling edges weaker than ``WEAK * high`` are pruned; without (a label
    map's mask), only the geometric tests prune."""
    import cv2
    from skimage.morphology import skeletonize

    skel = skeletonize(mask)
    dist = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    g = _build_graph(skel, dist, resp)
    _bridge_gaps(g, high if high is not None else 0.0)
    _prune(g, high)
    _fix_junction_thickness(g)
    for e in g.edges():
        g.xy[e], g.r[e] = _smooth_edge(g.points(e), g.thickness(e))
        g.len[e] = path_length(g.points(e))
    _split_loops(g)
    return g
