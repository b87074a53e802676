"""Structure synthesis: Wang tiles with content exchange and deformations (guingo2017 §4).

The structure layer and its masks are one multi-channel image (the masks "undergo the same
operations as P"). A tile set is built from it once per seed:

- Wang tiles (Cohen et al. 2003): ``colours`` edge colours per direction; each colour is a
  sample of the exemplar straddling the edge, so the two tiles on either side of an edge of
  that colour continue each other. A tile is composed of the four edge triangles of its
  colours.
- Content exchange (Vanhoey et al. 2013, mono-scale): every tile exists in ``variants``
  versions whose interiors are different samples of the exemplar, each chosen, as image
  quilting chooses its patches, among the samples that agree best with the tile's edge
  pieces on a ring along its border; the edge pieces are pasted over the interior along
  minimum-cost graph cuts (Kwatra et al. 2003, PyMaxflow) within a band along the edges, so
  the exchanged content fills most of the tile and the seams follow the texture. Of twice
  as many candidates, the ``variants`` with the cheapest seams are kept. Which version a
  cell uses is a hash of its position.
- Seam blending (sibbing2010 §5, Pérez et al. 2003): a graph cut across a structure that
  runs over it (willow's vertical furrows over a horizontal tile edge) still leaves a step;
  the structure of each tile is re-solved in the gradient domain (screened, so only the
  few pixels around a seam change) with its border fixed, so the tiles still join exactly.
- Deformations (guingo2017 §4, Fig. 9-10) are not baked into the tile set: the window
  turns and zooms each cell's exchanged content as it is made (per patch, any angle and
  zoom, plus rotation and zoom fields), reading it anew from the exemplar about its sample's
  centre (:class:`TileSet` keeps the centres and each content's weight); the Wang edges
  stay, so cells still join.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from barkgen.errors import InvalidInputError


@dataclass(frozen=True)
class Deformation:
    """Deformations of the structure's samples (guingo2017 §4), per patch and on the fly.

    Every tile cell of the window draws its own rotation and zoom (hashes of the cell, so
    any angle in the range, not a few fixed ones) and turns its exchanged content by them;
    the Wang edges are not turned, so cells still join.

    Parameters
    ----------
    rotate : float, default 0.0
        Largest rotation of a cell's content in degrees (0: none; 180: any angle).
    scale : (float, float), default (1.0, 1.0)
        ``(min, max)`` zoom of a cell's content (output px per exemplar px), 0.25 <= min <= max <= 4.
    keep_vertical : bool, default False
        Rotate only about the upright (0° or 180° plus up to ``rotate`` degrees), for bark whose
        furrows run vertically.

    Attributes
    ----------
    active : bool
        Any deformation at all.

    Raises
    ------
    InvalidInputError
        Angles or scales out of range.

    References
    ----------
    .. [1] guingo2017, §4 (deformations: the structure moves, the noise keeps its scale).

    Examples
    --------
    >>> Deformation(rotate=15, scale=(1, 1.5)).active
    True
    """

    rotate: float = 0.0
    scale: tuple[float, float] = (1.0, 1.0)
    keep_vertical: bool = False

    def __post_init__(self) -> None:
        lo, hi = (float(v) for v in self.scale)
        if not (0 <= self.rotate <= 180):
            raise InvalidInputError(f"rotation must be between 0 and 180 degrees, not {self.rotate}")
        if not (0.25 <= lo <= hi <= 4):
            raise InvalidInputError(f"scale must be MIN,MAX with 0.25 <= MIN <= MAX <= 4, not {lo},{hi}")
        object.__setattr__(self, "scale", (lo, hi))

    @property
    def active(self) -> bool:
        return self.rotate > 0 or self.scale != (1.0, 1.0) or self.keep_vertical


def default_tile_size(shape: tuple[int, int]) -> int:
    """A tile of about a quarter of the exemplar's shorter side (a multiple of 8, at least 16):
    large enough to hold whole structures (with a fifth, willow's furrows were cut often
    enough to add about 10 % of energy at 8-16 px), small enough that no tile's content is a
    large verbatim copy."""
    return int(max(16, 8 * round(min(shape) / 32)))


def _random_sample(sources: list[np.ndarray], size: int, rng: np.random.Generator) -> np.ndarray:
    src = sources[int(rng.integers(len(sources)))]
    y = int(rng.integers(src.shape[0] - size + 1))
    x = int(rng.integers(src.shape[1] - size + 1))
    return src[y : y + size, x : x + size].copy()


@dataclass
class _SampleIndex:
    """The sources as :func:`_matching_samples` searches them, prepared once per tile set: the
    ring is the same for every tile, so each source's sums over it are too."""

    sources: list[np.ndarray]
    size: int
    step: int  # large tiles are matched at half resolution (4x fewer sums)
    mask: np.ndarray  # the ring, at matching resolution, 3 channels
    images: list[np.ndarray]  # the sources' colours at matching resolution
    ring_energy: list[np.ndarray]  # sum over the ring of image**2, per position
    contrast: list[np.ndarray]  # the image's variance-like contrast over the ring, per position

    @classmethod
    def build(cls, sources: list[np.ndarray], ring: np.ndarray) -> _SampleIndex:
        import cv2

        size = ring.shape[0]
        step = 2 if size >= 64 else 1
        mask = np.repeat(ring[:, :, None], 3, axis=2).astype(np.float32)
        if step > 1:
            mask = (cv2.resize(mask, (size // step, size // step), interpolation=cv2.INTER_AREA) > 0.5).astype(
                np.float32
            )
        n = float(mask.sum())
        images, energies, contrasts = [], [], []
        for src in sources:
            image = np.ascontiguousarray(src[:, :, :3])
            if step > 1:
                image = cv2.resize(image, (src.shape[1] // step, src.shape[0] // step), interpolation=cv2.INTER_AREA)
            total = cv2.matchTemplate(image, mask, cv2.TM_CCORR)
            energy = cv2.matchTemplate(image * image, mask, cv2.TM_CCORR)
            images.append(image)
            energies.append(energy)
            contrasts.append(np.maximum(energy - total * total / n, 0.0) + 1e-3 * n)
        return cls(sources, size, step, mask, images, energies, contrasts)


def _matching_samples(
    index: _SampleIndex, frame: np.ndarray, count: int, rng: np.random.Generator
) -> list[tuple[np.ndarray, tuple[int, int]]]:
    """``count`` samples (and their top-left corners in their source) whose content agrees best with ``frame`` on the ring (the edge pieces
    already fixed around a tile), as image quilting chooses its patches (Efros & Freeman
    2001), the squared difference taken relative to the candidate's contrast on the ring: the
    best matches of each source at least half a tile apart, then a random choice among the
    ``2 count`` best, for variety. The masked squared difference is expanded as
    ``sum(m I^2) - 2 sum(m T I) + sum(m T^2)``: one correlation per source and tile."""
    import cv2

    size, step = index.size, index.step
    template = np.ascontiguousarray(frame[:, :, :3])
    if step > 1:
        template = cv2.resize(template, (size // step, size // step), interpolation=cv2.INTER_AREA)
    weighted = index.mask * template
    constant = float((weighted * template).sum())
    spacing = max(1, size // (2 * step))
    found = []
    for i, image in enumerate(index.images):
        cross = cv2.matchTemplate(image, weighted, cv2.TM_CCORR)
        # relative to the candidate's own contrast on the ring: plain squared differences
        # favour flat samples, and a tile set of flat samples is blurrier than the exemplar
        cost = np.maximum(index.ring_energy[i] - 2.0 * cross + constant, 0.0) / index.contrast[i]
        src = index.sources[i]
        for _ in range(2 * count):  # the best matches, each suppressing its neighbourhood
            y, x = np.unravel_index(int(np.argmin(cost)), cost.shape)
            if not np.isfinite(cost[y, x]):
                break
            found.append(
                (float(cost[y, x]), i, min(int(y) * step, src.shape[0] - size), min(int(x) * step, src.shape[1] - size))
            )
            cost[max(0, y - spacing + 1) : y + spacing, max(0, x - spacing + 1) : x + spacing] = np.inf
    found.sort()
    best = found[: 2 * count]
    picks = rng.choice(len(best), size=min(count, len(best)), replace=False)
    return [
        (index.sources[best[i][1]][best[i][2] : best[i][2] + size, best[i][3] : best[i][3] + size].copy(), best[i][2:])
        for i in sorted(picks)
    ]


def _graph_cut(canvas: np.ndarray, piece: np.ndarray, keep: np.ndarray, take: np.ndarray) -> tuple[np.ndarray, float]:
    """Boolean mask of the pixels to take from ``piece`` so that the seam between ``canvas``
    and ``piece`` has the least colour difference (Kwatra et al. 2003): ``keep`` pixels stay
    on the canvas, ``take`` pixels come from the piece, the others are free. Also returns the
    seam's cost."""
    import maxflow

    diff = np.sqrt(((canvas - piece) ** 2).sum(axis=2)) + 1e-3
    h, w = diff.shape
    graph = maxflow.Graph[float]()
    nodes = graph.add_grid_nodes((h, w))
    right = np.zeros((h, w))
    right[:, :-1] = diff[:, :-1] + diff[:, 1:]
    down = np.zeros((h, w))
    down[:-1, :] = diff[:-1, :] + diff[1:, :]
    graph.add_grid_edges(nodes, weights=right, structure=np.array([[0, 0, 0], [0, 0, 1], [0, 0, 0]]), symmetric=True)
    graph.add_grid_edges(nodes, weights=down, structure=np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0]]), symmetric=True)
    big = 1e9
    graph.add_grid_tedges(nodes, np.where(keep, big, 0.0), np.where(take, big, 0.0))
    flow = graph.maxflow()
    return graph.get_grid_segments(nodes), float(flow)


EDGES = ("N", "S", "W", "E")
#: how far (px) the blend spreads a seam's step: the screening length of the Poisson solve.
#: Unscreened, the corrections shift whole tiles' colours away from the exemplar's (texeval
#: coherence of willow and lichen 2.94x and 2.73x the core engine's, 2.80x and 2.47x without
#: blending); spread over 6-8 px the steps are gone just as well (willow's spectrum_dist 1.69x
#: the engine's without blending, 1.34x unscreened, 1.38-1.40x) and coherence stays put.
SEAM_SPREAD = 6.0


def _bounding_box(mask: np.ndarray, margin: int) -> tuple[slice, slice]:
    """The rows and columns holding ``mask``'s pixels, ``margin`` px wider (within the image)."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    return (
        slice(max(0, rows[0] - margin), rows[-1] + margin + 1),
        slice(max(0, cols[0] - margin), cols[-1] + margin + 1),
    )


def _edge_geometry(size: int, band: int):
    """Per edge (N, E, S, W): its triangle of the tile and the strip forced to it."""
    y, x = np.mgrid[0:size, 0:size]
    dist = {"N": y, "S": size - 1 - y, "W": x, "E": size - 1 - x}
    out = {}
    for name, d in dist.items():
        others = np.minimum.reduce([v for k, v in dist.items() if k != name])
        out[name] = (d <= others, d < band)
    return out


def _seam_guidance(composite: np.ndarray, stack: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """The divergence of the gradient field a composed tile should have: between two pixels
    of one source, that source's gradient (the composite's own); across a seam, the mean of
    the two sources' gradients (each source is a whole sample, so both are known there).
    ``composite`` is the tile ``(size, size, 3)``, ``stack`` its sources ``(S, size, size,
    3)`` and ``origin`` the source of each pixel."""
    div = np.zeros(composite.shape, np.float32)
    for axis in (0, 1):
        lo = (slice(None, -1), slice(None)) if axis == 0 else (slice(None), slice(None, -1))
        hi = (slice(1, None), slice(None)) if axis == 0 else (slice(None), slice(1, None))
        step = composite[lo] - composite[hi]
        a, b = origin[lo], origin[hi]
        ys, xs = np.nonzero(a != b)  # the pairs across a seam
        y1, x1 = (ys + 1, xs) if axis == 0 else (ys, xs + 1)
        sa, sb = a[ys, xs], b[ys, xs]
        step[ys, xs] = 0.5 * ((stack[sa, ys, xs] - stack[sa, y1, x1]) + (stack[sb, ys, xs] - stack[sb, y1, x1]))
        div[lo] += step
        div[hi] -= step
    return div


def poisson_blend(images: np.ndarray, guidance: np.ndarray, spread: float | None = None) -> np.ndarray:
    """Gradient-domain blending (Pérez et al. 2003) of a batch ``(B, H, W, C)`` at once: solve
    ``(1/spread**2 - laplacian) u = guidance + images/spread**2`` inside each image with its
    one-pixel border fixed to the image's own values. ``guidance`` is the divergence of the
    wanted gradients (``-laplacian`` of the wanted image); the screening term keeps ``u`` near
    ``images`` beyond about ``spread`` px of a seam (0: plain Poisson). The Dirichlet
    Laplacian is diagonal in the type-I discrete sine basis, so the solve is two transforms
    and a division (float32, all cores: 5x faster than float64 on one, same figures)."""
    from scipy.fft import dstn, idstn

    spread = SEAM_SPREAD if spread is None else spread
    h, w = images.shape[1] - 2, images.shape[2] - 2
    rhs = guidance[:, 1:-1, 1:-1].astype(np.float32)
    rhs[:, 0] += images[:, 0, 1:-1]  # the fixed border's share of each neighbour sum
    rhs[:, -1] += images[:, -1, 1:-1]
    rhs[:, :, 0] += images[:, 1:-1, 0]
    rhs[:, :, -1] += images[:, 1:-1, -1]
    ky = 2.0 - 2.0 * np.cos(np.pi * np.arange(1, h + 1) / (h + 1))
    kx = 2.0 - 2.0 * np.cos(np.pi * np.arange(1, w + 1) / (w + 1))
    screen = 1.0 / spread**2 if spread else 0.0
    rhs += screen * images[:, 1:-1, 1:-1]
    eigen = (ky[:, None, None] + kx[None, :, None] + screen).astype(np.float32)
    spectrum = dstn(rhs, type=1, axes=(1, 2), workers=-1) / eigen
    out = images.copy()
    out[:, 1:-1, 1:-1] = idstn(spectrum, type=1, axes=(1, 2), workers=-1)
    return out


@dataclass
class TileSet:
    """A Wang tile set with exchanged contents, and what the window needs to deform them.

    Attributes
    ----------
    tiles : ndarray of float32, shape (colours**4 * variants, size, size, C)
        Indexed ``(((n * colours + e) * colours + s) * colours + w) * variants + v``.
    centres : ndarray of float64, shape (n_tiles, 2)
        Per tile, the exemplar position (row, column) of its exchanged content's centre.
    interior : ndarray of float32, shape (n_tiles, size, size)
        Per tile, the exchanged content's weight: 1 where the graph cuts kept it, 0 on the
        Wang edge pieces and the tile's border, feathered over a few pixels between.
    """

    tiles: np.ndarray
    centres: np.ndarray
    interior: np.ndarray


#: how far (px) the exchanged content's weight is feathered across its graph cuts, for the
#: window's deformed content to fade into the undeformed Wang edges
INTERIOR_FEATHER = 1.5


def _interior_weight(origin: np.ndarray, edge_distance: np.ndarray) -> np.ndarray:
    """The exchanged content's weight in one tile (see :class:`TileSet`): ``origin == 0``
    feathered, and 0 on the tile's border so that neighbouring cells still join exactly."""
    from scipy.ndimage import gaussian_filter

    soft = gaussian_filter((origin == 0).astype(np.float32), INTERIOR_FEATHER, mode="nearest")
    return soft * np.clip((edge_distance - 1) / 3.0, 0.0, 1.0).astype(np.float32)


def build_tiles(
    layers: np.ndarray,
    rng: np.random.Generator,
    *,
    size: int,
    colours: int = 3,
    variants: int = 4,
    blend: bool = True,
) -> TileSet:
    """The Wang tile set with exchanged contents (see :class:`TileSet`). With ``blend``, the
    structure's seams are blended in the gradient domain (the masks' channels are left as
    cut). Deformations are not baked in: the window applies them per patch."""
    if size % 2 or size < 8:
        raise InvalidInputError(f"tile size must be even and at least 8, not {size}")
    if colours < 1 or variants < 1:
        raise InvalidInputError("tiles need at least one edge colour and one variant")
    if min(layers.shape[:2]) < size:
        raise InvalidInputError(f"tiles of {size} px need an exemplar of at least {size} px")
    sources = [layers]
    half = size // 2
    horizontal = [_random_sample(sources, size, rng) for _ in range(colours)]
    vertical = [_random_sample(sources, size, rng) for _ in range(colours)]
    geometry = _edge_geometry(size, band=2)
    y, x = np.mgrid[0:size, 0:size]
    edge_distance = np.minimum.reduce([y, x, size - 1 - y, size - 1 - x])
    ring = edge_distance < size // 4  # where the edge pieces are known before the interior
    core = edge_distance >= size // 6  # the exchanged content: all but a band along the edges
    index_of_samples = _SampleIndex.build(sources, ring)
    # each cut only needs the pixels it may move and their neighbours: the same cut on a
    # graph about a sixth of the tile's size
    boxes = {name: _bounding_box(triangle & ~core, margin=1) for name, (triangle, _) in geometry.items()}
    n_tiles = colours**4 * variants
    tiles = np.empty((n_tiles, size, size, layers.shape[2]), np.float32)
    centres = np.empty((n_tiles, 2), np.float64)
    interior = np.empty((n_tiles, size, size), np.float32)
    guidance = np.empty((n_tiles, size, size, 3), np.float32) if blend else None
    index = 0
    for n, e, s, w in itertools.product(range(colours), repeat=4):  # edge colours N, E, S, W
        pieces = {
            "N": np.roll(horizontal[n], -half, axis=0),  # the sample's lower half on top
            "S": np.roll(horizontal[s], half, axis=0),
            "W": np.roll(vertical[w], -half, axis=1),
            "E": np.roll(vertical[e], half, axis=1),
        }
        frame = np.zeros_like(pieces["N"])
        for name, piece in pieces.items():
            frame[geometry[name][0]] = piece[geometry[name][0]]
        made: list[tuple[float, int, np.ndarray, list[np.ndarray] | None, np.ndarray, tuple[int, int]]] = []
        for canvas, corner in _matching_samples(index_of_samples, frame, 2 * variants, rng):
            seam = 0.0
            stack = (
                [canvas[:, :, :3].copy()] + [pieces[name][:, :, :3] for name in EDGES] if blend else None
            )  # the sources the blend's guidance reads
            origin = np.zeros((size, size), np.intp)  # which of ``stack`` each pixel is
            for number, name in enumerate(EDGES, start=1):
                triangle, strip = geometry[name]
                box = boxes[name]
                take = np.zeros((size, size), bool)
                take[box], cost = _graph_cut(
                    canvas[box], pieces[name][box], keep=(~triangle | core)[box], take=(strip & triangle)[box]
                )
                canvas[take] = pieces[name][take]
                origin[take] = number
                seam += cost
            grad = np.abs(np.diff(canvas[:, :, :3], axis=0)).mean() + np.abs(np.diff(canvas[:, :, :3], axis=1)).mean()
            made.append((seam / (grad + 1e-6), len(made), canvas, stack, origin, corner))  # relative seams
        made.sort(key=lambda item: item[:2])  # content exchange: the best-fitting ones
        for _, _, canvas, stack, origin, corner in made[:variants]:
            tiles[index] = canvas
            centres[index] = (corner[0] + (size - 1) / 2, corner[1] + (size - 1) / 2)
            interior[index] = _interior_weight(origin, edge_distance)
            if blend:
                assert guidance is not None and stack is not None  # both made when blending
                guidance[index] = _seam_guidance(canvas[:, :, :3], np.stack(stack), origin)
            index += 1
    if blend:
        assert guidance is not None  # made when blending
        for start in range(0, n_tiles, 64):  # bounded memory for large tiles
            part = slice(start, start + 64)
            tiles[part, :, :, :3] = poisson_blend(tiles[part, :, :, :3], guidance[part])
    return TileSet(tiles, centres, interior)
