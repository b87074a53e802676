"""Automatic extraction of a crack / fissure network from a photo (sibbing2010 §3, automated).

The paper draws the input structure by hand (§3): a polygonal skeleton per branch plus a
thickness per vertex. Here it is found automatically:

1. :func:`crack_mask` — cracks are thin structures darker than their surroundings. A
   multi-scale Hessian "dark valley" response on the CIELAB luminance (scale-normalised, so it
   is about half the depth of a crack of matching width, in L* units) is thresholded with
   hysteresis (low threshold: Otsu of the response, high: twice that, both with an absolute
   floor, so a flat or smooth image has no cracks). The candidate regions are then cut to the
   crack itself: pixels at least half as deep (black top-hat) as the deepest crack pixel near
   them, so the mask's width is the crack's full width at half depth whatever its contrast.
   With a label map, the mask is the label that is darkest in the photo.
2. :func:`extract_structure` — the mask is skeletonised, the skeleton traced into a graph of
   pixel paths between junctions and end points (numba), spurs and specks pruned, nearby
   junctions merged, paths smoothed; at every junction the two edges that continue each other
   most straightly are paired into one branch (so a crack running through a junction stays one
   branch and the side crack becomes its child). Branches are ordered longest first through
   each network: a branch starting on an earlier branch gets ``parent``/``parent_vertex``, a
   branch ending on another branch gets ``joins``/``join_vertex`` (a merge). Closed loops (the
   cells of dried mud) are cut in two so that they are a branch plus a merge.
3. :func:`overlay_structure` — a preview of the structure on the photo.
"""

from __future__ import annotations

import heapq

import numpy as np

from barkgen.branching.structure import Branch, Structure, resample_polyline
from barkgen.errors import InvalidInputError

#: Gaussian scales (px) of the dark-valley filter: cracks of half-width ~1..5 px respond best
SIGMAS = (1.0, 1.5, 2.0, 3.0, 4.0, 6.0)
#: absolute floors of the hysteresis thresholds (response units ~ half the crack depth in L*)
LOW_FLOOR = 1.0
HIGH_FLOOR = 2.5
#: the high threshold is this multiple of the low (Otsu) threshold
HIGH_FACTOR = 2.0
#: how much a second positive curvature (a dark blob, not a line) takes off the response
BLOB_DAMPING = 0.5
#: the background of a crack is the median luminance within BG_RADIUS * max(SIGMAS) px
BG_RADIUS = 4.0
#: before measuring depths the luminance is smoothed by DEPTH_BLUR times the median best scale
#: of the strong crack pixels, clipped to DEPTH_BLUR_RANGE (px)
DEPTH_BLUR = 0.3
DEPTH_BLUR_RANGE = (0.5, 1.5)
#: the depth of the crack next to a pixel is the deepest candidate pixel within this radius (px)
DEPTH_RADIUS = 4
#: a mask pixel is at least this fraction of the depth of the crack next to it
HALF_DEPTH = 0.5
#: a dangling edge (spur, lone piece) whose mean response is below WEAK * high is not a crack
WEAK = 0.6
#: gap closing: a free end is joined to a crack within max(GAP_MIN, GAP_FACTOR * half-width)
#: px ahead of it, at most GAP_ANGLE degrees off its direction
GAP_MIN = 9.0
GAP_FACTOR = 4.0
GAP_ANGLE = 40.0
#: holes of the mask no wider than 2 * SLIVER px are filled (specks inside a broad crack)
SLIVER = 2.5
#: smallest image side accepted
MIN_SIDE = 16
#: default resampling step h: round(median thickness), clipped to this range (px)
STEP_RANGE = (2.0, 8.0)


# --------------------------------------------------------------------------- input checks


def _check_image(image: np.ndarray, what: str = "image") -> np.ndarray:
    """An ``(H, W)`` / ``(H, W, C)`` uint8, uint16, float [0, 1] or boolean image as float32 RGB
    in [0, 1] (:func:`barkgen.labels.regions.check_image`, which words the errors)."""
    from barkgen._shared.checks import check_image

    img = np.asarray(image)
    if img.dtype == np.bool_:
        img = img.astype(np.float32)
    return check_image(img, min_side=MIN_SIDE, what=what, purpose="crack extraction needs")


def _luminance(image: np.ndarray) -> np.ndarray:
    """CIELAB L* (0..100) of an image, float32 ``(H, W)``."""
    from barkgen.color import rgb_to_lab

    return np.ascontiguousarray(rgb_to_lab(_check_image(image))[..., 0])


def _label_ids(labels: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Integer id per pixel of an ``(H, W)`` or ``(H, W, C)`` label map (each value/colour one label)."""
    lab = np.asarray(labels)
    if lab.ndim == 3 and lab.shape[2] == 1:
        lab = lab[:, :, 0]
    if lab.ndim not in (2, 3) or lab.shape[:2] != tuple(shape):
        raise InvalidInputError(f"label map must be {shape[1]}x{shape[0]} px like the image, "
                                f"not shape {lab.shape}")
    if lab.ndim == 2:
        _, ids = np.unique(lab.ravel(), return_inverse=True)
    else:
        flat = np.ascontiguousarray(lab.reshape(-1, lab.shape[2]))
        _, ids = np.unique(flat, axis=0, return_inverse=True)
    return ids.reshape(shape).astype(np.int32)


# --------------------------------------------------------------------------- crack mask


def _valley_response(lum: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Multi-scale dark-valley response: ``max_s s^2 * (l1 - max(l2, 0) / 2)^+`` of the Hessian
    eigenvalues ``l1 >= l2`` of the luminance smoothed at scale ``s`` (large across a dark line,
    small along it; dark blobs, where both are large, are damped), and the index in
    :data:`SIGMAS` of the best scale per pixel (about the half-width of the crack there)."""
    import cv2

    from barkgen.branching._kernels import valley_update

    kxy = np.array([[1, 0, -1], [0, 0, 0], [-1, 0, 1]], np.float32) / 4.0
    out = np.zeros_like(lum)
    scale = np.zeros(lum.shape, np.uint8)
    for si, s in enumerate(SIGMAS):
        g = cv2.GaussianBlur(lum, (0, 0), s, borderType=cv2.BORDER_REFLECT)
        gxx = cv2.Sobel(g, cv2.CV_32F, 2, 0, ksize=1, borderType=cv2.BORDER_REFLECT)
        gyy = cv2.Sobel(g, cv2.CV_32F, 0, 2, ksize=1, borderType=cv2.BORDER_REFLECT)
        gxy = cv2.filter2D(g, cv2.CV_32F, kxy, borderType=cv2.BORDER_REFLECT)
        valley_update(gxx, gyy, gxy, s * s, BLOB_DAMPING, si, out, scale)
    return out, scale


def _otsu(values: np.ndarray, bins: int = 256) -> float:
    lo, hi = float(values.min()), float(values.max())
    if hi - lo < 1e-6:
        return hi
    hist, edges = np.histogram(values, bins=bins, range=(lo, hi))
    hist = hist.astype(np.float64)
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(hist)
    w1 = w0[-1] - w0
    m0 = np.cumsum(hist * centres)
    mu0 = m0 / np.maximum(w0, 1)
    mu1 = (m0[-1] - m0) / np.maximum(w1, 1)
    between = w0 * w1 * (mu0 - mu1) ** 2
    return float(centres[int(np.argmax(between[:-1]))])


def _hysteresis(resp: np.ndarray, low: float, high: float) -> np.ndarray:
    import cv2

    weak = (resp > low).astype(np.uint8)
    n, lab = cv2.connectedComponents(weak, connectivity=8)
    keep = np.zeros(n, bool)
    keep[np.unique(lab[resp > high])] = True
    keep[0] = False
    return keep[lab]


def _disk(radius: int) -> np.ndarray:
    import cv2

    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


def _remove_small(mask: np.ndarray, min_area: int) -> np.ndarray:
    import cv2

    n, lab, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= min_area
    keep[0] = False
    return keep[lab]


def _fill_slivers(mask: np.ndarray, max_inradius: float) -> np.ndarray:
    """Fill the holes of the mask that are thin slivers (no point farther than
    ``max_inradius`` px from the mask): bright specks inside a broad crack, not the cells
    between cracks."""
    import cv2

    holes = (~mask).astype(np.uint8)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(holes, connectivity=4)
    dist = cv2.distanceTransform(holes, cv2.DIST_L2, 3)
    inr = np.zeros(n, np.float32)
    np.maximum.at(inr, lab.ravel(), dist.ravel())
    h, w = mask.shape
    x0, y0 = stats[:, cv2.CC_STAT_LEFT], stats[:, cv2.CC_STAT_TOP]
    x1, y1 = x0 + stats[:, cv2.CC_STAT_WIDTH], y0 + stats[:, cv2.CC_STAT_HEIGHT]
    fill = (inr <= max_inradius) & (x0 > 0) & (y0 > 0) & (x1 < w) & (y1 < h)  # enclosed
    fill[0] = False  # label 0: the mask itself
    return mask | fill[lab]


def _auto_mask(lum: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(mask, valley response, high threshold) of a luminance image."""
    import cv2

    resp, best = _valley_response(lum)
    t = _otsu(resp[resp > 0]) if (resp > 0).any() else 0.0
    low = max(t, LOW_FLOOR)
    high = max(HIGH_FACTOR * t, HIGH_FLOOR)
    cand = _hysteresis(resp, low, high)
    if not cand.any():
        return cand, resp, high
    # cut the candidates to the crack: at least half as deep as the crack next to them
    k = 2 * int(np.ceil(BG_RADIUS * max(SIGMAS))) + 1
    lum8 = np.clip(lum * 2.55 + 0.5, 0, 255).astype(np.uint8)
    background = cv2.medianBlur(lum8, k).astype(np.float32) / 2.55
    # the typical crack scale: broad fissures in textured bark want smoother edges
    sigma = float(np.median(np.asarray(SIGMAS)[best[resp > high]]))
    blur = float(np.clip(DEPTH_BLUR * sigma, *DEPTH_BLUR_RANGE))
    depth = background - cv2.GaussianBlur(lum, (0, 0), blur)  # smooth, not ragged, edges
    local = cv2.dilate(np.where(cand, depth, 0).astype(np.float32), _disk(int(DEPTH_RADIUS)))
    near = cv2.dilate(cand.astype(np.uint8), _disk(2)).astype(bool)
    mask = near & (depth >= HALF_DEPTH * local) & (depth > 0)
    mask = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_CLOSE, _disk(1)).astype(bool)
    mask = _fill_slivers(mask, SLIVER)
    mask = _remove_small(mask, 12)
    return mask, resp, high


def _label_mask(lum: np.ndarray, labels: np.ndarray) -> np.ndarray:
    ids = _label_ids(labels, lum.shape)
    n = int(ids.max()) + 1
    if n < 2:
        raise InvalidInputError("label map: no cracks found (it has a single label; the cracks "
                                "must be a label of their own)")
    count = np.bincount(ids.ravel(), minlength=n)
    total = np.bincount(ids.ravel(), weights=lum.ravel().astype(np.float64), minlength=n)
    mean = total / np.maximum(count, 1)
    return ids == int(np.argmin(mean))


def crack_mask(image: np.ndarray, labels: np.ndarray | None = None) -> np.ndarray:
    """Boolean ``(H, W)`` mask of the cracks (dark thin structures) of ``image``.

    ``image`` is ``(H, W)`` or ``(H, W, C)``, uint8, uint16 or float in [0, 1]. Without
    ``labels`` the cracks are found automatically (see the module docs); with an ``(H, W)`` or
    ``(H, W, 3)`` label map (each distinct value or colour one label) the mask is the label
    whose pixels are darkest in the photo on average.
    """
    lum = _luminance(image)
    if labels is not None:
        return _label_mask(lum, labels)
    return _auto_mask(lum)[0]


# --------------------------------------------------------------------------- skeleton graph


def _arc_length(xy: np.ndarray) -> float:
    from barkgen.branching._kernels import arc_length

    return float(arc_length(xy))


class _Graph:
    """Nodes (junctions, end points) and edges (pixel paths with a thickness per point)."""

    def __init__(self) -> None:
        self.pos: list[np.ndarray] = []      # node position (x, y)
        self.rad: list[float] = []           # crack half-width at the node
        self.pseudo: list[bool] = []         # a cut point of a loop: never merged nor paired
        self.inc: list[list[tuple[int, int]]] = []  # (edge, end) incident to the node
        self.ea: list[int] = []
        self.eb: list[int] = []
        self.xy: list[np.ndarray | None] = []
        self.r: list[np.ndarray | None] = []
        self.s: list[float] = []             # mean valley response along the edge
        self.len: list[float] = []           # arc length
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
        self.len.append(_arc_length(xy))
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
        if end == 0:
            return self.xy[e], self.r[e]
        return self.xy[e][::-1], self.r[e][::-1]

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


def _build_graph(skel: np.ndarray, dist: np.ndarray, resp: np.ndarray | None) -> _Graph:
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

    g = _Graph()
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
        xy[0], xy[1:m + 1], xy[m + 1] = g.pos[a], inner, g.pos[b]
        r = np.empty(m + 2)
        if m:
            r[1:m + 1] = r_in
            r[0], r[m + 1] = r_in[0], r_in[-1]
        else:
            r[0], r[1] = g.rad[a], g.rad[b]
        g.add_edge(a, b, xy, r, s)
    return g


def _split_edge(g: _Graph, e: int, k: int) -> int:
    """Cut edge ``e`` at its inner point ``k`` by a new node; returns the node."""
    xy, r, s, a, b = g.xy[e], g.r[e], g.s[e], g.ea[e], g.eb[e]
    g.remove_edge(e)
    m = g.add_node(xy[k], r[k])
    g.add_edge(a, m, xy[:k + 1].copy(), r[:k + 1].copy(), s)
    g.add_edge(m, b, xy[k:].copy(), r[k:].copy(), s)
    return m


def _bridge_gaps(g: _Graph, strength: float) -> None:
    """Close small gaps: a free end that points at another crack close ahead is joined to it."""
    from scipy.spatial import cKDTree

    edges = g.edges()
    tips = [n for n in range(len(g.pos)) if g.degree(n) == 1]
    if not edges or not tips:
        return
    pts_a = np.concatenate([g.xy[e] for e in edges])
    owner_a = np.concatenate([np.full(len(g.xy[e]), e) for e in edges])
    index_a = np.concatenate([np.arange(len(g.xy[e])) for e in edges])
    tip_edge = np.empty(len(tips), np.int64)
    p0 = np.empty((len(tips), 2))
    out_dir = np.empty((len(tips), 2))
    reach = np.empty(len(tips))
    r_tip = np.empty(len(tips))
    for t, n in enumerate(tips):
        (f, f_end), = g.inc[n]
        xy, r = g.oriented(f, f_end)
        tip_edge[t] = f
        p0[t] = g.pos[n]
        r_tip[t] = float(np.add.reduce(r[:8])) / min(len(r), 8)
        reach[t] = max(GAP_MIN, GAP_FACTOR * r_tip[t])
        out_dir[t] = -_direction(xy, max(4.0, 2.0 * r_tip[t] + 2.0))
    k = min(32, len(pts_a))
    dist, idx = cKDTree(pts_a).query(p0, k=k, distance_upper_bound=float(reach.max()))
    dist = dist.reshape(len(tips), k)
    idx = idx.reshape(len(tips), k)
    found = idx < len(pts_a)
    idx_c = np.where(found, idx, 0)
    v = pts_a[idx_c] - p0[:, None]
    cos = (v * out_dir[:, None]).sum(axis=2) / np.maximum(dist, 1e-9)
    ok = (found & (dist <= reach[:, None]) & (dist > 1e-6) & (owner_a[idx_c] != tip_edge[:, None])
          & (cos >= np.cos(np.radians(GAP_ANGLE))))
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
        elif kk == len(g.xy[f]) - 1:
            target = g.eb[f]
        else:
            target = _split_edge(g, f, kk)
            split[f] = (len(g.ea) - 2, len(g.ea) - 1, kk)
        q = g.pos[target]
        steps = max(2, int(np.ceil(np.hypot(*(q - p0[t])))) + 1)
        w = np.linspace(0.0, 1.0, steps)[:, None]
        g.add_edge(n, target, p0[t][None] * (1 - w) + q[None] * w,
                   np.full(steps, max(0.5, min(r_tip[t], g.rad[target]))), strength)


def _prune(g: _Graph, high: float | None, *, isolated: bool = True) -> None:
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
                rmed = float(g.r[e].mean())
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


def _contract(g: _Graph, e: int) -> None:
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
            g.xy[f][0] = new
        else:
            g.eb[f] = a
            g.xy[f][-1] = new
        g.inc[a].append((f, end))
    g.inc[b] = []
    for f, end in g.inc[a]:
        if end == 0:
            g.xy[f][0] = new
        else:
            g.xy[f][-1] = new
        g.len[f] = _arc_length(g.xy[f])


def _smooth(xy: np.ndarray, r: np.ndarray, sigma_xy: float = 1.5,
            sigma_r: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian smoothing along a pixel path; the end points stay where they are."""
    from barkgen.branching._kernels import smooth_path

    return smooth_path(np.ascontiguousarray(xy, np.float64), np.ascontiguousarray(r, np.float64),
                       sigma_xy, sigma_r)


def _fix_junction_thickness(g: _Graph) -> None:
    """Near a junction the distance transform sees the junction's blob: use the value beyond."""
    from barkgen.branching._kernels import flatten_ends

    for e in g.edges():
        a, b = g.ea[e], g.eb[e]
        reach0 = g.rad[a] + 1.0 if g.degree(a) >= 3 else 0.0
        reach1 = g.rad[b] + 1.0 if g.degree(b) >= 3 else 0.0
        if reach0 > 0 or reach1 > 0:
            g.r[e] = flatten_ends(g.xy[e], g.r[e], reach0, reach1)


def _split_loops(g: _Graph) -> None:
    """Cut every loop edge (both ends on one node) in two at its middle (a pseudo node)."""
    for e in g.edges():
        if g.ea[e] != g.eb[e]:
            continue
        xy, r, s, a = g.xy[e], g.r[e], g.s[e], g.ea[e]
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
        m = int(np.clip(np.searchsorted(arc, arc[-1] / 2), 1, len(xy) - 2))
        g.remove_edge(e)
        mid = g.add_node(xy[m], r[m], pseudo=True)
        g.add_edge(a, mid, xy[:m + 1].copy(), r[:m + 1].copy(), s)
        g.add_edge(mid, a, xy[m:].copy(), r[m:].copy(), s)


# --------------------------------------------------------------------------- chains (branches)


class _Chain:
    def __init__(self, nodes: list[int], xy: np.ndarray, r: np.ndarray) -> None:
        self.nodes = nodes
        self.xy = xy
        self.r = r
        self.length = float(np.hypot(*np.diff(xy, axis=0).T).sum())


def _direction(xy: np.ndarray, reach: float) -> np.ndarray:
    """Unit vector from the first point of a path to its point ``reach`` px along it."""
    from barkgen.branching._kernels import path_direction

    # path steps are at least 1 px: the points beyond reach are not needed
    head = xy[:int(reach) + 2]
    return path_direction(np.ascontiguousarray(head, dtype=np.float64), float(reach))


def _find(parent: list[int], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def _chains(g: _Graph) -> list[_Chain]:
    """Pair the edges at every junction that continue each other most straightly; the chains of
    paired edges are the branches."""
    edges = g.edges()
    ufl = list(range(len(g.ea)))  # union-find over edges: pairing never closes a loop
    link: dict[tuple[int, int], tuple[int, int]] = {}
    for n in range(len(g.pos)):
        inc = g.inc[n]
        if g.pseudo[n] or len(inc) < 3:
            continue
        reach = max(4.0, 2.0 * g.rad[n] + 2.0)
        dirs = [_direction(g.oriented(e, end)[0], reach) for e, end in inc]
        pairs = []
        for i in range(len(inc)):
            for j in range(i + 1, len(inc)):
                pairs.append((float(-np.dot(dirs[i], dirs[j])), i, j))
        pairs.sort(reverse=True)
        used = set()
        for score, i, j in pairs:
            if score < np.cos(np.radians(70.0)) or i in used or j in used:
                continue
            ei, ej = inc[i][0], inc[j][0]
            ri, rj = _find(ufl, ei), _find(ufl, ej)
            if ri == rj:
                continue
            ufl[ri] = rj
            used.update((i, j))
            link[inc[i]] = inc[j]
            link[inc[j]] = inc[i]
    done = set()
    chains = []
    for e0 in edges:
        if e0 in done:
            continue
        # walk back to the chain's first edge
        e, back_end = e0, 0
        seen = {e0}
        while (e, back_end) in link:
            f, fend = link[(e, back_end)]
            if f in seen:
                break
            seen.add(f)
            e, back_end = f, 1 - fend
        start_end = back_end  # the chain leaves edge e through its other end
        nodes = [g.ea[e] if start_end == 0 else g.eb[e]]
        xys, rs = [], []
        while True:
            done.add(e)
            xy, r = g.oriented(e, start_end)
            xys.append(xy if not xys else xy[1:])
            rs.append(r if not rs else r[1:])
            exit_end = 1 - start_end
            nodes.append(g.eb[e] if exit_end == 1 else g.ea[e])
            nxt = link.get((e, exit_end))
            if nxt is None or nxt[0] in done:
                break
            e, start_end = nxt
        chains.append(_Chain(nodes, np.concatenate(xys), np.concatenate(rs)))
    return chains


def _nearest_vertex(points: np.ndarray, xy: np.ndarray) -> int:
    return int(np.argmin(np.hypot(points[:, 0] - xy[0], points[:, 1] - xy[1])))


def _hierarchy(g: _Graph, chains: list[_Chain], step: float) -> list[Branch]:
    """Order the chains longest first through each network and link them (parent, joins)."""
    at: dict[int, list[int]] = {}
    for ci, c in enumerate(chains):
        for n in set(c.nodes):
            at.setdefault(n, []).append(ci)

    def free(n: int) -> bool:
        return g.degree(n) <= 1

    placed: dict[int, int] = {}  # chain -> branch index
    order: list[tuple[int, bool]] = []  # (chain, reversed)
    parents: list[tuple[int, int] | None] = []  # (parent chain, node)
    heap: list[tuple[float, int]] = []

    def touching(ci: int, n: int) -> list[int]:
        return [c for c in at.get(n, ()) if c != ci and c in placed]

    def place(ci: int, rev: bool, parent) -> None:
        placed[ci] = len(order)
        order.append((ci, rev))
        parents.append(parent)
        for n in set(chains[ci].nodes):
            for cj in at.get(n, ()):
                if cj not in placed and n in (chains[cj].nodes[0], chains[cj].nodes[-1]):
                    heapq.heappush(heap, (-chains[cj].length, cj))

    def best(ci: int, n: int) -> int:
        cands = touching(ci, n)
        through = [c for c in cands if n in chains[c].nodes[1:-1]]
        return min(through or cands, key=lambda c: placed[c])

    remaining = sorted(range(len(chains)), key=lambda c: -chains[c].length)
    next_root = 0
    while len(placed) < len(chains):
        while heap:
            _, ci = heapq.heappop(heap)
            if ci in placed:
                continue
            c = chains[ci]
            s_t, e_t = touching(ci, c.nodes[0]), touching(ci, c.nodes[-1])
            if s_t and e_t:
                ps, pe = best(ci, c.nodes[0]), best(ci, c.nodes[-1])
                rev = placed[pe] < placed[ps]
            else:
                rev = not s_t
            n = c.nodes[-1] if rev else c.nodes[0]
            place(ci, rev, (best(ci, n), n))
        while next_root < len(remaining) and remaining[next_root] in placed:
            next_root += 1
        if next_root == len(remaining):
            break
        ci = remaining[next_root]
        c = chains[ci]
        # a root starts at a free end if it has one, so that its junction end can be a merge
        rev = (not free(c.nodes[0])) and free(c.nodes[-1])
        place(ci, rev, None)

    branches: list[Branch] = []
    pts_of: list[np.ndarray] = []
    for ci, rev in order:
        c = chains[ci]
        xy, r = (c.xy[::-1], c.r[::-1]) if rev else (c.xy, c.r)
        pts = resample_polyline(np.column_stack([xy, r]), step)
        pts_of.append(pts)
        branches.append(Branch(pts))
    for bi, (ci, rev) in enumerate(order):
        c = chains[ci]
        if parents[bi] is not None:
            pc, n = parents[bi]
            pb = placed[pc]
            branches[bi].parent = pb
            branches[bi].parent_vertex = _nearest_vertex(pts_of[pb], g.pos[n])
        end = c.nodes[0] if rev else c.nodes[-1]
        if free(end):
            continue
        others = [cj for cj in at.get(end, ()) if cj != ci]
        if not others:
            continue
        earlier = [cj for cj in others if placed[cj] < bi]
        through = [cj for cj in (earlier or others) if end in chains[cj].nodes[1:-1]]
        tj = min(through or earlier or others, key=lambda cj: placed[cj])
        jb = placed[tj]
        branches[bi].joins = jb
        branches[bi].join_vertex = _nearest_vertex(pts_of[jb], g.pos[end])
    return branches


def default_step(thickness: np.ndarray) -> float:
    """The resampling step h of a structure whose vertices have these thicknesses (px)."""
    med = float(np.median(thickness)) if len(thickness) else 1.0
    return float(np.clip(max(2.0, round(med)), *STEP_RANGE))


def extract_structure(image: np.ndarray, labels: np.ndarray | None = None, *,
                      step: float | None = None) -> Structure:
    """The crack / fissure network of ``image`` as a :class:`Structure` (sibbing2010 §3).

    ``labels`` (optional) is a label map whose darkest label in the photo is the cracks (see
    :func:`crack_mask`). ``step`` is the resampling step h in pixels (default: the median crack
    half-width, rounded, clipped to 2..8 px). Raises :class:`InvalidInputError` when no cracks
    are found.
    """
    import cv2
    from skimage.morphology import skeletonize

    if step is not None and (isinstance(step, bool) or not isinstance(step, (int, float, np.number))
                             or not np.isfinite(step) or not 0.25 <= float(step) <= 64):
        raise InvalidInputError(f"step must be a number of pixels in [0.25, 64], got {step!r}")
    lum = _luminance(image)
    h, w = lum.shape
    if labels is not None:
        mask, resp, high = _label_mask(lum, labels), None, None
        what = "label map"
    else:
        mask, resp, high = _auto_mask(lum)
        what = "image"
    if not mask.any():
        raise InvalidInputError(f"{what}: no cracks found (nothing darker than its surroundings "
                                "in thin lines)")
    skel = skeletonize(mask)
    dist = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    g = _build_graph(skel, dist, resp)
    _bridge_gaps(g, high if high is not None else 0.0)
    _prune(g, high)
    _fix_junction_thickness(g)
    for e in g.edges():
        g.xy[e], g.r[e] = _smooth(g.xy[e], g.r[e])
        g.len[e] = _arc_length(g.xy[e])
    _split_loops(g)
    chains = _chains(g)
    if not chains:
        raise InvalidInputError(f"{what}: no cracks found (only specks)")
    if step is None:
        rr = np.concatenate([c.r for c in chains])
        step = default_step(rr)
    step = float(step)
    chains = [c for c in chains if c.length >= step]
    if not chains:
        raise InvalidInputError(f"{what}: no cracks found (every crack is shorter than {step:g} px)")
    branches = _hierarchy(g, chains, step)
    structure = Structure(step, (w, h), branches)
    structure.validate("extracted structure")
    return structure


# --------------------------------------------------------------------------- preview


def _palette(n: int) -> np.ndarray:
    import cv2

    hues = (np.arange(n) * 0.618033988749895 % 1.0 * 180).astype(np.uint8)
    hsv = np.stack([hues, np.full(n, 230, np.uint8), np.full(n, 255, np.uint8)], axis=1)[None]
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[0]


def overlay_structure(image: np.ndarray, structure: Structure) -> np.ndarray:
    """``uint8 (H, W, 3)`` RGB preview: the image, dimmed, with each branch's skeleton in its own
    colour over a faint band of its thickness; furcations (a branch starts on another) are
    white dots, merges (a branch ends on another) black dots ringed in white."""
    import cv2

    rgb = _check_image(image)
    base = (rgb * 0.7 * 255).astype(np.uint8)
    h, w = base.shape[:2]
    cols = _palette(len(structure.branches))
    band = np.zeros_like(base)
    line = max(1, int(round(min(h, w) / 512)))
    for i, b in enumerate(structure.branches):
        col = tuple(int(v) for v in cols[i])
        p = b.points
        for j in range(len(p) - 1):
            rad = max(0.5 * (p[j, 2] + p[j + 1, 2]), 0.5)
            a = (int(round(p[j, 0] * 16)), int(round(p[j, 1] * 16)))
            c = (int(round(p[j + 1, 0] * 16)), int(round(p[j + 1, 1] * 16)))
            cv2.line(band, a, c, col, max(1, int(round(2 * rad))), cv2.LINE_AA, 4)
    out = cv2.addWeighted(base, 1.0, band, 0.25, 0)
    for i, b in enumerate(structure.branches):
        col = tuple(int(v) for v in cols[i])
        pts = np.round(b.xy * 16).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(out, [pts], False, col, line, cv2.LINE_AA, 4)
    dot = line + 1
    for b in structure.branches:
        if b.parent is not None:
            x, y = structure.branches[b.parent].xy[b.parent_vertex]
            cv2.circle(out, (int(round(x)), int(round(y))), dot, (255, 255, 255), -1, cv2.LINE_AA)
        if b.joins is not None:
            x, y = structure.branches[b.joins].xy[b.join_vertex]
            cv2.circle(out, (int(round(x)), int(round(y))), dot + 1, (255, 255, 255), -1, cv2.LINE_AA)
            cv2.circle(out, (int(round(x)), int(round(y))), dot, (0, 0, 0), -1, cv2.LINE_AA)
    return out
