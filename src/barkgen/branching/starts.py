"""Where growth starts new branches (sibbing2010 §4.3, §4.5): furcation points picked by the
fitted classifier, children started there with the non-causal model, and roots at the emptiest
place, on a branch when the structure has as many roots in the open as the source.

Functions of the grower (:mod:`barkgen.branching.grow`), its state their first argument."""

from __future__ import annotations

from typing import Any

import numpy as np

import barkgen.branching._grow_kernels as K
from barkgen.branching.growth_options import EPSILON


def furcate(g: Any, b: int) -> list[tuple[int, int]]:
    """Pick furcation points on a finished branch (§4.3): ``d`` is drawn around the sum of
    the classifier's (Platt-scaled) furcation probabilities along the branch, and the ``d``
    vertices with the highest margin are taken, each blocking its neighbourhood."""
    model, k = g.model, g.o.k
    branch = g.branches[b]
    p = branch.points
    n = len(p)
    if model.svm_w is None or n < 3 or len(model.furcations.branch_angle) == 0:
        return []
    block = max(k, int(np.ceil(2 * g.r_max / g.step)) + 1)
    allowed = np.ones(n, bool)
    allowed[:1] = False  # the branch's own ends: its furcation and its end point
    allowed[n - 1 :] = False
    if branch.joins is not None:
        allowed[n - block :] = False
    a, c = model.platt
    base, expected = K.furcation_margins(
        p, k, model.feat_mean, model.feat_scale, model.svm_w, model.svm_b, a, c, allowed
    )
    d = int(g.rng.poisson(expected))
    if d == 0:
        return []
    chosen = K.pick_furcations(base, allowed, d, block, model.feat_mean[-2:], model.feat_scale[-2:], model.svm_w[-2:])
    return [(b, int(v)) for v in chosen]


def child(g: Any, b: int, v: int) -> int | None:
    """Start a child branch at vertex ``v`` of branch ``b`` with the non-causal model."""
    model, k = g.model, g.o.k
    fur = model.furcations
    p = g.branches[b].points
    qual = K.child_qualities(p, v, k, fur.nb_angles, fur.nb_thickness)
    order = np.argsort(-qual, kind="stable")[: g.o.c]
    f = int(order[g._draw(qual[order])])
    a = p[max(v - 1, 0), :2]
    c = p[min(v + 1, len(p) - 1), :2]
    tangent = np.arctan2(c[1] - a[1], c[0] - a[0])
    heading = float(tangent + fur.branch_angle[f])
    first = fur.child_first[f]
    n = min(int(fur.child_len[f]), g.o.m)
    elements = (
        np.stack([model.angles[first : first + n], model.thickness[first : first + n]], axis=1)
        if first >= 0 and n
        else np.zeros((0, 2))
    )
    # first edge: the branching angle itself, then the child's own elements
    lead = np.array([[0.0, float(fur.child_thickness[f])]])
    start = np.array([p[v, 0], p[v, 1], float(fur.child_thickness[f])])
    return g.grow_branch(start, heading, np.concatenate([lead, elements]), b, v)


def root(g: Any) -> int | None:
    """A new root at the emptiest of some random points, weighted by the guide (§4.5). Beyond
    the paper: while the structure has as many roots that start in the open per grown
    length as the source, a new one starts instead where the line back through that point
    (against the root's heading) meets a branch, on that branch; so the networks close
    as the source's do, without more free ends than it has."""
    model = g.model
    n = 256
    xs = g.rng.uniform(0, g.w - 1, n)
    ys = g.rng.uniform(0, g.h - 1, n)
    d, _ = g.sample(g.density, xs, ys, np.float32(0))
    score = np.minimum(d.astype(np.float64), 1e4)
    if g.guide is not None:
        guide, _ = g.sample(g.guide, xs, ys, np.float32(1))
        score = (score + 1.0) * (1.0 - guide.astype(np.float64) + EPSILON)
    i = int(np.argmax(score))
    if d[i] < g.options.fill * g.rho:
        return None
    r = int(g.rng.integers(len(model.root_first)))
    first = model.root_first[r]
    end = model.element_end[first]
    n_el = min(end - first, g.o.k + 1)
    elements = np.stack([model.angles[first : first + n_el], model.thickness[first : first + n_el]], axis=1)
    lead = np.array([[0.0, float(model.root_thickness[r])]])
    heading = float(model.root_heading[r])
    start = np.array([xs[i], ys[i], float(model.root_thickness[r])])
    parent = vertex = None
    rate = model.free_starts_per_length
    if rate is not None and g.n_free_starts >= rate * g.length_so_far():
        found = _branch_behind(g, start, heading, float(d[i]))
        if found is not None:
            parent, vertex, start[:2] = found
    b = g.grow_branch(start, heading, np.concatenate([lead, elements]), parent, vertex)
    g.n_free_starts += b is not None and parent is None
    return b


def _branch_behind(g: Any, point: np.ndarray, heading: float, clearance: float):
    """``(branch, vertex, (x, y))`` of the first committed branch met going back from
    ``point`` against ``heading`` (within four times its ``clearance`` to the nearest
    branch, at most 256 px), or None."""
    reach = min(4.0 * clearance + g.radius, 256.0)
    t = np.arange(1.0, reach, 1.0)
    xs = point[0] - t * np.cos(heading)
    ys = point[1] - t * np.sin(heading)
    dist, inside = g.sample(g.dist, xs, ys, np.float32(1e6))
    met = np.flatnonzero(inside & (dist <= 0.5))
    if not len(met):
        return None
    x, y = xs[met[0]], ys[met[0]]
    nb, _ = g.sample(g.near_branch, np.array([x]), np.array([y]), np.int32(-1))
    nv, _ = g.sample(g.near_vertex, np.array([x]), np.array([y]), np.int32(-1))
    if nb[0] < 0 or nv[0] < 0:
        return None
    vx, vy, _ = g.branches[int(nb[0])].points[int(nv[0])]
    if g.wrap:  # the vertex's copy nearest to the point met
        vx += g.w * np.round((x - vx) / g.w)
        vy += g.h * np.round((y - vy) / g.h)
    return int(nb[0]), int(nv[0]), (vx, vy)
