"""Growing new branching structures from a learned model (sibbing2010 §4.2-4.5, + merges).

Growth follows the paper: a branch is extended ``m`` elements at a time by the continuation of
one of the ``c`` best-matching source histories (quality ``Q``, histogram-matched ``Q*``,
density-scaled ``Q** = Q* / (D + eps)``; intersecting extensions get ``Q = 0``); when a branch
is complete, ``d`` furcation points are picked where the linear classifier scores highest and
the children are grown in breadth-first order; roots are added at the emptiest point until a
stopping rule holds (total length, levels, or no empty space left).

Beyond the paper: an extension that would cross an existing branch may instead *end on it*
(a merge), with the source's merge rate and incidence angles, and a branch whose source
continuation ended on another branch reaches forward to join the nearest one. That is how
dried mud and reticulate bark close their cells.
"""

from __future__ import annotations

from collections import deque

import numpy as np

import barkgen.branching._grow_kernels as K
import barkgen.branching.starts as starts
from barkgen.branching.growth_options import EPSILON, GrowOptions, check_grow_size
from barkgen.branching.model import BranchModel, _wrap
from barkgen.branching.structure import Branch, Structure, junction_radius
from barkgen.errors import InvalidInputError

TOP = 16  # candidates kept after the bending quality, before histogram and density terms


class _Tip:
    """The growing end of a branch: its vertices and its element history in buffers."""

    def __init__(self, capacity: int, start: np.ndarray, heading: float):
        self.xyr = np.empty((capacity + 2, 3))
        self.xyr[0] = start
        self.n = 1
        self.hist = np.empty((capacity + 2, 2))
        self.n_hist = 0
        self.theta = float(heading)

    def points(self) -> np.ndarray:
        return self.xyr[: self.n].copy()


class _Grower:
    def __init__(
        self,
        model: BranchModel,
        size: tuple[int, int],
        guide: np.ndarray | None,
        options: GrowOptions,
        rng: np.random.Generator,
        wrap: bool = False,
    ):
        self.model, self.rng, self.options = model, rng, options
        self.wrap = bool(wrap)  # the output is a torus: branches run on across its edges
        self.o = model.options
        self.w, self.h = size
        self.step = model.step
        self.rho = float(options.rho or model.rho)
        self.radius = min(3.0 * self.rho, 32.0)  # the 3 rho vicinity; D < 0.02 beyond 32 px
        self.reach = max(3 * self.rho, self.o.m * self.step, float(np.median(model.branch_length)))
        # contact maps (committed branch bodies, the growing branch's last vertices left out)
        # and the density map (distance to everything grown so far, §4.4)
        self.dist = np.full((self.h, self.w), 1e6, np.float32)
        self.density = np.full((self.h, self.w), 1e6, np.float32)
        self.near_branch = np.full((self.h, self.w), -1, np.int32)
        self.near_vertex = np.full((self.h, self.w), -1, np.int32)
        self.guide = guide
        self.branches: list[Branch] = []
        self.a_counts = np.zeros(self.o.bins)
        self.r_counts = np.zeros(self.o.bins)
        self.h_counts = np.zeros(self.o.bins)
        self.n_t = 0
        self.length = 0.0
        self.n_merges = 0
        self.n_roots = 0
        self.n_free_starts = 0
        self._forced = False  # growing on to meet a branch: every collision is a merge
        self.n_free_ends = 0
        self._tip_n = 0
        self.target = (
            options.total_length if options.total_length is not None else model.length_density * self.w * self.h
        )
        self.r_max = float(model.thickness.max()) if len(model.thickness) else 1.0
        # the last ``lag`` vertices of a growing branch stay out of its contact maps
        self.lag = int(np.ceil((2 * self.r_max + 2.0) / self.step)) + 1
        self.extra = int(np.ceil(2 * self.reach / self.step)) + 1  # vertices a branch grows on
        k = self.o.k
        self.hist_a = model.angles[model.history_start[:, None] + np.arange(k + 1)[None, :]]
        self.hist_r = model.thickness[model.history_start[:, None] + np.arange(k + 1)[None, :]]
        self.children_per_pixel = model.children_per_branch.sum() / max(model.meta["source_length"], 1e-9)
        self._quality = np.empty(len(self.hist_a))
        t, m = min(TOP, len(self.hist_a)), self.o.m
        self._elements = np.empty((t, m, 2))  # the candidates' continuations (angle, thickness)
        self._bufs = (
            np.empty(t, np.int64),
            np.empty(t),
            np.empty(t, np.int64),
            self._elements[:, :, 0],
            self._elements[:, :, 1],
            np.empty((t, m)),
            np.empty((t, m)),
            np.empty((t, m)),
            np.empty(t, np.int64),
            np.empty(t, np.int64),
            np.empty(t),
        )
        self._guide = guide if guide is not None else np.zeros((1, 1), np.float32)
        self._decision = np.zeros(3, np.int64)
        everything = np.arange(len(model.branch_length))
        self._roots = np.flatnonzero(model.branch_is_root)
        self._children = np.flatnonzero(~model.branch_is_root)
        self._roots = self._roots if len(self._roots) else everything
        self._children = self._children if len(self._children) else everything
        self.near_tangent = np.zeros((self.h, self.w), np.float32)
        self.join_pdf = None
        if len(model.join_angles):
            hist, _ = np.histogram(model.join_angles, bins=6, range=(0, np.pi / 2))
            self.join_pdf = hist / hist.max()
        self._join_pdf = self.join_pdf if self.join_pdf is not None else np.zeros(0)

    # -- the density map ------------------------------------------------------------------
    def commit(self, b: int, first: int, last: int | None = None) -> None:
        """Enter vertices ``first:last`` of branch ``b`` into the contact maps."""
        p = self.branches[b].points
        last = len(p) if last is None else min(last, len(p))
        if first < last:
            self._stamp(self.dist, p, first, last, b, True)

    def commit_density(self, points: np.ndarray, first: int) -> None:
        """Enter vertices ``first:`` into the density map."""
        if first < len(points):
            self._stamp(self.density, points, first, len(points), -1, False)

    def _stamp(self, arr: np.ndarray, points: np.ndarray, first: int, last: int, b: int, track: bool) -> None:
        nearest = (self.near_branch, self.near_vertex, self.near_tangent)
        K.commit_points(arr, *nearest, np.ascontiguousarray(points), first, last, b, self.radius, track, self.wrap)

    def sample(self, arr: np.ndarray, x: np.ndarray, y: np.ndarray, outside):
        x = np.ascontiguousarray(x, np.float64)
        y = np.ascontiguousarray(y, np.float64)
        out = np.empty(x.shape, arr.dtype)
        inside = np.empty(x.shape, np.bool_)
        K.sample_nearest(arr, x, y, outside, out, inside, self.wrap)
        return out, inside

    # -- one branch -----------------------------------------------------------------------
    def grow_branch(
        self,
        start: np.ndarray,
        heading: float,
        first_elements: np.ndarray,
        parent: int | None,
        parent_vertex: int | None,
    ) -> int | None:
        """Grow one branch from ``start`` (x, y, thickness); returns its index or None."""
        b = len(self.branches)
        branch = Branch(np.asarray([start], np.float64), parent, parent_vertex)
        self.branches.append(branch)
        # the branch's length and ending are those of a source branch of its kind (root or
        # child): the Markov chain alone under-represents short branches, which have few or no
        # complete histories
        same_kind = self._roots if parent is None else self._children
        pick = int(same_kind[self.rng.integers(len(same_kind))])
        wanted = float(self.model.branch_length[pick])
        wants_join = self._joins(self.model.branch_joined, self.model.branch_cut, pick)
        limit = min(int(4 * (self.w + self.h) / self.step), int(np.ceil(wanted / self.step)) + 1)
        tip = _Tip(limit + 2 * (self.o.m + self.extra) + 8, np.asarray(start, np.float64), heading)
        exempt = junction_radius(
            float(self.branches[parent].points[parent_vertex, 2]) if parent is not None else 0.0,
            float(start[2]),
            self.step,
        )
        done = [0, 0]  # vertices entered into the contact maps and into the density map
        # how the branch ends: "free" (its source branch ended, no candidate, its length),
        # "joins" (on another branch), "merge" (it ended on one), "border" (left the image)
        end = None
        # the initial segment: copied elements (a root's or the furcation's child start)
        if len(first_elements):
            ok, hit = self._append(tip, first_elements, start, exempt, b)
            if hit is not None:
                end = "hit"
                if self._accept_join(hit[1], hit[2], hit[3]):
                    self._snap(tip, hit[1], hit[2], branch)
                    end = "merge"
            elif not ok:
                end = "border"
        if end is None:
            end = self._extend(tip, branch, b, start, exempt, limit, done)
        if end is None:  # reached the length of its source branch
            end = "joins" if wants_join else "free"
        if end in ("joins", "free") and tip.n >= 2 and self._crowded():
            # beyond the paper: with more free ends per length than the source, the branch grows
            # on (up to twice the reach) and ends on the first branch it meets
            self._forced = True
            end = self._extend(tip, branch, b, start, exempt, tip.n + self.extra, done) or end
            self._forced = False
        # a branch that stops in the open reaches forward to end on a branch: always when its
        # source branch did, else while the structure has fewer merges than the source's rate
        if end in ("joins", "free") and tip.n >= 2:
            rate = self.merge_rate()
            # beyond the paper: also while the structure has more free ends per length than the
            # source (a grown branch ends in the open more often than the source's did)
            if self.rng.random() < (rate if end == "joins" else rate * (rate >= 1.0)) or self._crowded():
                self._reach(tip, start, exempt, b, branch)
        self._tip_n = 0
        branch.points = tip.points()
        length = K.polyline_length(branch.points)
        # a child that never left its parent's side (not a step longer than the junction radius
        # of its furcation, within which it may touch the parent) is not a branch: one that
        # turned back along its parent there drew over it just outside the radius
        hugs_parent = parent is not None and branch.joins is None and done[0] == 0 and length < exempt + self.step
        if tip.n < 2 or hugs_parent:
            self.n_merges -= branch.joins is not None
            self.branches.pop()
            return None
        self.commit(b, max(done[0], 0))
        self.commit_density(branch.points, done[1])
        self.n_free_ends += end != "border" and branch.joins is None
        self.length += length
        return b

    def _extend(self, tip: _Tip, branch: Branch, b: int, start, exempt: float, limit: int, done: list[int]):
        """Extend branch ``b`` by §4.2-4.4's steps until it ends or has ``limit`` vertices;
        ``done`` = [vertices in the contact maps, in the density map]. Returns how it ended
        (None: it reached the limit)."""
        end = None
        while end is None and tip.n < limit:
            self._tip_n = tip.n
            choice = self._choose(tip, start, exempt, b)
            if choice is None:
                end = "free"
            elif choice[0] == "end":
                end = "joins" if choice[1] else "free"
            elif choice[0] == "join":
                elements, xs, ys, heads, j = choice[1]
                self._push(tip, elements, xs, ys, heads, j)
                self._snap(tip, xs[j], ys[j], branch)
                end = "merge"
            else:
                elements, xs, ys, heads, n_in, ends, source_joined = choice[1]
                self._push(tip, elements, xs, ys, heads, n_in)
                if n_in < len(elements):
                    end = "border"
                elif ends:
                    end = "joins" if source_joined else "free"
                elif tip.n - self.lag > done[0]:
                    # the last ``lag`` vertices stay out of the contact maps (a thick branch's
                    # own body would hide the branches it is about to cross); the density map
                    # has them all
                    branch.points = tip.points()
                    self.commit(b, done[0], tip.n - self.lag)
                    self.commit_density(branch.points, done[1])
                    done[0] = tip.n - self.lag
                    done[1] = tip.n
        return end

    def _push(self, tip: _Tip, elements, xs, ys, heads, n: int) -> None:
        """Append the first ``n`` of the element rows with their vertices."""
        if n <= 0:
            return
        m = self.model
        K.push_elements(
            tip.xyr,
            tip.hist,
            tip.n,
            tip.n_hist,
            elements,
            (xs, ys, heads),
            n,
            (self.a_counts, m.angle_edges, self.r_counts, m.thickness_edges, self.h_counts),
        )
        tip.n += n
        tip.n_hist += n
        tip.theta = float(heads[n - 1])
        self.n_t += n

    def _path(self, x0, y0, theta, elements, start, exempt, b):
        """The vertices and headings of element rows (angle, thickness) appended to branch
        ``b`` from ``(x0, y0)`` at heading ``theta``, and its first contact with a committed
        branch and first vertex outside the image (-1: none; ``K.path_contacts``)."""
        return K.path_contacts(
            float(x0),
            float(y0),
            float(theta),
            self.step,
            np.ascontiguousarray(elements, np.float64),
            self._contact(b, start, exempt),
        )

    def _contact(self, b: int, start, exempt: float) -> tuple:
        """The contact maps and branch ``b``'s exemptions as the kernels take them (``contact``
        of :func:`~barkgen.branching._grow_kernels.extension_candidates`)."""
        parent = self.branches[b].parent
        return (
            self.dist,
            self.near_branch,
            b,
            -2 if parent is None else parent,
            float(start[0]),
            float(start[1]),
            float(exempt),
            self.wrap,
        )

    def _append(self, tip: _Tip, elements, start, exempt, b):
        """Append element rows (L, 2) outside the Markov step (a copied initial segment); stops
        at the image border and at a collision. Returns (keep growing, hit) where hit =
        (index, x, y, heading) of the collision."""
        xs, ys, headings, first_hit, first_out = self._path(
            tip.xyr[tip.n - 1, 0], tip.xyr[tip.n - 1, 1], tip.theta, elements, start, exempt, b
        )
        n = len(elements)
        hit = None
        if first_hit >= 0:
            n = first_hit
            hit = (n, xs[n], ys[n], headings[n])
        keep = hit is None
        if 0 <= first_out < n:
            n, hit, keep = first_out, None, False
        self._push(tip, elements, xs, ys, headings, n)
        return keep and n > 0, hit

    def _choose(self, tip: _Tip, start, exempt, b):
        """One extension step of §4.2-4.4 (the kernel scores and chooses). Returns None (no
        candidate), ("end", source_branch_joined), ("join", (elements, xs, ys, heads, j)): add
        the first ``j`` elements and end on the branch met at vertex ``j``, or ("grow",
        (elements, xs, ys, heads, n_in, ends, source_joined)): add the first ``n_in`` (the rest
        left the image); ``ends`` when the source branch ended within the continuation."""
        model, o = self.model, self.o
        bufs = self._bufs
        q = min(tip.n_hist, o.k + 1)
        hist = tip.hist[tip.n_hist - q : tip.n_hist]
        x0, y0 = float(tip.xyr[tip.n - 1, 0]), float(tip.xyr[tip.n - 1, 1])
        K.extension_candidates(
            (self.hist_a, self.hist_r, model.history_start, model.branch_end, model.angles, model.thickness),
            (np.ascontiguousarray(hist[:, 0]), np.ascontiguousarray(hist[:, 1])),  # one signature, whatever its length
            o.k,
            o.m,
            (
                model.angle_edges,
                model.thickness_edges,
                self.a_counts,
                self.r_counts,
                model.angle_hist,
                model.thickness_hist,
                self.h_counts,
                model.heading_hist,
                float(self.n_t),
                float(o.omega_g),
            ),
            (x0, y0, tip.theta, self.step),
            self._contact(b, start, exempt),
            (self.density, self._guide, self.guide is not None, self.rho, EPSILON, self.wrap),
            (
                o.c,
                self.rng.random(3),
                self.merge_rate(),
                np.zeros(0) if self._forced else self._join_pdf,
                self.near_tangent,
                self.wrap,
            ),
            self._quality,
            bufs,
            self._decision,
        )
        code, t, j = self._decision
        cand, _, lens = bufs[:3]
        xs, ys, heads = bufs[5:8]
        if code == 0:
            return None
        if code == 3:
            return "join", (self._elements[t, :j], xs[t], ys[t], heads[t], int(j))
        if code == 2:
            return "end", self._joins(model.end_joins, model.end_cut, int(cand[t]))
        # a continuation cut short by the end of its source branch ends the branch too
        ends = bool(lens[t] < o.m)
        return "grow", (
            self._elements[t, : lens[t]],
            xs[t],
            ys[t],
            heads[t],
            int(j),
            ends,
            ends and self._joins(model.end_joins, model.end_cut, int(cand[t])),
        )

    def _joins(self, joined: np.ndarray, cut: np.ndarray | None, i: int) -> bool:
        """Whether a branch that takes source branch (or history) ``i``'s ending ends on another
        branch: as it did, or, where it left the image and its end is unseen, as the source's
        seen ends do (the share ``join_rate`` of them end on a branch)."""
        if joined[i]:
            return True
        return cut is not None and bool(cut[i]) and self.rng.random() < self.model.join_rate

    def _draw(self, scores: np.ndarray) -> int:
        c = np.cumsum(np.maximum(scores, 0.0))
        if c[-1] <= 0:
            return 0
        return int(min(np.searchsorted(c, self.rng.random() * c[-1], side="right"), len(c) - 1))

    def _crowded(self) -> bool:
        """The structure has as many free ends per grown length as the source, or more."""
        rate = self.model.free_ends_per_length
        return rate is not None and self.n_free_ends >= rate * self.length_so_far()

    def merge_rate(self) -> float:
        """Probability that a branch running into another ends on it: 1 while the structure has
        fewer merges per grown length than the source, else the source's share of branch ends
        that are merges (so the merge density tracks the source's, as §4.2's histogram
        matching makes the angles track it)."""
        model = self.model
        if self._forced:
            return 1.0
        if model.merges_per_length <= 0:
            return 0.0
        if self.n_merges < model.merges_per_length * self.length_so_far():
            return 1.0
        return model.join_rate

    def length_so_far(self) -> float:
        return self.length + self.step * max(self._tip_n - 1, 0)

    def _accept_join(self, x: float, y: float, heading: float) -> bool:
        """Merge where an initial segment runs into a branch: with the source's merge rate
        times the likelihood of the incidence angle (as the kernel decides for extensions)."""
        if self.model.join_rate <= 0:
            return False
        nb, _ = self.sample(self.near_branch, np.array([x]), np.array([y]), np.int32(-1))
        tan, _ = self.sample(self.near_tangent, np.array([x]), np.array([y]), np.float32(0))
        if nb[0] < 0:
            return False
        inc = abs(float(_wrap(heading - float(tan[0]))))
        inc = min(inc, np.pi - inc)
        like = 1.0
        if self.join_pdf is not None:
            like = max(float(self.join_pdf[min(int(inc / (np.pi / 2) * 6), 5)]), 0.1)
        return self.rng.random() < self.merge_rate() * like

    def _snap(self, tip: _Tip, hx, hy, branch: Branch) -> None:
        """End the branch on the committed vertex nearest to ``(hx, hy)`` (a merge)."""
        nb, _ = self.sample(self.near_branch, np.array([hx]), np.array([hy]), np.int32(-1))
        nv, _ = self.sample(self.near_vertex, np.array([hx]), np.array([hy]), np.int32(-1))
        if nb[0] < 0:
            return
        x, y, _ = self.branches[int(nb[0])].points[int(nv[0])]
        if self.wrap:  # the met vertex's copy nearest to the tip (branches run on across edges)
            x += self.w * np.round((hx - x) / self.w)
            y += self.h * np.round((hy - y) / self.h)
        tip.xyr[tip.n] = (x, y, tip.xyr[tip.n - 1, 2])
        tip.n += 1
        branch.joins, branch.join_vertex = int(nb[0]), int(nv[0])
        self.n_merges += 1

    def _reach(self, tip: _Tip, start, exempt, b, branch) -> None:
        """A branch whose source ended on another branch goes on straight until it meets one
        (within the source's median branch length, at least 3 rho and m steps) and ends on it."""
        n = int(np.ceil(self.reach / self.step))
        x0, y0, r = tip.xyr[tip.n - 1]
        straight = np.zeros((n, 2))
        straight[:, 1] = r
        xs, ys, _, j, _ = self._path(x0, y0, tip.theta, straight, start, exempt, b)
        if j < 0:
            return
        tip.xyr[tip.n : tip.n + j, 0] = xs[:j]
        tip.xyr[tip.n : tip.n + j, 1] = ys[:j]
        tip.xyr[tip.n : tip.n + j, 2] = r
        tip.n += j
        self._snap(tip, xs[j], ys[j], branch)

    def run(self, progress=None) -> None:
        """Grow until the stopping rules hold. Children are grown breadth first; a new root
        starts at the emptiest point whenever the structure has fewer separate networks per
        grown length than the source (or nothing is left to grow), so the networks spread
        over the whole output instead of one tree filling it from a corner; while below that
        rate, roots and children take turns."""
        queue: deque[tuple[int, int, int]] = deque()
        failures = 0
        roots_open = True
        last_was_root = False
        while self.length < self.target and len(self.branches) < self.options.max_branches:
            want_root = (
                roots_open
                and self.n_roots < self.model.roots_per_length * self.length + 1
                and not (last_was_root and queue)
            )  # roots and children take turns
            last_was_root = want_root or not queue
            if want_root or not queue:
                b = starts.root(self)
                if b is None:
                    failures += 1
                    if failures > 20:
                        if not queue:
                            break
                        roots_open = False
                    continue
                failures = 0
                self.n_roots += 1
                queue.extend((b, v, 1) for _, v in starts.furcate(self, b))
            else:
                parent, v, level = queue.popleft()
                if level > self.options.max_levels:
                    continue
                c = starts.child(self, parent, v)
                if c is not None:
                    queue.extend((c, w, level + 1) for _, w in starts.furcate(self, c))
            if progress:
                progress(min(self.length, self.target), self.target)


def grow_structure(
    model: BranchModel,
    size: tuple[int, int],
    *,
    seed: int = 0,
    guide: np.ndarray | None = None,
    options: GrowOptions | None = None,
    progress=None,
    tile: bool = False,
) -> Structure:
    """Grow a new structure of ``size = (width, height)`` pixels from ``model``.

    Args:
        model: statistics of a source structure (:func:`~barkgen.branching.model.fit_model`).
        size: output size in pixels, ``(width, height)``.
        seed: seeds the one ``numpy.random.Generator`` behind every random choice.
        guide: optional ``(height, width)`` map in [0, 1] (sibbing2010 §4.5): branches are drawn
            to low values (a dark valley along a path), roots start where it is low.
        options: stopping rules and the density spread.
        progress: optional ``progress(done, total)`` callback (length grown so far).
        tile: grow on the torus: the contact and density maps (and the guide) run on across
            the output's edges, so branches cross them and meet branches on the other side,
            and the structure is :attr:`~Structure.periodic` (its rasterization tiles).
    """
    options = (options or GrowOptions()).validate()
    w, h = int(size[0]), int(size[1])
    check_grow_size((w, h), options, guide is not None)
    if guide is not None:
        guide = np.asarray(guide, np.float32)
        if guide.shape != (h, w):
            raise InvalidInputError(
                f"guide map is {guide.shape[1]}x{guide.shape[0]} but the output is {w}x{h}; they must be the same size"
            )
    grower = _Grower(model, (w, h), guide, options, np.random.default_rng(seed), wrap=tile)
    grower.run(progress)
    if not grower.branches:
        raise InvalidInputError("growth produced no branch (the output is too small for the model)")
    return Structure(model.step, (w, h), grower.branches, periodic=bool(tile))
