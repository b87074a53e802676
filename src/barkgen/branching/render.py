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
2. **Fragments (§5.1, :mod:`barkgen.branching.fragments`).** Disks centred on the skeletons,
   radius ``radius_factor`` x the interpolated half-width (clamped to ``[min_radius,
   max_radius]``), centres ``lambda (s_i + s_{i+1})`` apart along the arc; extra *junction*
   fragments at furcations (and, beyond the paper, at merges: a branch that ends on another). A fragment's *shape* is
   ``k`` skeleton samples at arc offsets ``-r .. r`` around its centre (2-D positions relative
   to the centre) and their half-widths; a junction adds ``k`` samples along the child.
   Samples beyond a free branch end have half-width 0 (the crack stops there).
3. **Branch synthesis (§5.2).** Target fragments are filled in structure order (parents before
   children, a child's junction fragment first). For each one, the closed-form 2-D rigid
   alignment (rotation about the centres, forward or reversed along the skeleton) to every
   source fragment and the shape cost ``S`` of eq. 1 are computed in one pass (numba); the
   ``shortlist`` best get the colour cost ``C`` (squared colour difference to the content
   already in the disk); one of the ``candidates`` best ``S + omega_c C`` is drawn with a
   probability inversely proportional to its cost.
4. **Composition (§5.3).** The rotated source fragment is warped by the smooth displacement
   field that minimises the squared discrete Laplacian while moving its skeleton samples
   exactly onto the target's (closed form on a grid scaled to the fragment, :class:`_Warp`);
   source pixels are copied verbatim (nearest), and on the fragment's own crack the copied
   pixel is chosen so that the crack's dark core lands on the target skeleton. A graph cut
   (PyMaxflow, Kwatra et al. 2003 costs) finds the seam with the content already there: the
   fragment's own crack is forced in; the disk rim, other cracks of the target and source
   cracks that are not the fragment's own are forced out (no pseudo-branches). The colour
   difference along the seam is interpolated harmonically over the new pixels (Poisson
   photometric correction, [PGB03]) with zero offset where the new pixels touch no previous
   content (the paper's constraint against colour drift). Beyond the paper, the correction
   is a smooth *gain* (it works on log values) so a dark crack keeps its depth, the seam
   difference is averaged over 5 x 5 pixels (a colour shift, not the texture's pixel noise),
   and it is not imposed across the edge of another crack or on cracks only the fill has
   painted, where old and new differ by design. A junction fragment first clears the
   parent's pixels in its disk (Fig. 6).

Everything random comes from one ``numpy.random.Generator`` seeded by ``seed``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

import barkgen.branching._render_kernels as K
from barkgen.branching.fragments import Fragment, FragmentBank, FragmentSpec, source_banks, target_plan
from barkgen.branching.structure import Structure, rasterize
from barkgen.errors import InvalidInputError
from barkgen.synth import SynthesisConfig

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
#: the photometric correction's iterations stop when no log value changes by more than this
POISSON_TOL = 0.002
#: the seam differences are averaged over this many pixels (square window) before they are
#: interpolated: the correction is for colour shifts, not for the texture's pixel noise
SEAM_SMOOTH = 5
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
            content already in the disk, in units of the source image's colour variance (so
            ``omega_c`` does not depend on the photo's contrast) and multiplied by ``r^2`` (so it
            scales with the fragment like ``S``, as the paper's sum over the overlap does). With
            the default, a fragment whose colours differ like two random pixels of the photo
            costs as much as a skeleton misfit of a quarter of the radius at every sample; on
            cracked earth and dried mud the best shapes fit within ~0.1 radius, so the colour
            term decides among the ``shortlist`` best shapes.
        candidates: ``c``, how many of the best fragments the random choice is among.
        samples: ``k``, skeleton samples per fragment shape.
        shortlist: best fragments by shape that get the (costlier) colour test.
        source_density: source fragments are this many times denser than target ones along
            the source skeleton (more candidates; the paper uses 1).
        max_rotation: largest rotation (degrees) of a source fragment; 180 = any (the paper).
            Photos lit from one side look wrong rotated far; 0 copies without rotation.
        interpolation: how the rotated, warped source is read: ``"nearest"`` copies source
            pixels verbatim (as sharp as the photo, the texture stays pixel-exact between the
            1-px steps of the warp), ``"cubic"`` interpolates (smoother cracks, slightly
            softer texture).
        fill_label_weight: ``label_weight`` of the texture-by-numbers fill (its default 20):
            lower gives larger coherent pieces of background but lets more crack texture into
            it.
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
    fill_label_weight: float = 20.0
    fill_config: SynthesisConfig | None = None

    def __post_init__(self) -> None:
        def bad(name: str, rule: str) -> None:
            raise InvalidInputError(f"render option {name} must be {rule}, got {getattr(self, name)!r}")

        for name, lo, hi in (
            ("lambda_spacing", 0.2, 1.0),
            ("radius_factor", 0.5, 20.0),
            ("omega_s", 0.0, 1e6),
            ("omega_c", 0.0, 1e6),
            ("source_density", 1.0, 8.0),
            ("max_rotation", 0.0, 180.0),
            ("fill_label_weight", 0.0, 1e4),
        ):
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
        # plain floats from here on (the numba kernels see one signature)
        for name in (
            "lambda_spacing",
            "radius_factor",
            "omega_s",
            "omega_c",
            "source_density",
            "max_rotation",
            "fill_label_weight",
            "min_radius",
            "max_radius",
        ):
            object.__setattr__(self, name, float(getattr(self, name)))
        if self.interpolation not in ("nearest", "cubic"):
            bad("interpolation", "'nearest' or 'cubic'")
        if self.fill_config is not None and not isinstance(self.fill_config, SynthesisConfig):
            bad("fill_config", "a SynthesisConfig")

    @property
    def fragment_spec(self) -> FragmentSpec:
        """The fragment sampling's part of the options (§5.1)."""
        return FragmentSpec(
            self.lambda_spacing, self.radius_factor, self.min_radius, self.max_radius, self.samples, self.source_density
        )


@dataclass
class RenderResult:
    """What :func:`render_branches` returns.

    Attributes:
        image: the output, uint8, with the input photo's shape convention (``(H, W, 3)``,
            ``(H, W, 1)`` or ``(H, W)``).
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
        self.green = np.ascontiguousarray(spla.splu(a).solve(np.eye(n)))

    def field(self, half: int, points: np.ndarray, vectors: np.ndarray, rows: slice, cols: slice) -> np.ndarray:
        """The field (complex) on ``rows, cols`` of a ``(2 half + 1)^2`` box, given constraint
        ``points`` (complex box pixel coordinates) and ``vectors`` (complex)."""
        return K.warp_field(
            self.green,
            self.m,
            half,
            points.real.copy(),
            points.imag.copy(),
            vectors.real.copy(),
            vectors.imag.copy(),
            rows.start,
            rows.stop,
            cols.start,
            cols.stop,
        )


# ----------------------------------------------------------------------------------------------
# input checks


def _check_inputs(image: object, source: object, target: object) -> tuple[np.ndarray, bool]:
    if not isinstance(image, np.ndarray) or image.dtype not in (np.uint8, np.uint16):
        raise InvalidInputError("the source image must be a uint8 (or uint16) array")
    if image.dtype == np.uint16:  # rendered in 8 bits
        image = ((image.astype(np.uint32) + 128) // 257).astype(np.uint8)
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
                raise InvalidInputError(f"{name} structure: branch {i} needs at least two finite x, y, thickness rows")
            if (p[:, 2] <= 0).any():
                raise InvalidInputError(f"{name} structure: branch {i} has a thickness <= 0")
    assert isinstance(source, Structure) and isinstance(target, Structure)  # checked just above
    if tuple(source.size) != (w, h):
        raise InvalidInputError(
            f"the source structure is for a {source.width}x{source.height} image, the source image is {w}x{h}"
        )
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
    def __init__(
        self,
        img: np.ndarray,
        src_raster: np.ndarray,
        tgt_raster: np.ndarray,
        canvas: np.ndarray,
        content: np.ndarray,
        opts: RenderOptions,
        rng: np.random.Generator,
        regular: FragmentBank,
        junction: FragmentBank,
    ):
        import cv2

        self.opts, self.rng = opts, rng
        self.src = np.ascontiguousarray(img, np.float32)
        self.sh, self.sw = img.shape[:2]
        self.canvas, self.content = canvas, content
        self.h, self.w = canvas.shape[:2]
        self.var = max(float(self.src.reshape(-1, self.src.shape[2]).var(axis=0).sum()), 1.0)
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * OTHER_MARGIN + 1,) * 2)
        self.src_cracks = cv2.dilate(src_raster.astype(np.uint8), kernel).astype(bool)
        self.tgt_cracks = cv2.dilate(tgt_raster.astype(np.uint8), kernel).astype(bool)
        self.regular, self.junction = regular, junction
        self.warp = _Warp()
        ang = np.arange(RING_SAMPLES) * (2 * np.pi / RING_SAMPLES)
        ring = np.concatenate(
            [f * np.exp(1j * (ang + 0.5 * i * 2 * np.pi / RING_SAMPLES)) for i, f in enumerate(RING_RADII)]
        )
        self.ring_re, self.ring_im = np.ascontiguousarray(ring.real), np.ascontiguousarray(ring.imag)
        self.eps = 1e-3 * math.sqrt(self.var)
        self._no_pixels = np.zeros((1, 1, self.src.shape[2]), np.float32)
        self.coverage = np.zeros((self.h, self.w), bool)
        self.fragment_map = np.full((self.h, self.w), -1, np.int32)
        # the kernels' views: the canvas being painted, and the cracks no fragment may spoil
        self.layers = (self.canvas, self.content, self.coverage)
        self.cracks = (self.tgt_cracks, self.src_cracks)

    # -- §5.2: choose a source fragment -------------------------------------------------------

    def choose(self, g: Fragment) -> tuple[FragmentBank, int, int, complex] | None:
        bank = self.junction if (g.junction and self.junction.n) else self.regular
        if g.junction and bank is self.regular:
            return None  # no junction in the source: the child's own fragments make the joint
        target = (g.pos_re, g.pos_im, g.thick, g.weight)
        weights = (
            float(self.opts.omega_s),
            math.radians(self.opts.max_rotation),
            self.opts.omega_c * g.radius**2 / self.var,
        )
        args = (
            self.opts.shortlist,
            self.src,
            self.layers,
            self.tgt_cracks,
            (g.centre.real, g.centre.imag, g.radius),
            (self.ring_re, self.ring_im),
        )
        rows, total, rc, rs = K.select_candidates(bank.kernel, target, weights, g.radius + 2, *args)
        if len(rows) == 0:  # no source fragment fits this radius inside the photo: allow them all
            rows, total, rc, rs = K.select_candidates(bank.kernel, target, weights, -np.inf, *args)
        # rows come sorted by S; the c best by S + omega_c C, drawn with probability ~ 1 / cost
        pick = K.draw_candidate(total, self.opts.candidates, self.rng.random()) if len(rows) else -1
        if pick < 0:
            return None
        o, i = divmod(int(rows[pick]), bank.n)
        return bank, i, o, complex(rc[pick], rs[pick])

    # -- §5.3: compose it ---------------------------------------------------------------------

    def place(self, j: int, g: Fragment, bank: FragmentBank, i: int, o: int, rot: complex) -> bool:
        """Compose source fragment ``i`` (orientation ``o``, rotation ``rot``) into target
        fragment ``j``; False when it adds no pixel."""
        import cv2
        import maxflow

        f = bank.frags[i]
        fpos = bank.oriented[o][i]
        freal = bank.oriented_real[o][i]
        x0, y0, mapx, mapy = K.fragment_maps(
            (self.warp.green, self.warp.m),
            (g.centre.real, g.centre.imag, g.radius),
            (self.w, self.h),
            (g.pos_re, g.pos_im, g.real),
            (fpos.real, fpos.imag, freal),
            (f.centre.real, f.centre.imag, rot.real, rot.imag),
        )
        if mapx.size == 0:
            return False
        given: np.ndarray
        if self.opts.interpolation == "nearest":
            given = self._no_pixels
        else:
            given = cv2.remap(self.src, mapx, mapy, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT_101)
            given = np.clip(given.reshape(mapx.shape + (self.src.shape[2],)), 0.0, 255.0)
        clear = JUNCTION_CLEAR * g.radius if g.junction else 0.0  # a junction clears its centre
        new, take, free, ei, ej, cap, src_caps, sink_caps, boundary, fixed, n_take = K.compose_setup(
            self.src,
            (mapx, mapy),
            given,
            self.opts.interpolation != "nearest",
            (x0, y0),
            self.layers,
            self.cracks,
            (g.centre.real, g.centre.imag, g.radius, clear),
            g.own_cols,
            f.own_cols,
            (OWN_MARGIN, float(OTHER_MARGIN), self.eps),
        )
        if n_take == 0:
            return False
        newmask = take
        if len(free):
            # the seam (Kwatra et al. 2003) through the pixels the constraints leave free
            graph = maxflow.Graph[float](len(free), len(cap))
            nodes = graph.add_nodes(len(free))
            graph.add_edges(nodes[ei], nodes[ej], cap, cap)
            graph.add_grid_tedges(nodes, src_caps, sink_caps)
            graph.maxflow()
            newmask = take.copy()
            newmask.flat[free] = ~graph.get_grid_segments(nodes)
        # Poisson photometric correction: harmonic offset, seam difference on the boundary,
        # zero where the new pixels touch nothing placed before
        K.blend(
            (x0, y0),
            newmask,
            new,
            fixed,
            boundary,
            self.layers,
            self.fragment_map,
            j,
            (np.float32(POISSON_TOL), 4 * int(math.ceil(g.radius)) + 24, SEAM_SMOOTH),
        )
        return True


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
        image: the source photo, uint8 ``(H, W, 3)``, ``(H, W, 1)`` or grey ``(H, W)`` (uint16 is
            taken down to 8 bits).
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
        MemoryBudgetError: the fill's estimated memory exceeds its configured budget.
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
    regular, junction = source_banks(source, sw, sh, opts.fragment_spec)
    if regular.n == 0:
        raise InvalidInputError(
            "the source structure gives no fragment: its branches are too short "
            "or too close to the image border for fragments of radius "
            f">= {opts.min_radius:g} px"
        )
    plan = target_plan(target, opts.fragment_spec, junction.n > 0)
    labels = rasterize(target)
    src_raster = rasterize(source)

    fill_total = 0

    def fill_progress(done: int, total: int) -> None:
        nonlocal fill_total
        fill_total = total
        if progress is not None:
            progress(done, total + len(plan))

    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    if fill:
        from barkgen.synth import Budget, texture_by_numbers

        res = texture_by_numbers(
            img,
            src_raster.astype(np.uint8) * 255,
            labels.astype(np.uint8) * 255,
            label_weight=float(opts.fill_label_weight),
            config=opts.fill_config,
            budget=Budget(seed=int(seed), progress=fill_progress),
        )
        canvas = res.image.reshape(th, tw, -1).astype(np.float32)
        content = np.ones((th, tw), bool)
    else:
        canvas = np.zeros((th, tw, img.shape[2]), np.float32)
        content = np.zeros((th, tw), bool)
    timings["fill"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    rng = np.random.default_rng(int(seed))
    r = _Renderer(img, src_raster, labels, canvas, content, opts, rng, regular, junction)
    placed = 0
    for j, g in enumerate(plan):
        pick = r.choose(g) if g.visible else None
        if pick is not None and r.place(j, g, *pick):
            placed += 1
        if progress is not None:
            progress(fill_total + j + 1, fill_total + len(plan))
    timings["fragments"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start

    out = np.clip(np.rint(canvas), 0, 255).astype(np.uint8)
    if grey:
        out = out[:, :, 0]
    return RenderResult(
        image=out,
        labels=labels.astype(np.uint8) * 255,
        coverage=r.coverage,
        fragment_map=r.fragment_map,
        n_fragments=placed,
        n_source_fragments=regular.n + junction.n,
        seed=int(seed),
        timings=timings,
    )
