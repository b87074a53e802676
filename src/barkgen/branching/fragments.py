"""Fragment sampling along a branching structure (sibbing2010 §5.1).

A branch is a function of its arc length (:class:`Arc`, extrapolated along the end tangents).
Fragments are disks centred on the skeletons, radius ``radius_factor`` x the interpolated
half-width (clamped to ``[min_radius, max_radius]``), centres ``lambda (s_i + s_{i+1})``
apart along the arc; extra *junction* fragments sit at furcations (and, beyond the paper, at
merges). A fragment's *shape* is ``k`` skeleton samples at arc offsets ``-r .. r`` around its
centre (2-D positions relative to the centre) and their half-widths; a junction adds ``k``
samples along the child. Samples beyond a free branch end have half-width 0.

:func:`source_banks` stacks the source fragments for the vectorised fit of §5.2;
:func:`target_plan` lists the target fragments in synthesis order. The numbers come from
:class:`FragmentSpec` (:attr:`barkgen.branching.render.RenderOptions.fragment_spec`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import barkgen.branching._render_kernels as K
from barkgen.branching.structure import Structure


@dataclass(frozen=True)
class FragmentSpec:
    """How fragments are laid along the branches (sibbing2010 §5.1; the fields of the same
    names of :class:`~barkgen.branching.render.RenderOptions`, already validated)."""

    lambda_spacing: float
    radius_factor: float
    min_radius: float
    max_radius: float
    samples: int
    source_density: float

    @property
    def radius_rule(self) -> tuple[float, float, float]:
        """``(factor, rmin, rmax)``: a fragment's radius is ``clip(factor x half-width, rmin,
        rmax)`` (the kernels' form)."""
        return float(self.radius_factor), float(self.min_radius), float(self.max_radius)


# ----------------------------------------------------------------------------------------------
# geometry of one branch: arc-length parametrisation with extrapolation beyond the ends


class Arc:
    """A branch as a function of arc length; beyond an end it continues along the end tangent,
    with half-width 0 at a free end and the end's half-width where the end is connected.

    ``kernel`` is the tuple the sampling kernels take: ``(s, x, y, half-width, start tangent,
    end tangent, start connected, end connected)``."""

    def __init__(self, points: np.ndarray, start_connected: bool, end_connected: bool):
        self.vertex_arc, self.s, self.px, self.py, self.pt, self.t0, self.t1 = K.arc_setup(
            np.ascontiguousarray(points, np.float64)
        )
        self.length = float(self.s[-1])
        self.start_connected, self.end_connected = bool(start_connected), bool(end_connected)
        self.kernel = (self.s, self.px, self.py, self.pt, self.t0, self.t1, self.start_connected, self.end_connected)


def _centres(arc: Arc, t0: float, r_before: float | None, spec: FragmentSpec, density: float = 1.0) -> np.ndarray:
    """Arc positions of fragment centres from ``t0`` (or one spacing after a fragment of radius
    ``r_before`` at ``t0``) to the end: ``lambda (s_i + s_{i+1}) / density`` apart, the last
    one at the end when the previous one leaves the tail uncovered."""
    return K.fragment_centres(
        arc.s, arc.pt, float(t0), float(r_before or 0.0), spec.lambda_spacing / density, spec.radius_rule
    )


@dataclass
class Fragment:
    """A fragment's shape: centre, radius, samples (complex positions relative to the centre,
    half-widths, on-branch flags) and the number of leading samples that may be reversed
    (all of them for a regular fragment, the parent window of a junction); ``own_cols`` is the
    fragment's own crack as a polyline (x, y, half-width, valid columns) in image coordinates;
    ``weight`` (target fragments) weighs the samples in the shape cost."""

    centre: complex
    radius: float
    pos: np.ndarray
    thick: np.ndarray
    real: np.ndarray
    split: int
    own_cols: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    junction: bool = False
    weight: np.ndarray | None = None
    visible: bool = True

    def __post_init__(self) -> None:
        self.pos_re, self.pos_im = np.ascontiguousarray(self.pos.real), np.ascontiguousarray(self.pos.imag)


def _regulars(arc: Arc, ts: np.ndarray, spec: FragmentSpec) -> list[Fragment]:
    """Regular fragments centred at arc positions ``ts`` (their radii from the half-width)."""
    if len(ts) == 0:
        return []
    k = spec.samples
    r, cx, cy, x, y, th, real = K.regular_samples(arc.kernel, np.asarray(ts, np.float64), k, spec.radius_rule)
    n = len(r)
    centre = cx + 1j * cy
    pos = (x + 1j * y) - centre[:, None]
    return [
        Fragment(complex(centre[i]), float(r[i]), pos[i], th[i], real[i], k, (x[i], y[i], th[i], real[i]))
        for i in range(n)
    ]


def _junction(parent: Arc, vertex: int, child: Arc, child_reversed: bool, k: int, spec: FragmentSpec) -> Fragment:
    """A junction fragment at vertex ``vertex`` of ``parent``: the parent window and ``k``
    samples along the child going away from the junction (the child's end when reversed)."""
    r, cx, cy, px, py, pth, preal, qx, qy, qth, qreal = K.junction_samples(
        parent.kernel, float(parent.vertex_arc[vertex]), child.kernel, bool(child_reversed), k, spec.radius_rule
    )
    c = complex(cx, cy)
    pos = np.concatenate([px + 1j * py, qx + 1j * qy]) - c
    # own crack: the parent window, a break, then the child from the junction point
    own = (
        np.concatenate([px, [cx, cx], qx]),
        np.concatenate([py, [cy, cy], qy]),
        np.concatenate([pth, [0.0, qth[0]], qth]),
        np.concatenate([preal, [False, True], qreal]),
    )
    return Fragment(c, r, pos, np.concatenate([pth, qth]), np.concatenate([preal, qreal]), k, own, junction=True)


def _arcs(structure: Structure) -> list[Arc]:
    return [Arc(b.points, b.parent is not None, b.joins is not None) for b in structure.branches]


def _order(structure: Structure) -> list[int]:
    """Branch indices with every parent before its children (structure order otherwise)."""
    done: set[int] = set()
    out: list[int] = []
    for i in range(len(structure.branches)):
        chain = []
        j: int | None = i
        while j is not None and j not in done and j not in chain:
            chain.append(j)
            j = structure.branches[j].parent
        for j in reversed(chain):
            done.add(j)
            out.append(j)
    return out


class FragmentBank:
    """The source fragments of one kind (regular or junction) as stacked arrays."""

    def __init__(self, frags: list[Fragment]):
        self.frags = frags
        self.n = len(frags)
        if not frags:
            return
        self.centre = np.array([f.centre for f in frags])
        self.radius = np.array([f.radius for f in frags])
        self.pos = np.stack([f.pos for f in frags])
        self.thick = np.stack([f.thick for f in frags])
        self.real = np.stack([f.real for f in frags])
        split = frags[0].split
        m = self.pos.shape[1]
        rev = np.concatenate([np.arange(split)[::-1], np.arange(split, m)])
        self.orders = (np.arange(m), rev)
        # per orientation: sample positions and on-branch flags, rows in that order
        self.oriented = tuple(np.ascontiguousarray(self.pos[:, o]) for o in self.orders)
        self.oriented_real = tuple(np.ascontiguousarray(self.real[:, o]) for o in self.orders)
        # both orientations stacked (forward rows first) for the vectorised fit
        pos = np.concatenate([self.pos[:, o] for o in self.orders])
        self.pre, self.pim = np.ascontiguousarray(pos.real), np.ascontiguousarray(pos.imag)
        self.cre, self.cim = np.ascontiguousarray(self.centre.real), np.ascontiguousarray(self.centre.imag)
        self.thick_all = np.ascontiguousarray(np.concatenate([self.thick[:, o] for o in self.orders]))
        self.border = np.zeros(self.n)  # set by source_banks: distance of the centre to the border

    @property
    def kernel(self) -> tuple[np.ndarray, ...]:
        """``(pre, pim, half-widths, border, centre re, centre im)``: the rows (both
        orientations) as :func:`barkgen.branching._render_kernels.select_candidates` takes them."""
        return self.pre, self.pim, self.thick_all, self.border, self.cre, self.cim


def source_banks(source: Structure, width: int, height: int, spec: FragmentSpec) -> tuple[FragmentBank, FragmentBank]:
    arcs = _arcs(source)
    k = spec.samples
    regular: list[Fragment] = []
    junction: list[Fragment] = []

    def inside(f: Fragment) -> bool:
        return (
            f.radius + 1 <= f.centre.real <= width - 2 - f.radius
            and f.radius + 1 <= f.centre.imag <= height - 2 - f.radius
        )

    for arc in arcs:
        if arc.length <= 0:
            continue
        regular.extend(
            f for f in _regulars(arc, _centres(arc, 0.0, None, spec, spec.source_density), spec) if inside(f)
        )
    for i, b in enumerate(source.branches):
        for ref, vertex, rev in ((b.parent, b.parent_vertex, False), (b.joins, b.join_vertex, True)):
            if ref is None or arcs[i].length <= 0 or arcs[ref].length <= 0:
                continue
            assert vertex is not None  # set with its link (Structure.validate)
            f = _junction(arcs[ref], vertex, arcs[i], rev, k, spec)
            if inside(f):
                junction.append(f)
    banks = FragmentBank(regular), FragmentBank(junction)
    for bank in banks:
        if bank.n:
            c = bank.centre
            border = np.minimum(np.minimum(c.real, width - 1 - c.real), np.minimum(c.imag, height - 1 - c.imag))
            bank.border = np.concatenate([border, border])  # both orientations
    return banks


def target_plan(target: Structure, spec: FragmentSpec, with_junctions: bool) -> list[Fragment]:
    """Target fragments in synthesis order: branches parents first, a child's junction fragment
    before its own fragments; the junctions of merges last (both branches exist by then)."""
    arcs = _arcs(target)
    k = spec.samples
    plan: list[Fragment] = []
    merges: list[Fragment] = []
    for i in _order(target):
        b, arc = target.branches[i], arcs[i]
        if arc.length <= 0:
            continue
        if b.parent is not None and with_junctions and arcs[b.parent].length > 0:
            assert b.parent_vertex is not None  # set with parent (Structure.validate)
            j = _junction(arcs[b.parent], b.parent_vertex, arc, False, k, spec)
            plan.append(j)
            ts = _centres(arc, 0.0, j.radius, spec)
        else:
            ts = _centres(arc, 0.0, None, spec)
        plan.extend(_regulars(arc, ts, spec))
        if b.joins is not None and with_junctions and arcs[b.joins].length > 0:
            assert b.join_vertex is not None  # set with joins (Structure.validate)
            merges.append(_junction(arcs[b.joins], b.join_vertex, arc, True, k, spec))
    # samples outside the canvas do not count in the shape cost (where the crack goes there is
    # invisible)
    w, h = target.size
    everything = plan + merges
    for size in {len(g.pos) for g in everything}:
        group = [g for g in everything if len(g.pos) == size]
        x = np.stack([g.pos_re for g in group]) + np.array([g.centre.real for g in group])[:, None]
        y = np.stack([g.pos_im for g in group]) + np.array([g.centre.imag for g in group])[:, None]
        weight = ((x >= -2) & (x <= w + 1) & (y >= -2) & (y <= h + 1)).astype(np.float64)
        weight[weight.sum(axis=1) < 2] = 1.0
        r = np.array([g.radius for g in group])
        cx = np.array([g.centre.real for g in group])
        cy = np.array([g.centre.imag for g in group])
        # the disk must meet the canvas
        visible = (cx + r >= 0) & (cx - r <= w - 1) & (cy + r >= 0) & (cy - r <= h - 1)
        for g, wt, vis in zip(group, weight, visible):
            g.weight, g.visible = wt, bool(vis)
    return everything
