"""Fragment-based image synthesis along a branching structure (sibbing2010 §5).

:func:`render_branches` paints a new image whose cracks follow a *target* structure, from a
photo and the *source* structure drawn on it:

1. **Fill (§5.4, by the core engine).** The whole output is first synthesized by
   :func:`barkgen.synth.texture_by_numbers` with the rasterized source structure as the
   exemplar's labels and the rasterized target structure as the wanted labels, so background
   only comes from source background and no pseudo-branches appear. The paper fills the gaps
   last; here the fill comes first and counts as "previous content" for every fragment, so the
   seams and the photometric correction of the fragments anchor to it (same result where the
   fragments cover the branches, and no hole can be left between them).
2. **Fragments (§5.1).** Disks centred on the skeletons, radius ``radius_factor`` x the
   interpolated half-width (clamped to ``[min_radius, max_radius]``), centres
   ``lambda (s_i + s_{i+1})`` apart along the arc; extra *junction* fragments at furcations
   (and, beyond the paper, at merges: a branch that ends on another). A fragment's *shape* is
   ``k`` skeleton samples at arc offsets ``-r .. r`` around its centre (2-D positions relative
   to the centre) and their half-widths; a junction adds ``k`` samples along the child.
   Samples beyond a free branch end have half-width 0 (the crack stops there).
3. **Branch synthesis (§5.2).** Target fragments are filled in structure order (parents before
   children, a child's junction fragment first). For each one, the closed-form 2-D rigid
   alignment (rotation about the centres, forward or reversed along the skeleton) to every
   source fragment and the shape cost ``S`` of eq. 1 are computed at once with numpy; the best
   ``shortlist`` get the colour cost ``C`` (squared colour difference to the content already in
   the disk); one of the ``candidates`` best ``S + omega_c C`` is drawn with a probability
   inversely proportional to its cost.
4. **Composition (§5.3).** The rotated source fragment is warped by the smooth displacement
   field that minimises the squared discrete Laplacian while moving its skeleton samples
   exactly onto the target's; a graph cut (PyMaxflow) finds the seam with the content already
   there (the new fragment's own crack is forced in, the disk rim, other cracks of the target
   and source cracks that are not the fragment's own are forced out); the colour difference
   along the seam is interpolated harmonically over the new pixels (Poisson photometric
   correction; zero offset where the new pixels touch no previous content). A junction
   fragment first clears the parent's pixels in its disk (Fig. 6).

Everything random comes from one ``numpy.random.Generator`` seeded by ``seed``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from barkgen.branching.structure import Structure, rasterize
from barkgen.errors import InvalidInputError
from barkgen.synth.config import SynthesisConfig

ProgressCallback = Callable[[int, int], None]

#: nodes per side of the grid the displacement field is solved on (scaled to each fragment);
#: the field is smooth, so it is solved coarse and interpolated bilinearly to the pixels
WARP_GRID = 13
#: regulariser of the warp energy (pulls the field to 0 far from the constraints)
WARP_EPS = 1e-4
#: pixels within this distance of a fragment's own crack edge always come from the fragment
OWN_MARGIN = 1.5
#: other cracks (of the target or of the source) are protected this far beyond their edge
OTHER_MARGIN = 2
#: a junction fragment clears (takes unconditionally) this fraction of its radius (Fig. 6)
JUNCTION_CLEAR = 0.6
#: colour-consistency probes: rings at these fractions of the radius, this many per ring
RING_RADII = (0.45, 0.7, 0.95)
RING_SAMPLES = 24


@dataclass(frozen=True)
class RenderOptions:
    """Parameters of :func:`render_branches` (sibbing2010 §5).

    Attributes:
        lambda_spacing: centres of successive fragments are ``lambda (s_i + s_{i+1})`` apart.
        radius_factor: fragment radius = this x the branch half-width at its centre.
        min_radius, max_radius: clamp of the fragment radius in pixels; thin cracks would
            otherwise give fragments too small to carry any texture.
        omega_s: weight of the half-width term of the shape cost (eq. 1).
        omega_c: weight of the colour cost. ``C`` is the mean squared colour difference to the
            content already in the disk, in units of the source image's colour variance and
            multiplied by ``r^2`` (so it scales with the fragment like ``S``); the default
            makes a fragment whose colours differ like two random pixels of the photo cost
            as much as a skeleton misfit of about a fifth of the radius per sample.
        candidates: ``c``, how many of the best fragments the random choice is among.
        samples: ``k``, skeleton samples per fragment shape.
        shortlist: best fragments by shape that get the (costlier) colour test.
        source_density: source fragments are this many times denser than target ones along
            the source skeleton (more candidates; the paper uses 1).
        fill_config: solver configuration of the texture-by-numbers fill (default: the core
            engine's texture-by-numbers defaults).
    """

    lambda_spacing: float = 0.75
    radius_factor: float = 3.0
    min_radius: float = 8.0
    max_radius: float = 40.0
    omega_s: float = 2.0
    omega_c: float = 0.3
    candidates: int = 2
    samples: int = 9
    shortlist: int = 16
    source_density: float = 2.0
    max_rotation: float = 180.0
    interpolation: str = "nearest"
    fill_config: SynthesisConfig | None = None

    def __post_init__(self) -> None:
        def bad(name: str, rule: str) -> None:
            raise InvalidInputError(f"render option {name} must be {rule}, got {getattr(self, name)!r}")

        for name, lo, hi in (("lambda_spacing", 0.2, 1.0), ("radius_factor", 0.5, 20.0),
                             ("omega_s", 0.0, 1e6), ("omega_c", 0.0, 1e6),
                             ("source_density", 1.0, 8.0), ("max_rotation", 0.0, 180.0)):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not lo <= v <= hi:
                bad(name, f"a number in [{lo}, {hi}]")
        if not isinstance(self.min_radius, (int, float)) or not 3.0 <= self.min_radius <= 256:
            bad("min_radius", "a number of pixels in [3, 256]")
        if not isinstance(self.max_radius, (int, float)) or not self.min_radius <= self.max_radius <= 256:
            bad("max_radius", "a number of pixels in [min_radius, 256]")
        for name, lo, hi in (("candidates", 1, 64), ("samples", 3, 64), ("shortlist", 1, 1024)):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or not lo <= v <= hi:
                bad(name, f"an integer in [{lo}, {hi}]")
        if self.interpolation not in ("nearest", "cubic"):
            bad("interpolation", "'nearest' or 'cubic'")
        if self.fill_config is not None and not isinstance(self.fill_config, SynthesisConfig):
            bad("fill_config", "a SynthesisConfig")


@dataclass
class RenderResult:
    """What :func:`render_branches` returns.

    Attributes:
        image: the output, uint8, ``(H, W, 3)`` or ``(H, W)`` like the input photo.
        labels: uint8 fissure map of the output: 255 on the rasterized target structure.
        coverage: bool, where fragments were placed.
        fragment_map: int32, index of the target fragment that wrote each pixel (-1: fill).
        n_fragments: target fragments placed; n_source_fragments: candidates on the source.
        seed: as requested.
        timings: seconds spent in ``fill`` (texture-by-numbers), ``fragments`` and ``total``.
    """

    image: np.ndarray
    labels: np.ndarray
    coverage: np.ndarray
    fragment_map: np.ndarray
    n_fragments: int = 0
    n_source_fragments: int = 0
    seed: int = 0
    timings: dict[str, float] = field(default_factory=dict)


# ----------------------------------------------------------------------------------------------
# geometry of one branch: arc-length parametrisation with extrapolation beyond the ends


class _Arc:
    """A branch as a function of arc length; beyond an end it continues along the end tangent,
    with half-width 0 at a free end and the end's half-width where the end is connected."""

    def __init__(self, points: np.ndarray, start_connected: bool, end_connected: bool):
        pts = np.asarray(points, np.float64)
        seg = np.hypot(*np.diff(pts[:, :2], axis=0).T)
        self.vertex_arc = np.concatenate([[0.0], np.cumsum(seg)])
        keep = np.concatenate([[True], seg > 1e-9])
        self.s = self.vertex_arc[keep]
        self.p = pts[keep]
        self.length = float(self.s[-1])
        self.start_connected, self.end_connected = start_connected, end_connected
        if len(self.s) >= 2:
            t0 = self.p[1, :2] - self.p[0, :2]
            t1 = self.p[-1, :2] - self.p[-2, :2]
            self.t0 = t0 / np.hypot(*t0)
            self.t1 = t1 / np.hypot(*t1)
        else:
            self.t0 = self.t1 = np.array([1.0, 0.0])

    def at(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``x, y, half-width, real`` at arc positions ``t`` (real: on the branch itself)."""
        t = np.atleast_1d(np.asarray(t, np.float64))
        x = np.interp(t, self.s, self.p[:, 0])
        y = np.interp(t, self.s, self.p[:, 1])
        th = np.interp(t, self.s, self.p[:, 2])
        before, after = t < 0, t > self.length
        x = np.where(before, self.p[0, 0] + t * self.t0[0], x)
        y = np.where(before, self.p[0, 1] + t * self.t0[1], y)
        x = np.where(after, self.p[-1, 0] + (t - self.length) * self.t1[0], x)
        y = np.where(after, self.p[-1, 1] + (t - self.length) * self.t1[1], y)
        if not self.start_connected:
            th = np.where(before, 0.0, th)
        if not self.end_connected:
            th = np.where(after, 0.0, th)
        return x, y, th, ~(before | after)


def _radius(arc: _Arc, t: float, opts: RenderOptions) -> float:
    th = float(np.interp(t, arc.s, arc.p[:, 2]))
    return float(np.clip(opts.radius_factor * th, opts.min_radius, opts.max_radius))


def _centres(arc: _Arc, t0: float, r_before: float | None, opts: RenderOptions,
             density: float = 1.0) -> list[float]:
    """Arc positions of fragment centres from ``t0`` (or one spacing after a fragment of radius
    ``r_before`` at ``t0``) to the end: ``lambda (s_i + s_{i+1}) / density`` apart, the last
    one at the end when the previous one leaves the tail uncovered."""
    lam = opts.lambda_spacing / density
    out: list[float] = []
    if r_before is None:
        t, r = t0, _radius(arc, t0, opts)
        out.append(t)
    else:
        t, r = t0, r_before
    length = arc.length
    while True:
        nxt = t + 2 * lam * r
        for _ in range(2):
            nxt = t + lam * (r + _radius(arc, min(nxt, length), opts))
        if nxt >= length:
            if length - t > 0.5 * lam * r or not out:
                out.append(length)
            break
        t, r = nxt, _radius(arc, nxt, opts)
        out.append(t)
    return out


@dataclass
class _Fragment:
    """A fragment's shape: centre, radius, samples (complex positions relative to the centre,
    half-widths, on-branch flags) and the number of leading samples that may be reversed
    (all of them for a regular fragment, the parent window of a junction); ``own`` is the
    fragment's own crack as a polyline (x, y, half-width, valid) in image coordinates."""

    centre: complex
    radius: float
    pos: np.ndarray
    thick: np.ndarray
    real: np.ndarray
    split: int
    own: np.ndarray
    junction: bool = False


def _regular(arc: _Arc, t: float, r: float, k: int) -> _Fragment:
    x, y, th, real = arc.at(t + r * np.linspace(-1.0, 1.0, k))
    cx, cy, _, _ = arc.at(t)
    c = complex(cx[0], cy[0])
    own = np.stack([x, y, th, real.astype(np.float64)], axis=1)
    return _Fragment(c, r, (x + 1j * y) - c, th, real, k, own)


def _junction(parent: _Arc, vertex: int, child: _Arc, child_reversed: bool, k: int,
              opts: RenderOptions) -> _Fragment:
    """A junction fragment at vertex ``vertex`` of ``parent``: the parent window and ``k``
    samples along the child going away from the junction (the child's end when reversed)."""
    a = float(parent.vertex_arc[vertex])
    r = max(_radius(parent, a, opts), _radius(child, child.length if child_reversed else 0.0, opts))
    px, py, pth, preal = parent.at(a + r * np.linspace(-1.0, 1.0, k))
    cx, cy, _, _ = parent.at(a)
    c = complex(cx[0], cy[0])
    steps = r * np.arange(1, k + 1) / k
    qx, qy, qth, qreal = child.at(child.length - steps if child_reversed else steps)
    pos = np.concatenate([px + 1j * py, qx + 1j * qy]) - c
    thick = np.concatenate([pth, qth])
    real = np.concatenate([preal, qreal])
    start = np.array([[cx[0], cy[0], qth[0], 1.0]])
    sep = np.array([[cx[0], cy[0], 0.0, 0.0]])
    own = np.concatenate([np.stack([px, py, pth, preal.astype(np.float64)], axis=1), sep, start,
                          np.stack([qx, qy, qth, qreal.astype(np.float64)], axis=1)])
    return _Fragment(c, r, pos, thick, real, k, own, junction=True)


def _arcs(structure: Structure) -> list[_Arc]:
    return [_Arc(b.points, b.parent is not None, b.joins is not None) for b in structure.branches]


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


class _Bank:
    """The source fragments of one kind (regular or junction) as stacked arrays."""

    def __init__(self, frags: list[_Fragment]):
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
        # both orientations stacked (forward rows first) for the vectorised fit
        pos = np.concatenate([self.pos[:, o] for o in self.orders])
        self.conj_pos = np.ascontiguousarray(np.conj(pos))
        self.sq = np.ascontiguousarray(np.abs(pos) ** 2)
        self.thick_all = np.ascontiguousarray(np.concatenate([self.thick[:, o] for o in self.orders]))
        self.thick2 = self.thick_all ** 2


def _source_banks(source: Structure, width: int, height: int, opts: RenderOptions) -> tuple[_Bank, _Bank]:
    arcs = _arcs(source)
    k = opts.samples
    regular: list[_Fragment] = []
    junction: list[_Fragment] = []

    def inside(f: _Fragment) -> bool:
        return (f.radius + 1 <= f.centre.real <= width - 2 - f.radius
                and f.radius + 1 <= f.centre.imag <= height - 2 - f.radius)

    for arc in arcs:
        if arc.length <= 0:
            continue
        for t in _centres(arc, 0.0, None, opts, opts.source_density):
            f = _regular(arc, t, _radius(arc, t, opts), k)
            if inside(f):
                regular.append(f)
    for i, b in enumerate(source.branches):
        for ref, vertex, rev in ((b.parent, b.parent_vertex, False), (b.joins, b.join_vertex, True)):
            if ref is None or arcs[i].length <= 0 or arcs[ref].length <= 0:
                continue
            f = _junction(arcs[ref], vertex, arcs[i], rev, k, opts)
            if inside(f):
                junction.append(f)
    return _Bank(regular), _Bank(junction)


def _target_plan(target: Structure, opts: RenderOptions, with_junctions: bool) -> list[_Fragment]:
    """Target fragments in synthesis order: branches parents first, a child's junction fragment
    before its own fragments; the junctions of merges last (both branches exist by then)."""
    arcs = _arcs(target)
    k = opts.samples
    plan: list[_Fragment] = []
    merges: list[_Fragment] = []
    for i in _order(target):
        b, arc = target.branches[i], arcs[i]
        if arc.length <= 0:
            continue
        if b.parent is not None and with_junctions and arcs[b.parent].length > 0:
            j = _junction(arcs[b.parent], b.parent_vertex, arc, False, k, opts)
            plan.append(j)
            ts = _centres(arc, 0.0, j.radius, opts)
        else:
            ts = _centres(arc, 0.0, None, opts)
        plan.extend(_regular(arc, t, _radius(arc, t, opts), k) for t in ts)
        if b.joins is not None and with_junctions and arcs[b.joins].length > 0:
            merges.append(_junction(arcs[b.joins], b.join_vertex, arc, True, k, opts))
    return plan + merges


# ----------------------------------------------------------------------------------------------
# the smooth displacement field (§5.3): argmin sum |Laplacian d|^2 subject to d(q_l) = d_l


class _Warp:
    """Minimiser of the squared graph Laplacian (Neumann border) of a displacement field on a
    ``WARP_GRID``-square grid spanning the fragment's box, interpolating given vectors at given
    points (bilinear constraints), in closed form: ``d = G B^T (B G B^T)^-1 c`` with
    ``G = (L^T L + eps I)^-1``. ``L`` is built with scipy.sparse and factorised once; since the
    grid is scaled to every fragment, the same ``G`` serves all of them."""

    def __init__(self, m: int = WARP_GRID):
        import scipy.sparse as sp
        import scipy.sparse.linalg as spla

        self.m = m
        n = m * m
        idx = np.arange(n).reshape(m, m)
        rows, cols = [], []
        for a, b in ((idx[:, :-1], idx[:, 1:]), (idx[:-1, :], idx[1:, :])):
            rows += [a.ravel(), b.ravel()]
            cols += [b.ravel(), a.ravel()]
        r, c = np.concatenate(rows), np.concatenate(cols)
        adj = sp.csr_matrix((np.ones(len(r)), (r, c)), shape=(n, n))
        lap = sp.diags(np.asarray(adj.sum(axis=1)).ravel()) - adj
        a = (lap.T @ lap + WARP_EPS * sp.identity(n)).tocsc()
        self.green = spla.splu(a).solve(np.eye(n))
        self._interp: dict[int, np.ndarray] = {}

    def weights(self, gx: np.ndarray, gy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Node indices and bilinear weights (``(n, 4)`` each) of grid points ``(gx, gy)``."""
        m = self.m
        gx = np.clip(gx, 0.0, m - 1 - 1e-9)
        gy = np.clip(gy, 0.0, m - 1 - 1e-9)
        x0, y0 = np.floor(gx).astype(np.int64), np.floor(gy).astype(np.int64)
        fx, fy = gx - x0, gy - y0
        idx = np.stack([y0 * m + x0, y0 * m + x0 + 1, (y0 + 1) * m + x0, (y0 + 1) * m + x0 + 1], 1)
        w = np.stack([(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy], 1)
        return idx, w

    def solve(self, half: int, points: np.ndarray, vectors: np.ndarray) -> np.ndarray:
        """The field on the pixels of a ``(2 half + 1)^2`` box, as a complex array, given
        constraint ``points`` (complex, relative to the box centre) and ``vectors``."""
        size = 2 * half + 1
        if len(points) == 0:
            return np.zeros((size, size), np.complex128)
        scale = (self.m - 1) / (2.0 * half)
        idx, w = self.weights((points.real + half) * scale, (points.imag + half) * scale)
        gbt = (self.green[:, idx] * w[None]).sum(axis=2)                   # G B^T, (n, k)
        bgbt = (gbt[idx] * w[:, :, None]).sum(axis=1)                     # B G B^T, (k, k)
        bgbt += np.eye(len(points)) * (1e-9 * np.trace(bgbt) / len(points))
        nodes = gbt @ np.linalg.solve(bgbt, vectors)
        interp = self._interp.get(half)
        if interp is None:
            g = np.arange(size) * scale
            g0 = np.minimum(np.floor(g).astype(np.int64), self.m - 2)
            f = g - g0
            interp = np.zeros((size, self.m))
            interp[np.arange(size), g0] = 1 - f
            interp[np.arange(size), g0 + 1] += f
            self._interp[half] = interp
        return interp @ nodes.reshape(self.m, self.m) @ interp.T


# ----------------------------------------------------------------------------------------------
# input checks


def _check_inputs(image: object, source: object, target: object) -> tuple[np.ndarray, bool]:
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8:
        raise InvalidInputError("the source image must be a uint8 array")
    grey = image.ndim == 2
    if not (grey or (image.ndim == 3 and image.shape[2] in (1, 3))):
        raise InvalidInputError(f"the source image must be (H, W) or (H, W, 3), not shape {image.shape}")
    h, w = image.shape[:2]
    if min(h, w) < 16:
        raise InvalidInputError(f"the source image is too small ({w}x{h}); at least 16x16 pixels")
    for name, s in (("source", source), ("target", target)):
        if not isinstance(s, Structure):
            raise InvalidInputError(f"the {name} structure must be a Structure, not {type(s).__name__}")
        if not s.branches:
            raise InvalidInputError(f"the {name} structure is empty (no branches)")
        s.validate(f"{name} structure")
        for i, b in enumerate(s.branches):
            p = np.asarray(b.points)
            if p.ndim != 2 or p.shape[1] != 3 or len(p) < 2 or not np.isfinite(p).all():
                raise InvalidInputError(f"{name} structure: branch {i} needs at least two finite "
                                        "x, y, thickness rows")
            if (p[:, 2] <= 0).any():
                raise InvalidInputError(f"{name} structure: branch {i} has a thickness <= 0")
    if tuple(source.size) != (w, h):
        raise InvalidInputError(f"the source structure is for a {source.width}x{source.height} image, "
                                f"the source image is {w}x{h}")
    pts = np.concatenate([b.points for b in source.branches])
    if (pts[:, 0] < -1).any() or (pts[:, 0] > w).any() or (pts[:, 1] < -1).any() or (pts[:, 1] > h).any():
        raise InvalidInputError(f"the source structure has points outside the {w}x{h} source image")
    tw, th = target.size
    if not (16 <= tw <= 16384 and 16 <= th <= 16384):
        raise InvalidInputError(f"the target size must be 16..16384 pixels a side, got {tw}x{th}")
    return (image[:, :, None] if grey else image), grey


# ----------------------------------------------------------------------------------------------
# the renderer


class _Renderer:
    def __init__(self, img: np.ndarray, source: Structure, target: Structure, canvas: np.ndarray,
                 content: np.ndarray, opts: RenderOptions, rng: np.random.Generator,
                 regular: _Bank, junction: _Bank):
        import cv2

        self.opts, self.rng = opts, rng
        self.src = np.ascontiguousarray(img, np.float32)
        self.sh, self.sw = img.shape[:2]
        self.canvas, self.content = canvas, content
        self.h, self.w = canvas.shape[:2]
        self.var = max(float(self.src.reshape(-1, self.src.shape[2]).var(axis=0).sum()), 1.0)
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * OTHER_MARGIN + 1,) * 2)
        self.src_cracks = cv2.dilate(rasterize(source).astype(np.uint8), kernel).astype(bool)
        self.tgt_raster = rasterize(target)
        self.tgt_cracks = cv2.dilate(self.tgt_raster.astype(np.uint8), kernel).astype(bool)
        self.regular, self.junction = regular, junction
        self.warp = _Warp()
        ang = np.arange(RING_SAMPLES) * (2 * np.pi / RING_SAMPLES)
        self.ring = np.concatenate([f * np.exp(1j * (ang + 0.5 * i * 2 * np.pi / RING_SAMPLES))
                                    for i, f in enumerate(RING_RADII)])
        self.coverage = np.zeros((self.h, self.w), bool)
        self.fragment_map = np.full((self.h, self.w), -1, np.int32)

    # -- §5.2: choose a source fragment -------------------------------------------------------

    def _shape_costs(self, bank: _Bank, g: _Fragment, weight: np.ndarray):
        """Shape cost S (eq. 1) and rotation of every source fragment, forward and reversed:
        arrays ``(n, 2)``. The rotation about the centres is the closed-form least-squares one
        (2-D Procrustes: the argument of ``sum conj(p_l) q_l``), clamped to
        ``max_rotation``."""
        wq = weight * g.pos
        qq = float((weight * np.abs(g.pos) ** 2).sum())
        wnu = weight * g.thick
        nn = float((wnu * g.thick).sum())
        z = bank.conj_pos @ wq                                  # (2n,)
        mag = np.abs(z)
        limit = math.radians(self.opts.max_rotation)
        if limit >= math.pi:
            rot = np.where(mag > 1e-12, z / np.maximum(mag, 1e-12), 1.0)
            fit = mag
        else:
            ang = np.clip(np.angle(z), -limit, limit)
            rot = np.exp(1j * ang)
            fit = (z * np.conj(rot)).real
        residual = bank.sq @ weight + qq - 2 * fit
        thick = bank.thick2 @ weight - 2 * (bank.thick_all @ wnu) + nn
        cost = (np.maximum(residual, 0.0) + self.opts.omega_s * np.maximum(thick, 0.0)).reshape(2, -1).T
        # the box sampled around a source centre must stay inside the photo
        margin = g.radius + 2
        c = bank.centre
        ok = ((c.real >= margin) & (c.real <= self.sw - 1 - margin)
              & (c.imag >= margin) & (c.imag <= self.sh - 1 - margin))
        if ok.any():
            cost[~ok] = np.inf
        return cost, rot.reshape(2, -1).T

    def _colour_costs(self, bank: _Bank, g: _Fragment, idx: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """Colour cost C: mean squared difference between the rigidly placed candidates and the
        content already under the probe rings, / colour variance x r^2."""
        t = g.centre + g.radius * self.ring
        tx, ty = np.rint(t.real).astype(np.int64), np.rint(t.imag).astype(np.int64)
        ok = (tx >= 0) & (tx < self.w) & (ty >= 0) & (ty < self.h)
        tx, ty = tx[ok], ty[ok]
        has = self.content[ty, tx]
        if not has.any():
            return np.zeros(len(idx))
        old = self.canvas[ty[has], tx[has]]
        s = bank.centre[idx, None] + np.conj(rot[:, None]) * (g.radius * self.ring[ok][has])[None]
        sx = np.clip(np.rint(s.real).astype(np.int64), 0, self.sw - 1)
        sy = np.clip(np.rint(s.imag).astype(np.int64), 0, self.sh - 1)
        new = self.src[sy, sx]
        return ((new - old[None]) ** 2).sum(axis=2).mean(axis=1) / self.var * g.radius ** 2

    def choose(self, g: _Fragment) -> tuple[_Bank, int, int, complex] | None:
        bank = self.junction if (g.junction and self.junction.n) else self.regular
        if g.junction and bank is self.regular:
            return None  # no junction in the source: the child's own fragments make the joint
        # samples outside the canvas do not count (where the crack continues is invisible)
        p = g.pos + g.centre
        weight = ((p.real >= -2) & (p.real <= self.w + 1) & (p.imag >= -2) & (p.imag <= self.h + 1)).astype(float)
        if weight.sum() < 2:
            weight[:] = 1.0
        cost, rots = self._shape_costs(bank, g, weight)
        flat = cost.ravel()
        m = min(self.opts.shortlist, flat.size)
        short = np.argpartition(flat, m - 1)[:m] if m < flat.size else np.arange(flat.size)
        short = short[np.isfinite(flat[short])]
        i, o = np.divmod(short, 2)
        rot = rots[i, o]
        total = flat[short] + self.opts.omega_c * self._colour_costs(bank, g, i, rot)
        order = np.argsort(total, kind="stable")[: self.opts.candidates]
        inv = 1.0 / (total[order] + 1e-6 * (1.0 + total[order].min()))
        pick = order[self.rng.choice(len(order), p=inv / inv.sum())]
        return bank, int(i[pick]), int(o[pick]), complex(rot[pick])

    # -- §5.3: compose it ---------------------------------------------------------------------

    def place(self, j: int, g: _Fragment, bank: _Bank, i: int, o: int, rot: complex) -> None:
        import cv2
        import maxflow

        from barkgen.branching import _render_kernels as K

        f = bank.frags[i]
        order = bank.orders[o]
        half = int(math.ceil(g.radius)) + 1
        icx, icy = int(round(g.centre.real)), int(round(g.centre.imag))
        x0, x1 = max(icx - half, 0), min(icx + half + 1, self.w)
        y0, y1 = max(icy - half, 0), min(icy + half + 1, self.h)
        if x0 >= x1 or y0 >= y1:
            return
        # smooth displacement making the rotated source samples land on the target's
        pairs = g.real & f.real[order]
        q = g.pos[pairs]
        d = rot * f.pos[order][pairs] - q
        shift = g.centre - complex(icx, icy)
        field = self.warp.solve(half, q + shift, d)[y0 - icy + half:y1 - icy + half,
                                                    x0 - icx + half:x1 - icx + half]
        yy, xx = np.mgrid[y0:y1, x0:x1]
        rel = (xx + 1j * yy) - g.centre
        srcpos = f.centre + np.conj(rot) * (rel + field)
        mapx = srcpos.real.astype(np.float32)
        mapy = srcpos.imag.astype(np.float32)
        interp = cv2.INTER_NEAREST if self.opts.interpolation == "nearest" else cv2.INTER_CUBIC
        new = cv2.remap(self.src, mapx, mapy, interp, borderMode=cv2.BORDER_REFLECT_101)
        new = new.reshape(mapx.shape + (self.src.shape[2],))
        old = self.canvas[y0:y1, x0:x1]
        has = self.content[y0:y1, x0:x1]

        # graph-cut constraints
        dist = np.abs(rel)
        disk = dist <= g.radius
        go = g.own
        tgt_own = K.crack_distance(xx.astype(np.float64), yy.astype(np.float64), go[:, 0], go[:, 1],
                                   go[:, 2], go[:, 3] > 0)
        so = f.own
        src_own = K.crack_distance(srcpos.real, srcpos.imag, so[:, 0], so[:, 1], so[:, 2], so[:, 3] > 0)
        sx = np.clip(np.rint(mapx).astype(np.int64), 0, self.sw - 1)
        sy = np.clip(np.rint(mapy).astype(np.int64), 0, self.sh - 1)
        foreign = self.src_cracks[sy, sx] & (src_own > OTHER_MARGIN + 1)
        other = self.tgt_cracks[y0:y1, x0:x1] & (tgt_own > OTHER_MARGIN + 1)
        own = disk & (tgt_own <= OWN_MARGIN)
        take = own | (disk & ~has & ~foreign)
        if g.junction:
            take |= (dist <= JUNCTION_CLEAR * g.radius) & ~foreign & ~other
        keep = has & ~take & ((dist > g.radius - 1) | other | foreign)
        if not take.any():
            return
        free = ~(take | keep)
        if free.any():
            diff = np.sqrt(((new - old) ** 2).sum(axis=2)) * has
            right = np.zeros_like(diff)
            right[:, :-1] = diff[:, :-1] + diff[:, 1:]
            down = np.zeros_like(diff)
            down[:-1] = diff[:-1] + diff[1:]
            eps = 1e-3 * np.sqrt(self.var)
            graph = maxflow.Graph[float]()
            nodes = graph.add_grid_nodes(diff.shape)
            graph.add_grid_edges(nodes, weights=right + eps, structure=_RIGHT, symmetric=True)
            graph.add_grid_edges(nodes, weights=down + eps, structure=_DOWN, symmetric=True)
            big = 1e9
            graph.add_grid_tedges(nodes, np.where(take, big, 0.0), np.where(keep, big, 0.0))
            graph.maxflow()
            newmask = ~graph.get_grid_segments(nodes)
            newmask &= disk | take
        else:
            newmask = take
        # Poisson photometric correction: harmonic offset, seam difference on the boundary,
        # zero where the new pixels touch nothing placed before
        boundary = np.where(has[:, :, None], old - new, 0.0).astype(np.float32)
        offset = K.harmonic_offset(newmask, boundary, np.float32(0.05), 4 * half + 20)
        out = new + offset
        region = self.canvas[y0:y1, x0:x1]
        region[newmask] = out[newmask]
        self.content[y0:y1, x0:x1] |= newmask
        self.coverage[y0:y1, x0:x1] |= newmask
        self.fragment_map[y0:y1, x0:x1][newmask] = j


_RIGHT = np.array([[0, 0, 0], [0, 0, 1], [0, 0, 0]])
_DOWN = np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0]])


def render_branches(
    image: np.ndarray,
    source: Structure,
    target: Structure,
    *,
    seed: int = 0,
    fill: bool = True,
    progress: ProgressCallback | None = None,
    options: RenderOptions | None = None,
) -> RenderResult:
    """Render an image whose cracks follow ``target``, from ``image`` and its ``source``
    structure (sibbing2010 §5; see the module docstring).

    Args:
        image: the source photo, uint8 ``(H, W, 3)`` or grey ``(H, W)``.
        source: the structure on ``image`` (its size must be the image's).
        target: the structure to render; its size is the output size ``(width, height)``.
        seed: seeds the fill and the one ``numpy.random.Generator`` of the fragment choices.
        fill: complete the gaps with texture-by-numbers (§5.4); False leaves them black.
        progress: optional ``progress(done, total)`` callback.
        options: :class:`RenderOptions`.

    Returns:
        :class:`RenderResult`.

    Raises:
        InvalidInputError: a bad image, an empty or invalid structure, a source structure that
            does not fit the image or has no usable fragment, bad options.
    """
    t_start = time.perf_counter()
    opts = options if options is not None else RenderOptions()
    if not isinstance(opts, RenderOptions):
        raise InvalidInputError("options must be a RenderOptions")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise InvalidInputError(f"seed must be a non-negative integer, got {seed!r}")
    img, grey = _check_inputs(image, source, target)
    sh, sw = img.shape[:2]
    tw, th = target.size
    regular, junction = _source_banks(source, sw, sh, opts)
    if regular.n == 0:
        raise InvalidInputError("the source structure gives no fragment: its branches are too short "
                                "or too close to the image border for fragments of radius "
                                f">= {opts.min_radius:g} px")
    plan = _target_plan(target, opts, junction.n > 0)
    labels = rasterize(target)

    fill_total = 0

    def fill_progress(done: int, total: int) -> None:
        nonlocal fill_total
        fill_total = total
        if progress is not None:
            progress(done, total + len(plan))

    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    if fill:
        from barkgen.synth import texture_by_numbers

        res = texture_by_numbers(img, rasterize(source).astype(np.uint8) * 255,
                                 labels.astype(np.uint8) * 255, seed=int(seed),
                                 config=opts.fill_config, progress=fill_progress)
        canvas = res.image.reshape(th, tw, -1).astype(np.float32)
        content = np.ones((th, tw), bool)
    else:
        canvas = np.zeros((th, tw, img.shape[2]), np.float32)
        content = np.zeros((th, tw), bool)
    timings["fill"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    rng = np.random.default_rng(int(seed))
    r = _Renderer(img, source, target, canvas, content, opts, rng, regular, junction)
    placed = 0
    for j, g in enumerate(plan):
        p = g.pos + g.centre
        if (p.real.max() < -g.radius or p.real.min() > tw + g.radius
                or p.imag.max() < -g.radius or p.imag.min() > th + g.radius):
            continue
        pick = r.choose(g)
        if pick is not None:
            r.place(j, g, *pick)
            placed += 1
        if progress is not None:
            progress(fill_total + j + 1, fill_total + len(plan))
    timings["fragments"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start

    out = np.clip(np.rint(canvas), 0, 255).astype(np.uint8)
    if grey:
        out = out[:, :, 0]
    return RenderResult(image=out, labels=labels.astype(np.uint8) * 255, coverage=r.coverage,
                        fragment_map=r.fragment_map, n_fragments=placed,
                        n_source_fragments=regular.n + junction.n, seed=int(seed), timings=timings)
