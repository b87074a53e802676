"""Structure synthesis: Wang tiles with content exchange and deformations (guingo2017 §4).

The structure layer and its masks are one multi-channel image (the masks "undergo the same
operations as P"). A tile set is built from it once per seed and deformation:

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
- Deformations (guingo2017 §4, Fig. 9-10): every sample (interior or edge) can be rotated by
  up to ``rotate`` degrees (optionally about the vertical only, keeping bark upright: 0° or
  180° plus the jitter) and zoomed by a factor in ``scale``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from barkgen.errors import InvalidInputError


@dataclass(frozen=True)
class Deformation:
    """Deformations of the structure's samples (guingo2017 §4).

    Attributes:
        rotate: largest rotation of a sample in degrees (0: none; 180: any angle).
        scale: ``(min, max)`` zoom of a sample (output px per exemplar px).
        keep_vertical: rotate only about the upright (0° or 180° plus up to ``rotate``
            degrees), for bark whose furrows run vertically.
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


def _sources(layers: np.ndarray, rng: np.random.Generator, deformation: Deformation,
             count: int = 8) -> list[np.ndarray]:
    """The exemplar layers as the tiles see them: itself, or ``count`` copies each rotated and
    zoomed by one random draw of the deformation (resampled once, bilinear, borders reflected)."""
    import cv2

    if not deformation.active:
        return [layers]
    h, w, c = layers.shape
    out = []
    for _ in range(count):
        angle = rng.uniform(-deformation.rotate, deformation.rotate) if deformation.rotate > 0 else 0.0
        if deformation.keep_vertical and rng.random() < 0.5:
            angle += 180.0
        zoom = rng.uniform(*deformation.scale)
        cos, sin = abs(np.cos(np.radians(angle))), abs(np.sin(np.radians(angle)))
        out_w = int(np.ceil((w * cos + h * sin) * zoom))
        out_h = int(np.ceil((w * sin + h * cos) * zoom))
        matrix = cv2.getRotationMatrix2D((w / 2, h / 2), angle, zoom)
        matrix[:, 2] += np.array([out_w / 2 - w / 2, out_h / 2 - h / 2])
        warped = np.empty((out_h, out_w, c), np.float32)
        for start in range(0, c, 4):  # OpenCV warps at most 4 channels at a time
            chunk = np.ascontiguousarray(layers[:, :, start:start + 4])
            res = cv2.warpAffine(chunk, matrix, (out_w, out_h), flags=cv2.INTER_LINEAR,
                                 borderMode=cv2.BORDER_REFLECT)
            warped[:, :, start:start + 4] = res.reshape(out_h, out_w, -1)
        out.append(warped)
    return out


def _random_sample(sources: list[np.ndarray], size: int, rng: np.random.Generator) -> np.ndarray:
    src = sources[int(rng.integers(len(sources)))]
    y = int(rng.integers(src.shape[0] - size + 1))
    x = int(rng.integers(src.shape[1] - size + 1))
    return src[y:y + size, x:x + size].copy()


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
            mask = (cv2.resize(mask, (size // step, size // step), interpolation=cv2.INTER_AREA) > 0.5
                    ).astype(np.float32)
        n = float(mask.sum())
        images, energies, contrasts = [], [], []
        for src in sources:
            image = np.ascontiguousarray(src[:, :, :3])
            if step > 1:
                image = cv2.resize(image, (src.shape[1] // step, src.shape[0] // step),
                                   interpolation=cv2.INTER_AREA)
            total = cv2.matchTemplate(image, mask, cv2.TM_CCORR)
            energy = cv2.matchTemplate(image * image, mask, cv2.TM_CCORR)
            images.append(image)
            energies.append(energy)
            contrasts.append(np.maximum(energy - total * total / n, 0.0) + 1e-3 * n)
        return cls(sources, size, step, mask, images, energies, contrasts)


def _matching_samples(index: _SampleIndex, frame: np.ndarray, count: int,
                      rng: np.random.Generator) -> list[np.ndarray]:
    """``count`` samples whose content agrees best with ``frame`` on the ring (the edge pieces
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
            found.append((float(cost[y, x]), i, min(int(y) * step, src.shape[0] - size),
                          min(int(x) * step, src.shape[1] - size)))
            cost[max(0, y - spacing + 1):y + spacing, max(0, x - spacing + 1):x + spacing] = np.inf
    found.sort()
    best = found[:2 * count]
    picks = rng.choice(len(best), size=min(count, len(best)), replace=False)
    return [index.sources[best[i][1]][best[i][2]:best[i][2] + size, best[i][3]:best[i][3] + size].copy()
            for i in sorted(picks)]


def _graph_cut(canvas: np.ndarray, piece: np.ndarray, keep: np.ndarray, take: np.ndarray) -> np.ndarray:
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
    graph.add_grid_edges(nodes, weights=right, structure=np.array([[0, 0, 0], [0, 0, 1], [0, 0, 0]]),
                         symmetric=True)
    graph.add_grid_edges(nodes, weights=down, structure=np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0]]),
                         symmetric=True)
    big = 1e9
    graph.add_grid_tedges(nodes, np.where(keep, big, 0.0), np.where(take, big, 0.0))
    flow = graph.maxflow()
    return graph.get_grid_segments(nodes), float(flow)


def _edge_geometry(size: int, band: int):
    """Per edge (N, E, S, W): its triangle of the tile and the strip forced to it."""
    y, x = np.mgrid[0:size, 0:size]
    dist = {"N": y, "S": size - 1 - y, "W": x, "E": size - 1 - x}
    out = {}
    for name, d in dist.items():
        others = np.minimum.reduce([v for k, v in dist.items() if k != name])
        out[name] = (d <= others, d < band)
    return out


def build_tiles(layers: np.ndarray, rng: np.random.Generator, *, size: int, colours: int = 3,
                variants: int = 4, deformation: Deformation = Deformation()) -> np.ndarray:
    """The Wang tile set with exchanged contents: ``(colours**4 * variants, size, size, C)``
    float32, indexed ``(((n * colours + e) * colours + s) * colours + w) * variants + v``."""
    if size % 2 or size < 8:
        raise InvalidInputError(f"tile size must be even and at least 8, not {size}")
    if colours < 1 or variants < 1:
        raise InvalidInputError("tiles need at least one edge colour and one variant")
    sources = _sources(layers, rng, deformation)
    if min(min(src.shape[:2]) for src in sources) < size:
        raise InvalidInputError(f"tiles of {size} px need an exemplar of at least {size} px")
    half = size // 2
    horizontal = [_random_sample(sources, size, rng) for _ in range(colours)]
    vertical = [_random_sample(sources, size, rng) for _ in range(colours)]
    geometry = _edge_geometry(size, band=2)
    y, x = np.mgrid[0:size, 0:size]
    edge_distance = np.minimum.reduce([y, x, size - 1 - y, size - 1 - x])
    ring = edge_distance < size // 4  # where the edge pieces are known before the interior
    core = edge_distance >= size // 6  # the exchanged content: all but a band along the edges
    index_of_samples = _SampleIndex.build(sources, ring)
    n_tiles = colours ** 4 * variants
    tiles = np.empty((n_tiles, size, size, layers.shape[2]), np.float32)
    index = 0
    for n in range(colours):
        for e in range(colours):
            for s in range(colours):
                for w in range(colours):
                    pieces = {
                        "N": np.roll(horizontal[n], -half, axis=0),  # the sample's lower half on top
                        "S": np.roll(horizontal[s], half, axis=0),
                        "W": np.roll(vertical[w], -half, axis=1),
                        "E": np.roll(vertical[e], half, axis=1),
                    }
                    frame = np.zeros_like(pieces["N"])
                    for name, piece in pieces.items():
                        frame[geometry[name][0]] = piece[geometry[name][0]]
                    made = []
                    for canvas in _matching_samples(index_of_samples, frame, 2 * variants, rng):
                        seam = 0.0
                        for name in ("N", "S", "W", "E"):
                            triangle, strip = geometry[name]
                            take, cost = _graph_cut(canvas, pieces[name], keep=~triangle | core,
                                                    take=strip & triangle)
                            canvas[take] = pieces[name][take]
                            seam += cost
                        grad = np.abs(np.diff(canvas[:, :, :3], axis=0)).mean() + np.abs(
                            np.diff(canvas[:, :, :3], axis=1)).mean()
                        made.append((seam / (grad + 1e-6), len(made), canvas))  # relative seams
                    made.sort(key=lambda item: item[:2])  # content exchange: the best-fitting ones
                    for _, _, canvas in made[:variants]:
                        tiles[index] = canvas
                        index += 1
    return tiles
