"""Example-based texture synthesis with the k-coherence discrete solver.

Implements the texture-optimization solver of Han et al. 2006 as described in mazzolini2012 §4.1
(k-coherence analysis and synthesis phases, multi-resolution) and laitoch2018 §3.3 (image of
references, forward-shifted neighbourhoods, exact reference up-sampling, M-step on a sparse subset,
E-step, extra channels), with these additions:

* appearance space (Lefebvre & Hoppe 2006): neighbourhoods are compared as PCA vectors;
* several neighbourhood sizes per level, largest first (Kwatra et al. 2005);
* an occurrence penalty (Kaspar et al. 2015) so every exemplar region is used about equally,
  which answers the "same patterns repeated" defect of laitoch2018 §4.1;
* a coherence bias (Ashikhmin 2001) that keeps exemplar patches whole;
* toroidal neighbourhoods at every level for tileable output;
* an exemplar that tiles itself is a torus too (:mod:`barkgen.synth.edges`); along an edge
  that does not wrap, the seams where pieces end are cut like the others, so they do not
  follow the edge's line;
* seam optimisation: local moves and graph cuts of straight seams (Kwatra et al. 2003,
  :mod:`barkgen.synth.cuts`), so the borders between pieces follow low-error paths;
* the output is an image of references, resolved to exemplar pixels only at the end, so nothing
  is ever averaged: the result is exactly as sharp as the exemplar (laitoch2018 §4.2's blur).
"""

from __future__ import annotations

import hashlib
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import cv2
import numpy as np

from barkgen._shared.arrays import ProgressCallback, as_hw_c, as_uint8, unit_float
from barkgen._shared.checks import parse_output_shape
from barkgen.color import rgb_to_lab
from barkgen.errors import InvalidInputError, MemoryBudgetError
from barkgen.nnf import (
    NeighbourhoodProjection,
    k_coherence_sets,
    k_coherence_sets_from_parent,
    neighbourhood_pca,
    project_neighbourhoods,
)
from barkgen.pyramid import count_levels, gaussian_pyramid, level_shape
from barkgen.synth.config import SynthesisConfig
from barkgen.synth.edges import resolve_exemplar_wrap
from barkgen.synth.gradient import resolve_continuous

MIN_EXEMPLAR_SIDE = 16
#: exemplar levels with at most this many pixels get an exact k-NN search (faiss); larger
#: ones refine their parent's k-coherence sets
DIRECT_SEARCH_LIMIT = 2048


@dataclass
class SynthesisResult:
    """What :func:`synthesize` returns.

    Attributes:
        image: the synthesized texture, same dtype and channel count as the exemplar.
        references: ``(H, W, 2)`` int32, the exemplar (row, col) each output pixel copies.
        extras: each extra map of the exemplar through the same references, in the gradient
            domain (:func:`barkgen.synth.gradient.resolve_continuous`: no cliffs where copied
            pieces meet; :func:`apply_references` gives the exact copy).
        exemplar_shape: ``(h, w)`` of the exemplar the references point into.
        exemplar_wrap: ``(rows, columns)``: the exemplar was used as a torus along that axis
            (a reference may step from its last row to its first inside one piece).
        seed, tile: as requested.
        timings: seconds spent in ``analysis`` and ``synthesis``.
    """

    image: np.ndarray
    references: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    exemplar_shape: tuple[int, int] = (0, 0)
    exemplar_wrap: tuple[bool, bool] = (False, False)
    seed: int = 0
    tile: bool = False
    timings: dict[str, float] = field(default_factory=dict)


@dataclass
class LevelAnalysis:
    """The k-coherence analysis of one exemplar pyramid level (mazzolini2012 §4.1.2)."""

    height: int
    width: int
    features: np.ndarray  # (h * w, C) float32 per-pixel matching features
    coords_y: np.ndarray  # (h * w,) int32 row of each flat index (division-free decoding)
    coords_x: np.ndarray  # (h * w,) int32 column of each flat index
    projections: dict[int, NeighbourhoodProjection]
    kernel_weights: dict[int, np.ndarray]  # projection weights laid out [dy, dx, c, d] for m_step
    ksets: np.ndarray  # (h * w, k) int32
    scale: float  # typical squared appearance distance to the nearest distinct neighbour
    wrap: tuple[bool, bool] = (False, False)  # the exemplar tiles along (rows, columns)


# --------------------------------------------------------------------------------------------
# validation and set-up


def matching_features(exemplar: np.ndarray, extras: Mapping[str, np.ndarray] | None,
                      extra_weight: float) -> np.ndarray:
    """Per-pixel features used for matching: CIELAB (L in 0..100) or L alone for grey images,
    plus each extra channel scaled to 0..100 and weighted (laitoch2018 §3.3.1, extra channels).
    """
    ex = unit_float(as_hw_c("exemplar", exemplar))
    if ex.shape[2] >= 3:
        feats = [rgb_to_lab(ex[:, :, :3])]
    else:
        feats = [ex[:, :, :1] * 100.0]
    for name, arr in (extras or {}).items():
        e = unit_float(as_hw_c(f"extra map {name!r}", arr))
        feats.append(e * (100.0 * extra_weight / np.sqrt(e.shape[2])))
    return np.ascontiguousarray(np.concatenate(feats, axis=2), dtype=np.float32)


def estimate_memory(exemplar_shape: tuple[int, int], output_shape: tuple[int, int],
                    channels: int, bytes_per_channel: int, feature_channels: int,
                    config: SynthesisConfig) -> int:
    """Estimated peak memory of a synthesis, in bytes (made before any work starts)."""
    n_ex = exemplar_shape[0] * exemplar_shape[1]
    n_out = output_shape[0] * output_shape[1]
    sizes = {s for sched in (config.schedule_coarsest, config.schedule_middle,
                             config.schedule_finest) for s, _ in sched}
    per_ex = (feature_channels * 4 * 3 + config.pca_components * 4 * len(sizes) * 1.4
              + config.k * 4 * 1.4 + 8)
    per_out = 100 + 3 * channels * bytes_per_channel
    search = min(n_ex, 262_144) * max(4 * config.k + 8, 32) * 12
    return int(200e6 + n_ex * per_ex + n_out * per_out + search)


# --------------------------------------------------------------------------------------------
# analysis


def _schedule_sizes(config: SynthesisConfig, level: int, n_levels: int) -> list[int]:
    return sorted({s for s, _ in config.schedule_for(level, n_levels)}, reverse=True)


def analyse_exemplar(features: np.ndarray, n_levels: int, config: SynthesisConfig,
                     progress: Callable[[], None] | None = None,
                     wrap: tuple[bool, bool] = (False, False)) -> list[LevelAnalysis]:
    """k-coherence analysis phase on every pyramid level of the exemplar features; ``wrap``
    ``(rows, columns)``: the exemplar tiles along that axis (:mod:`barkgen.synth.edges`), so its
    pyramid and neighbourhoods run round its edges."""
    wrap = (bool(wrap[0]), bool(wrap[1]))
    pyramid = gaussian_pyramid(features, n_levels, wrap)
    levels: list[LevelAnalysis | None] = [None] * n_levels
    parent: LevelAnalysis | None = None
    for lvl in reversed(range(n_levels)):
        img = pyramid[lvl]
        h, w, c = img.shape
        projections = {s: neighbourhood_pca(img, s, config.pca_components, wrap=wrap)
                       for s in _schedule_sizes(config, lvl, n_levels)}
        largest = projections[max(projections)]
        if parent is None or h * w <= DIRECT_SEARCH_LIMIT:
            ksets, scale = k_coherence_sets(largest.features, w, config.k, radius=2)
        else:
            ksets, scale = k_coherence_sets_from_parent(
                parent.ksets, (parent.height, parent.width), largest.features, (h, w),
                config.k, radius=2)
        cy, cx = np.divmod(np.arange(h * w, dtype=np.int32), np.int32(w))
        kernel_weights = {size: np.ascontiguousarray(p.weights.transpose(1, 2, 3, 0))
                          for size, p in projections.items()}
        parent = LevelAnalysis(h, w, img.reshape(h * w, c), cy, cx, projections, kernel_weights,
                               ksets, scale, wrap)
        levels[lvl] = parent
        if progress:
            progress()
    return levels  # type: ignore[return-value]


class AnalysisCache:
    """Exemplar analyses (:func:`analyse_exemplar`) kept for reuse.

    The k-coherence analysis phase (mazzolini2012 §4.1.2) depends on the exemplar alone, not on
    the seed, so one analysis serves every variant synthesized from one photo. Entries are keyed
    by what the analysis depends on (the matching features' bytes, the pyramid depth and the
    config's analysis fields), so a cache can never hand back the analysis of other inputs: a
    changed photo, label map or option is a miss and is analysed afresh. Plain data, so it can
    be pickled and shipped to other processes (:mod:`barkgen.batch`).
    """

    def __init__(self) -> None:
        self._entries: dict[str, list[LevelAnalysis]] = {}

    @staticmethod
    def key(features: np.ndarray, n_levels: int, config: SynthesisConfig,
            wrap: tuple[bool, bool] = (False, False)) -> str:
        digest = hashlib.blake2b(digest_size=20)
        key = (features.shape, features.dtype.str, int(n_levels), config.k, config.pca_components,
               config.schedule_coarsest, config.schedule_middle, config.schedule_finest)
        if any(wrap):  # (the key of an exemplar that does not wrap is as it always was)
            key += (bool(wrap[0]), bool(wrap[1]))
        digest.update(repr(key).encode())
        digest.update(memoryview(np.ascontiguousarray(features)).cast("B"))
        return digest.hexdigest()

    def analyse(self, features: np.ndarray, n_levels: int, config: SynthesisConfig,
                progress: Callable[[], None] | None = None,
                wrap: tuple[bool, bool] = (False, False)) -> list[LevelAnalysis]:
        """:func:`analyse_exemplar`, computed on the first call for these inputs only."""
        key = self.key(features, n_levels, config, wrap)
        levels = self._entries.get(key)
        if levels is None:
            levels = self._entries[key] = analyse_exemplar(features, n_levels, config, progress,
                                                           wrap)
        elif progress is not None:
            for _ in range(n_levels):
                progress()
        return levels

    def __len__(self) -> int:
        return len(self._entries)

    @property
    def nbytes(self) -> int:
        """Bytes held by the cached arrays."""
        total = 0
        for levels in self._entries.values():
            for la in levels:
                total += la.features.nbytes + la.coords_y.nbytes + la.coords_x.nbytes + la.ksets.nbytes
                total += sum(w.nbytes for w in la.kernel_weights.values())
                total += sum(p.features.nbytes for p in la.projections.values())
        return total


# --------------------------------------------------------------------------------------------
# synthesis steps


def _jitter(refs: np.ndarray, level: LevelAnalysis, amplitude: int,
            rng: np.random.Generator) -> np.ndarray:
    """Displace every reference by a seeded random offset in [-amplitude, amplitude]
    (Lefebvre & Hoppe 2005, controllable jitter)."""
    if amplitude <= 0:
        return refs
    ry, rx = level.coords_y[refs], level.coords_x[refs]
    jy = rng.integers(-amplitude, amplitude + 1, size=refs.shape, dtype=np.int32)
    jx = rng.integers(-amplitude, amplitude + 1, size=refs.shape, dtype=np.int32)
    ry = np.mod(ry + jy, level.height) if level.wrap[0] else np.clip(ry + jy, 0, level.height - 1)
    rx = np.mod(rx + jx, level.width) if level.wrap[1] else np.clip(rx + jx, 0, level.width - 1)
    return np.ascontiguousarray(ry * level.width + rx, dtype=np.int32)


def _occurrence_penalty(refs: np.ndarray, level: LevelAnalysis, weight: float,
                        radius: int, expected_use: np.ndarray | None = None) -> np.ndarray:
    """Cost per exemplar pixel from how much more (or less) often its region is referenced than a
    uniform use of the exemplar would give (occurrence map, Kaspar et al. 2015 §5). With a guide,
    ``expected_use`` gives each exemplar pixel's uniform share (per label)."""
    n = level.height * level.width
    if weight <= 0:
        return np.zeros(n, np.float32)
    counts = np.bincount(refs.ravel(), minlength=n).astype(np.float32).reshape(level.height, level.width)
    k = 2 * radius + 1
    regional = _box_blur(counts, k, level.wrap)
    if expected_use is None:
        expected = max(1.0, refs.size / n)
        # > 0 for regions used more than their share, down to -1 (a bonus) for unused ones: small
        # outputs then still cover the whole exemplar (completeness)
        excess = regional / expected - 1.0
    else:
        share = _box_blur(expected_use.reshape(level.height, level.width), k, level.wrap)
        # regions of labels the target does not want get neither cost nor bonus
        excess = np.where(share > 0, regional / np.maximum(share, 1.0) - 1.0, 0.0)
    return np.ascontiguousarray((weight * level.scale) * excess, dtype=np.float32).ravel()


def _box_blur(image: np.ndarray, k: int, wrap: tuple[bool, bool]) -> np.ndarray:
    """``k x k`` box mean of a level's map, round the edges along the axes that wrap (else
    reflected)."""
    import cv2

    image = np.ascontiguousarray(image, dtype=np.float32)
    if not any(wrap):
        return cv2.blur(image, (k, k), borderType=cv2.BORDER_REFLECT_101)
    r = k // 2
    pad = np.pad(image, ((r, r), (0, 0)), mode="wrap" if wrap[0] else "reflect")
    pad = np.pad(pad, ((0, 0), (r, r)), mode="wrap" if wrap[1] else "reflect")
    return np.ascontiguousarray(cv2.blur(pad, (k, k))[r:r + image.shape[0], r:r + image.shape[1]])


@dataclass
class LabelBalance:
    """Keeps the label areas of a synthesized label map (histogram matching, Kopf et al. 2007,
    in the discrete solver's occurrence cost).

    ``shares[l]`` ``(h_l * w_l, L)``: how much of each label the full-resolution exemplar
    pixels under each pixel of level ``l`` have (finest first); ``fractions`` ``(L,)``: each
    label's share of the exemplar. The shares of the referenced pixels predict the final label
    areas already at coarse levels, where thin labels are not resolved; an exemplar pixel costs
    more the more it holds of labels the output has too much of, and less for labels it lacks,
    by ``weight`` x the relative excess (same units as the occurrence cost).
    """

    shares: list
    fractions: np.ndarray
    weight: float

    def penalty(self, refs: np.ndarray, level: int, scale: float) -> np.ndarray:
        shares = self.shares[level]
        current = shares[refs.ravel()].mean(axis=0)
        excess = np.clip(current / np.maximum(self.fractions, 1e-6) - 1.0, -1.0, 1.0)
        return shares @ (np.float32(self.weight * scale) * excess.astype(np.float32))


def _offset_codes(dy: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """Offsets (reference - position) as the int64 codes the kernels compare
    (``_kernels.offset_code``)."""
    import barkgen.synth._kernels as K

    bias = K.OFFSET_BIAS
    return (np.asarray(dy, np.int64) + bias) * (2 * bias) + (np.asarray(dx, np.int64) + bias)


def _offset_parts(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`_offset_codes`: ``(dy, dx)``."""
    import barkgen.synth._kernels as K

    bias = K.OFFSET_BIAS
    dy, dx = np.divmod(codes, 2 * bias)
    return dy - bias, dx - bias


#: swing of the copy-size control's meandering cut lines, as a fraction of the side of a
#: square piece of the largest area allowed
CUT_MEANDER_AMPLITUDE = 0.05
#: their shortest period, in the same unit (the longest is twice this)
CUT_MEANDER_PERIOD = 0.4


def _limit_copies(refs: np.ndarray, level: LevelAnalysis, max_area: float,
                  forbid: np.ndarray, tile: bool, rng: np.random.Generator) -> int:
    """Copy-size control: find the pieces copied verbatim (``_kernels.label_pieces``: a piece that
    runs round a tiled output or across a wrapping exemplar's edge is one) larger than
    ``max_area`` pixels and forbid their offsets on a cross-shaped band through each one's
    centroid, so the next iterations cut it in up to four. The band's two lines meander (random
    phase and period per piece, drawn from ``rng``): straight, they would leave two straight
    seams, which the seam cuts would close again. Returns the number of regions cut.

    The discrete solver left alone grows whole-exemplar copies wherever nothing stops coherence
    (G'MIC's results copy 64 % of the exemplar in one piece); this keeps the coherence bias while
    bounding the largest verbatim piece.
    """
    import barkgen.synth._kernels as K

    labels = np.empty(refs.shape, np.int32)
    sizes = K.label_pieces(refs, level.coords_y, level.coords_x, level.height, level.width,
                           level.wrap[0], level.wrap[1], tile, labels)
    big = sizes > max_area
    if not big.any():
        return 0
    ys, xs = np.nonzero(big[labels])
    lab = labels[ys, xs]
    n = np.bincount(lab, minlength=sizes.size).astype(np.float64)
    side = np.sqrt(max_area)
    which = np.cumsum(big) - 1  # a big piece's row in the draws
    phase = 2 * np.pi * rng.random((2, int(big.sum())))
    period = CUT_MEANDER_PERIOD * side * (1.0 + rng.random(phase.shape))
    k = which[lab]
    swing_y = CUT_MEANDER_AMPLITUDE * side * np.sin(2 * np.pi * xs / period[0, k] + phase[0, k])
    swing_x = CUT_MEANDER_AMPLITUDE * side * np.sin(2 * np.pi * ys / period[1, k] + phase[1, k])
    if tile:  # a piece round the torus: its centre is the circular mean, the band wraps
        H, W = refs.shape
        cy = _circular_centre(lab, ys, H, n)
        cx = _circular_centre(lab, xs, W, n)
        band = ((_circular_gap(ys, cy[lab] + swing_y, H) <= 1.0)
                | (_circular_gap(xs, cx[lab] + swing_x, W) <= 1.0))
    else:
        cy = np.bincount(lab, ys, minlength=sizes.size) / np.maximum(n, 1)
        cx = np.bincount(lab, xs, minlength=sizes.size) / np.maximum(n, 1)
        band = (np.abs(ys - cy[lab] - swing_y) <= 1.0) | (np.abs(xs - cx[lab] - swing_x) <= 1.0)
    ys, xs = ys[band], xs[band]
    e = refs[ys, xs]
    forbid[ys, xs] = _offset_codes(level.coords_y[e] - ys, level.coords_x[e] - xs)
    return int(big.sum())


#: rows (or columns) of the lower piece that a straight seam stuck at the exemplar's border
#: forbids (:func:`_unstick_border_seams`)
UNSTICK_DEPTH = 4


def _unstick_border_seams(refs: np.ndarray, level: LevelAnalysis, forbid: np.ndarray,
                          tile: bool, min_run: int) -> int:
    """Where a straight seam joins two pieces that both end at the exemplar's border there
    (the upper one on its last row, the lower one on its first, along an axis that does not
    wrap), no cut can move it: neither piece continues past the border. The lower piece's offset
    is forbidden on the ``UNSTICK_DEPTH`` rows below the seam, so the next iterations put
    other pieces there, which can be cut. The same for seams between columns. Returns the
    number of seams treated."""
    import barkgen.synth._kernels as K

    ry = np.ascontiguousarray(level.coords_y[refs], dtype=np.int32)
    rx = np.ascontiguousarray(level.coords_x[refs], dtype=np.int32)
    h, w = level.height, level.width
    treated = 0
    for axis in (0, 1):
        if level.wrap[axis]:
            continue
        if axis == 0:
            a, b, n_ex, wy, wx, fb = ry, rx, (h, w), level.wrap[0], level.wrap[1], forbid
        else:
            a, b, n_ex, wy, wx, fb = (cv2.transpose(rx), cv2.transpose(ry), (w, h),
                                      level.wrap[1], level.wrap[0], forbid.T)
        H, W = a.shape
        runs = K.seam_runs(a, b, n_ex[0], n_ex[1], wy, wx, tile, min_run)
        for i, start, length in runs:
            cols = np.arange(start, start + length)
            cols = np.mod(cols, W) if tile else cols
            j = (i + 1) % H
            stuck = (a[i, cols] == n_ex[0] - 1) & (a[j, cols] == 0)
            if stuck.mean() < 0.5:
                continue
            rows = j + np.arange(UNSTICK_DEPTH)
            if tile:
                rows = np.mod(rows, H)
            else:
                rows = rows[rows < H]
            yy, xx = np.meshgrid(rows, cols, indexing="ij")
            dy = (rows - j)[:, None] if not tile else np.mod(rows - j, H)[:, None]
            same = (a[yy, xx] == a[j, cols][None, :] + dy) & (b[yy, xx] == b[j, cols][None, :])
            yy, xx = yy[same], xx[same]
            ey, ex = a[yy, xx], b[yy, xx]
            if axis == 0:
                fb[yy, xx] = _offset_codes(ey - yy, ex - xx)
            else:  # transposed frame: output (xx, yy), exemplar (ex, ey)
                fb[yy, xx] = _offset_codes(ex - xx, ey - yy)
            treated += 1
    return treated


def _circular_centre(lab: np.ndarray, pos: np.ndarray, period: int, n: np.ndarray) -> np.ndarray:
    """Per label, the circular mean of the positions ``pos`` on a circle of ``period`` pixels."""
    angle = pos * (2 * np.pi / period)
    c = np.bincount(lab, np.cos(angle), minlength=n.size)
    s = np.bincount(lab, np.sin(angle), minlength=n.size)
    return np.mod(np.arctan2(s, c) * (period / (2 * np.pi)), period)


def _circular_gap(pos: np.ndarray, centre: np.ndarray, period: int) -> np.ndarray:
    d = np.abs(pos - centre) % period
    return np.minimum(d, period - d)


def _roll(refs: np.ndarray, forbid: np.ndarray, shift: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Toroidal shift of the output state; forbidden offsets are re-expressed for the pixels'
    new positions."""
    H, W = refs.shape
    dy, dx = _offset_parts(forbid)
    ys = np.arange(H)[:, None]
    xs = np.arange(W)[None, :]
    # an offset is relative to the position; after the shift the position is (y + sy) mod H
    moved = _offset_codes(dy - ((ys + shift[0]) % H - ys), dx - ((xs + shift[1]) % W - xs))
    moved = np.where(forbid >= 0, moved, -1)
    return (np.ascontiguousarray(np.roll(refs, shift, axis=(0, 1))),
            np.ascontiguousarray(np.roll(moved, shift, axis=(0, 1))))


def _cut_seams(refs: np.ndarray, level: LevelAnalysis, features: np.ndarray, tile: bool,
               min_run: int, labels: tuple[np.ndarray, np.ndarray] | None,
               rng: np.random.Generator) -> np.ndarray:
    """The level's reference map with its straight seams re-cut (:mod:`barkgen.synth.cuts`);
    ``features`` ``(h, w, C)``: what the seam cost compares; ``labels`` ``(exemplar labels,
    target labels)`` keeps texture-by-numbers' labels; ``rng`` draws the meanders."""
    from barkgen.synth.cuts import cut_straight_seams

    allowed = None
    if labels is not None:
        ex_labels, target = labels

        def allowed(ys, xs, ey, ex):
            return ex_labels[ey * level.width + ex] == target[ys, xs]

    coords = np.stack([level.coords_y[refs], level.coords_x[refs]], axis=-1)
    cut = cut_straight_seams(coords, features, tile=tile, wrap=level.wrap, min_run=min_run,
                             allowed=allowed, rng=rng)
    return np.ascontiguousarray(cut[..., 0] * level.width + cut[..., 1], dtype=np.int32)


def _stride_for(size: int) -> int:
    return 1 if size <= 3 else 2


@dataclass
class Guidance:
    """What turns the solver into texture-by-numbers (laitoch2018 §3.3, image analogies).

    ``exemplar_guides[l]`` ``(h_l, w_l, G)`` and ``target_guides[l]`` ``(H_l, W_l, G)`` are the
    guide channels (soft labels) of the exemplar (``A``) and of the output (``B``) at level
    ``l``; their neighbourhoods are compared in an appearance space of their own with
    ``components`` dimensions. ``levels`` are the label tables; ``initial_references(a, b, rng)``
    makes the coarsest level's reference map from its exemplar and target labels.

    ``random_candidates``: M-step candidates drawn per pixel from the wanted label's exemplar
    pixels (plus one aligned on the nearest other label). ``vote_discount``: weight of E-step
    votes whose label is wrong (0: used only when no vote has the right label).
    ``cleanup_passes``: label clean-up passes after the finest level (``_kernels.enforce_labels``).
    """

    levels: list  # list[LevelGuide], finest first
    exemplar_guides: list  # list[np.ndarray], finest first
    target_guides: list  # list[np.ndarray], finest first
    initial_references: Callable[[np.ndarray, np.ndarray, np.random.Generator], np.ndarray]
    components: int = 4
    random_candidates: int = 1
    vote_discount: float = 0.0
    cleanup_passes: int = 3


#: debug(name, image): receives intermediate images (uint8 RGB) when given
DebugCallback = Callable[[str, np.ndarray], None]


def validate_inputs(exemplar: np.ndarray, size: int | tuple[int, int], seed: int,
                    extra: Mapping[str, np.ndarray] | None) -> tuple[np.ndarray, tuple[int, int], dict]:
    """Check the exemplar, output size, seed and extra maps; return them normalised."""
    ex = as_hw_c("exemplar", exemplar)
    if ex.shape[2] not in (1, 3):
        raise InvalidInputError(f"exemplar must have 1 or 3 channels, not {ex.shape[2]}")
    if min(ex.shape[:2]) < MIN_EXEMPLAR_SIDE:
        raise InvalidInputError(
            f"exemplar is {ex.shape[1]}x{ex.shape[0]} px; it must be at least "
            f"{MIN_EXEMPLAR_SIDE} px on each side")
    out_shape = parse_output_shape(size)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise InvalidInputError(f"seed must be a non-negative integer, not {seed!r}")
    extras = {}
    for name, arr in (extra or {}).items():
        e = as_hw_c(f"extra map {name!r}", arr)
        if e.shape[:2] != ex.shape[:2]:
            raise InvalidInputError(
                f"extra map {name!r} is {e.shape[1]}x{e.shape[0]} px but the exemplar is "
                f"{ex.shape[1]}x{ex.shape[0]} px; they must match")
        extras[name] = e
    return ex, out_shape, extras


def check_memory(ex: np.ndarray, extras: Mapping[str, np.ndarray], out_shape: tuple[int, int],
                 feature_channels: int, config: SynthesisConfig, guided: bool = False) -> None:
    """Raise :class:`MemoryBudgetError` before any work if the job would not fit the budget."""
    need = estimate_memory(ex.shape[:2], out_shape,
                           ex.shape[2] + sum(e.shape[2] for e in extras.values()),
                           max([ex.dtype.itemsize] + [e.dtype.itemsize for e in extras.values()]),
                           feature_channels, config)
    if guided:  # label pyramids and tables
        need += 24 * out_shape[0] * out_shape[1] + 24 * ex.shape[0] * ex.shape[1]
    if need > config.max_memory:
        raise MemoryBudgetError(
            f"output {out_shape[1]}x{out_shape[0]} needs about {need / 2**30:.1f} GiB, more than "
            f"the memory budget of {config.max_memory / 2**30:.1f} GiB (raise it with --max-memory)")


def _set_threads(config: SynthesisConfig) -> None:
    import numba

    # set on every call: a previous call's thread count must not leak into this one
    n_threads = min(config.threads or numba.config.NUMBA_NUM_THREADS, numba.config.NUMBA_NUM_THREADS)
    numba.set_num_threads(n_threads)
    if config.threads is not None or "faiss" in sys.modules:
        import faiss

        faiss.omp_set_num_threads(n_threads)


def _level_image(ex: np.ndarray, refs: np.ndarray, level: int) -> np.ndarray:
    """A level's reference map shown with the full-resolution exemplar's colours (debug)."""
    h, w = ex.shape[:2]
    lw = level_shape((h, w), level)[1]
    ry, rx = np.divmod(refs, lw)
    img = ex[np.minimum(ry << level, h - 1), np.minimum(rx << level, w - 1)]
    return as_uint8(img)


def solve(ex: np.ndarray, extras: Mapping[str, np.ndarray], features: np.ndarray,
          out_shape: tuple[int, int], *, n_levels: int, config: SynthesisConfig, seed: int,
          tile: bool, guidance: Guidance | None = None,
          progress: ProgressCallback | None = None,
          debug: DebugCallback | None = None,
          start: tuple[int, np.ndarray] | None = None,
          balance: LabelBalance | None = None,
          cache: AnalysisCache | None = None, stop_level: int = 0,
          exemplar_wrap: tuple[bool, bool] = (False, False),
          seam_channels: int | None = None) -> SynthesisResult:
    """The coarse-to-fine discrete solver shared by :func:`synthesize` and texture-by-numbers.

    ``ex`` ``(h, w, C)`` and ``extras`` are resolved through the final references; ``features``
    ``(h, w, F)`` float32 are what is matched. Inputs must already be validated. ``start``:
    ``(level, references)`` resumes at that level from a given reference map (flat indices
    into the level's exemplar) instead of starting at the coarsest level. ``balance`` adds the
    label-area term of :class:`LabelBalance` to the occurrence cost. ``cache``: an
    :class:`AnalysisCache` that supplies (or keeps) the exemplar's analysis. ``stop_level`` > 0
    stops after that level: the result's ``references`` and ``exemplar_shape`` are then that
    level's, its ``image`` the level shown in the exemplar's colours, and it has no extras.
    ``exemplar_wrap`` ``(rows, columns)``: the exemplar tiles along that axis and is used as a
    torus there; along an axis that does not wrap, pieces may run up to its border
    (:mod:`barkgen.synth.edges`), and after each iteration a straight seam stuck at that border
    is handed back to the solver (:func:`_unstick_border_seams`).
    After each level's iterations, ``config.seam_sweeps`` sweeps of seam optimisation
    (``_kernels.refine_seams``) and, at the finest levels, graph cuts of the straight seams
    (:mod:`barkgen.synth.cuts`) move the borders between pieces onto low-error paths; their
    seam cost compares the first ``seam_channels`` feature channels (the colour; None: all).
    """
    if not 0 <= stop_level < n_levels:
        raise InvalidInputError(f"stop_level must be in 0..{n_levels - 1}")
    _set_threads(config)
    import barkgen.synth._kernels as K

    rng = np.random.default_rng(int(seed))
    total = n_levels + sum(it for lvl in range(n_levels) for _, it in config.schedule_for(lvl, n_levels))
    done = 0

    def tick() -> None:
        nonlocal done
        done += 1
        if progress:
            progress(done, total)

    t0 = time.perf_counter()
    cache = cache if cache is not None else AnalysisCache()
    wrap = (bool(exemplar_wrap[0]), bool(exemplar_wrap[1]))
    levels = cache.analyse(features, n_levels, config, progress=tick, wrap=wrap)
    t1 = time.perf_counter()

    no_labels = np.zeros(1, np.int32)
    no_target = np.zeros((1, 1), np.int32)
    no_pool_start = np.zeros(2, np.int32)
    no_guide_ex = np.zeros((1, 0), np.float32)
    no_guide_out = np.zeros((1, 1, 0), np.float32)
    refs = None
    for lvl in reversed(range(stop_level, n_levels)):
        la = levels[lvl]
        shape = level_shape(out_shape, lvl)
        lg = guidance.levels[lvl] if guidance is not None else None
        if start is not None and lvl > start[0]:  # levels above the resumed one are not run
            for _ in range(sum(it for _, it in config.schedule_for(lvl, n_levels))):
                tick()
            continue
        if debug is not None:
            debug(f"level{lvl}_exemplar", _level_image(ex, np.arange(la.height * la.width).reshape(
                la.height, la.width), lvl))
        if start is not None and lvl == start[0]:
            refs = np.ascontiguousarray(start[1], dtype=np.int32)
            forbid = np.full(shape, -1, np.int64)
        elif refs is None:
            if lg is not None:
                refs = np.ascontiguousarray(guidance.initial_references(
                    lg.exemplar_labels.reshape(la.height, la.width), lg.target_labels, rng),
                    dtype=np.int32)
                if debug is not None:
                    debug("initialization", _level_image(ex, refs, lvl))
            else:
                refs = rng.integers(0, la.height * la.width, size=shape, dtype=np.int32)
            forbid = np.full(shape, -1, np.int64)
        else:
            coarse = levels[lvl + 1]
            fine_refs = np.empty(shape, np.int32)
            fine_forbid = np.empty(shape, np.int64)
            K.upsample_state(refs, forbid, coarse.coords_y, coarse.coords_x, la.height, la.width,
                             wrap[0], wrap[1], fine_refs, fine_forbid)
            refs, forbid = fine_refs, fine_forbid
            if tile and lvl > 0 and lg is None:
                # seams formed at coarse levels lie on the block grid of the upsampling; a random
                # toroidal shift per level keeps that grid from lining up with the tile border.
                # (None at the finest level: shifts stay even there, so exemplar pieces keep the
                # pixel parity of the exemplar and survive 2x downsampling intact. None either
                # with a guide: the output must stay aligned with its target label map.)
                shift = (int(rng.integers(0, shape[0])), int(rng.integers(0, shape[1])))
                refs, forbid = _roll(refs, forbid, shift)
            if lvl >= 2:
                refs = _jitter(refs, la, int(round(config.jitter * 2)), rng)
        guide_ex, guide_out = {}, {}
        if lg is not None:
            ex_labels, target = lg.exemplar_labels, lg.target_labels
            pool, pool_start = lg.pool, lg.pool_start
            expected = lg.expected_use
            n_random, discount = guidance.random_candidates, guidance.vote_discount
            for nb_size in _schedule_sizes(config, lvl, n_levels):
                gp = neighbourhood_pca(guidance.exemplar_guides[lvl], nb_size, guidance.components,
                                       wrap=wrap)
                guide_ex[nb_size] = gp.features
                guide_out[nb_size] = project_neighbourhoods(
                    guidance.target_guides[lvl], gp.weights, gp.mean, wrap=tile).reshape(shape + (-1,))
        else:
            ex_labels, target, pool, pool_start = no_labels, no_target, no_labels, no_pool_start
            expected, n_random, discount = None, 0, 1.0
        match = np.empty(shape, np.int32)
        new = np.empty(shape, np.int32)
        occ_radius = 3
        seam_image = np.ascontiguousarray(la.features[:, :seam_channels]).reshape(
            la.height, la.width, -1)  # what the seam costs compare, as an image

        def occurrence(refs: np.ndarray) -> np.ndarray:
            cost = _occurrence_penalty(refs, la, config.occurrence_weight, occ_radius, expected)
            if balance is not None:
                cost += balance.penalty(refs, lvl, la.scale)
            return cost

        penalty = occurrence(refs)
        schedule = [size for size, iters in config.schedule_for(lvl, n_levels) for _ in range(iters)]
        for step, nb_size in enumerate(schedule):
            proj = la.projections[nb_size]
            stride = _stride_for(nb_size)
            oy, ox = (int(v) for v in rng.integers(0, stride, size=2))
            key = np.uint64(rng.integers(0, 2**63)) if lg is not None else np.uint64(0)
            match.fill(-1)
            K.m_step(refs, la.features, la.coords_y, la.coords_x, la.height, la.width, wrap[0],
                     wrap[1], la.kernel_weights[nb_size], proj.mean,
                     proj.features, la.ksets, penalty, np.float32(config.kset_cost * la.scale),
                     stride, oy, ox, tile, forbid, guide_ex.get(nb_size, no_guide_ex),
                     guide_out.get(nb_size, no_guide_out), ex_labels, target, pool, pool_start,
                     n_random, key, match)
            K.e_step(match, refs, la.features, la.coords_y, la.coords_x, la.height, la.width,
                     wrap[0], wrap[1], min(nb_size // 2, config.vote_radius), stride,
                     oy, ox, tile, np.float32(max(nb_size / 3.0, 1.0)), forbid,
                     ex_labels, target, np.float32(discount), new)
            refs, new = new, refs
            if config.max_copy < 1.0 and (lvl > 0 or step < len(schedule) - 1):
                # (cuts act through the following iterations, none after the very last one)
                _limit_copies(refs, la, config.max_copy * la.height * la.width, forbid, tile, rng)
            if config.seam_cut_run and not all(wrap):
                _unstick_border_seams(refs, la, forbid, tile, max(4, config.seam_cut_run >> lvl))
            penalty = occurrence(refs)
            tick()
        # the first sweep looks at every pixel; later half-sweeps only beside the moved ones
        moved_map, after = np.empty(shape, np.uint8), np.zeros(shape, np.uint8)
        every = np.zeros((1, 1), np.uint8)
        for sweep in range(config.seam_sweeps):
            moved = 0
            for parity in (0, 1):
                moved += K.refine_seams(refs, seam_image, la.coords_y, la.coords_x, la.height,
                                        la.width, wrap[0], wrap[1], tile, parity, forbid,
                                        ex_labels, target, every if sweep == 0 else after,
                                        moved_map, new)
                refs, new = new, refs
                moved_map, after = after, moved_map
            if moved == 0:
                break
        if config.seam_cut_run and lvl <= config.seam_cut_levels - 1:
            refs = _cut_seams(refs, la, seam_image, tile, config.seam_cut_run,
                              (ex_labels, target) if lg is not None else None, rng)
        if lg is not None and lvl == 0:
            for _ in range(guidance.cleanup_passes):
                if K.enforce_labels(refs, la.coords_y, la.coords_x, la.height, la.width, wrap[0],
                                    wrap[1], ex_labels, target, tile, new) == 0:
                    break
                refs, new = new, refs
        if debug is not None:
            debug(f"level{lvl}_result", _level_image(ex, refs, lvl))
    t2 = time.perf_counter()
    if stop_level > 0:
        la = levels[stop_level]
        references = np.stack([la.coords_y[refs], la.coords_x[refs]], axis=-1).astype(np.int32)
        return SynthesisResult(image=_level_image(ex, refs, stop_level), references=references,
                               exemplar_shape=(la.height, la.width), exemplar_wrap=wrap,
                               seed=int(seed), tile=bool(tile),
                               timings={"analysis": t1 - t0, "synthesis": t2 - t1})

    h, w = ex.shape[:2]
    image = ex.reshape(h * w, ex.shape[2])[refs].reshape(out_shape + (ex.shape[2],))
    ry, rx = levels[0].coords_y[refs], levels[0].coords_x[refs]
    references = np.stack([ry, rx], axis=-1).astype(np.int32)
    # extra maps are continuous (height, normals, roughness): resolved in the gradient domain,
    # so the borders of the copied pieces leave no cliffs in them
    out_extras = {name: resolve_continuous(e, references, tile=tile, wrap=wrap)
                  for name, e in extras.items()}
    return SynthesisResult(image=image, references=references, extras=out_extras,
                           exemplar_shape=(h, w), exemplar_wrap=wrap, seed=int(seed),
                           tile=bool(tile),
                           timings={"analysis": t1 - t0, "synthesis": t2 - t1})


# --------------------------------------------------------------------------------------------
# public API


def synthesize(
    exemplar: np.ndarray,
    size: int | tuple[int, int],
    *,
    tile: bool = False,
    seed: int = 0,
    extra: Mapping[str, np.ndarray] | None = None,
    config: SynthesisConfig | None = None,
    progress: ProgressCallback | None = None,
    exemplar_wrap: str | bool | tuple[bool, bool] = "auto",
) -> SynthesisResult:
    """Synthesize a new texture of ``size`` = ``(height, width)`` from ``exemplar``.

    Args:
        exemplar: ``(h, w)`` or ``(h, w, C)`` array (uint8, uint16 or float), C = 1 or 3.
        size: output ``(height, width)`` (numpy order) or an int for a square.
        tile: make the output wrap seamlessly in x and y (toroidal neighbourhoods).
        seed: seeds the one ``numpy.random.Generator`` behind every random choice.
        extra: named maps aligned with the exemplar (height, normal, ...); they take part in the
            matching (weight ``config.extra_weight``) and are returned resolved.
        config: solver parameters (:class:`SynthesisConfig`).
        progress: optional ``progress(done, total)`` callback.
        exemplar_wrap: ``"auto"`` (the exemplar is used as a torus along each axis along which
            it tiles itself, :func:`barkgen.synth.edges.exemplar_wraps`), ``"yes"``, ``"no"``,
            or a ``(rows, columns)`` pair of bools.

    Returns:
        :class:`SynthesisResult` with the image, the references and the extra maps.

    Raises:
        InvalidInputError: bad shapes, sizes or parameters.
        MemoryBudgetError: the estimated memory exceeds ``config.max_memory``.
    """
    config = config or SynthesisConfig()
    ex, out_shape, extras = validate_inputs(exemplar, size, seed, extra)
    n_feat = (3 if ex.shape[2] == 3 else 1) + sum(e.shape[2] for e in extras.values())
    check_memory(ex, extras, out_shape, n_feat, config)
    wrap = resolve_exemplar_wrap(exemplar_wrap, ex)
    feats = matching_features(ex, extras, config.extra_weight)
    n_levels = count_levels(ex.shape[:2], out_shape, config.coarsest_exemplar)
    result = solve(ex, extras, feats, out_shape, n_levels=n_levels, config=config, seed=seed,
                   tile=tile, progress=progress, exemplar_wrap=wrap,
                   seam_channels=3 if ex.shape[2] == 3 else 1)
    if np.asarray(exemplar).ndim == 2:
        result.image = result.image[:, :, 0]
    return result


def apply_references(references: np.ndarray, image: np.ndarray) -> np.ndarray:
    """Resolve a reference map against any map of the exemplar's size (laitoch2018 §3.3.1):
    ``out[y, x] = image[references[y, x, 0], references[y, x, 1]]``."""
    refs = np.asarray(references)
    img = np.asarray(image)
    if refs.ndim != 3 or refs.shape[2] != 2:
        raise InvalidInputError(f"references must have shape (H, W, 2), not {refs.shape}")
    if img.ndim not in (2, 3):
        raise InvalidInputError(f"image must be (H, W) or (H, W, C), not {img.shape}")
    if refs.size and (refs.min() < 0 or refs[:, :, 0].max() >= img.shape[0]
                      or refs[:, :, 1].max() >= img.shape[1]):
        raise InvalidInputError(
            f"the reference map points outside a {img.shape[1]}x{img.shape[0]} image; "
            "apply it to a map of the exemplar's size")
    return img[refs[:, :, 0], refs[:, :, 1]]
