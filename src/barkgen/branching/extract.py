"""Automatic extraction of a crack / fissure network from a photo (sibbing2010 §3, automated).

The paper draws the input structure by hand (§3): a polygonal skeleton per branch plus a
thickness per vertex. Here it is found automatically:

1. :func:`~barkgen.branching.mask.crack_mask` (:mod:`barkgen.branching.mask`) — the cracks,
   thin structures darker than their surroundings, from a multi-scale dark-valley response
   thresholded with hysteresis and cut to the crack's width at half depth; or, with a label
   map, the label that is darkest in the photo.
2. :func:`~barkgen.branching.graph.skeleton_graph` (:mod:`barkgen.branching.graph`) — the mask
   is skeletonised and the skeleton traced into a graph of pixel paths between junctions and
   end points (numba), gaps bridged, spurs and specks pruned, nearby junctions merged, paths
   smoothed, closed loops (the cells of dried mud) cut in two so that they are a branch plus a
   merge.
3. :func:`extract_structure` — at every junction the two edges that continue each other most
   straightly are paired into one branch (so a crack running through a junction stays one
   branch and the side crack becomes its child). Branches are ordered longest first through
   each network: a branch starting on an earlier branch gets ``parent``/``parent_vertex``, a
   branch ending on another branch gets ``joins``/``join_vertex`` (a merge).
4. :func:`overlay_structure` — a preview of the structure on the photo.
"""

from __future__ import annotations

import heapq

import numpy as np

from barkgen.branching.graph import SkeletonGraph, direction, skeleton_graph
from barkgen.branching.mask import auto_mask, check_crack_image, crack_mask, label_mask, luminance
from barkgen.branching.structure import Branch, Structure, resample_polyline
from barkgen.errors import InvalidInputError

__all__ = ["crack_mask", "default_step", "extract_structure", "overlay_structure"]

#: default resampling step h: round(median thickness), clipped to this range (px)
STEP_RANGE = (2.0, 8.0)


# --------------------------------------------------------------------------- chains (branches)


class _Chain:
    def __init__(self, nodes: list[int], xy: np.ndarray, r: np.ndarray) -> None:
        self.nodes = nodes
        self.xy = xy
        self.r = r
        self.length = float(np.hypot(*np.diff(xy, axis=0).T).sum())


def _find(parent: list[int], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def _chains(g: SkeletonGraph) -> list[_Chain]:
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
        dirs = [direction(g.oriented(e, end)[0], reach) for e, end in inc]
        pairs = []
        for i in range(len(inc)):
            for j in range(i + 1, len(inc)):
                pairs.append((float(-np.dot(dirs[i], dirs[j])), i, j))
        pairs.sort(reverse=True)
        used: set[int] = set()
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
        xys: list[np.ndarray] = []
        rs: list[np.ndarray] = []
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


def _hierarchy(g: SkeletonGraph, chains: list[_Chain], step: float) -> list[Branch]:
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
        parent_link = parents[bi]
        if parent_link is not None:
            pc, n = parent_link
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


def extract_structure(image: np.ndarray, labels: np.ndarray | None = None, *, step: float | None = None) -> Structure:
    """The crack / fissure network of ``image`` as a :class:`Structure` (sibbing2010 §3).

    ``labels`` (optional) is a label map whose darkest label in the photo is the cracks (see
    :func:`crack_mask`). ``step`` is the resampling step h in pixels (default: the median crack
    half-width, rounded, clipped to 2..8 px). Raises :class:`InvalidInputError` when no cracks
    are found.
    """
    if step is not None and (
        isinstance(step, bool)
        or not isinstance(step, (int, float, np.number))
        or not np.isfinite(step)
        or not 0.25 <= float(step) <= 64
    ):
        raise InvalidInputError(f"step must be a number of pixels in [0.25, 64], got {step!r}")
    lum = luminance(image)
    h, w = lum.shape
    if labels is not None:
        mask, resp, high = label_mask(lum, labels), None, None
        what = "label map"
    else:
        mask, resp, high = auto_mask(lum)
        what = "image"
    if not mask.any():
        raise InvalidInputError(f"{what}: no cracks found (nothing darker than its surroundings in thin lines)")
    g = skeleton_graph(mask, resp, high)
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

    rgb = check_crack_image(image)
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
