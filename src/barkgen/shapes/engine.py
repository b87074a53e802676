"""Label-map synthesis with the core engine on soft one-hot label channels.

barkgen's second strategy for output label maps (laitoch2018 §4.4 found the layered one fails for
many labels): the exemplar label map becomes an image of one channel per label (each label's
indicator, blurred by one pixel so that a boundary one pixel off costs little), and the
k-coherence discrete solver of :mod:`barkgen.synth` synthesizes it like any texture. Every output
label pixel is then an exemplar label pixel (references, no averaging), so every label's shapes
and boundaries are exemplar shapes and boundaries, whatever the number of labels and whether or
not they nest. Two additions keep each label's area (plain synthesis lets it drift by 5-12
percentage points on the bark set):

* the coarsest level starts from a random patchwork of exemplar squares instead of random
  pixels, so small isolated regions (lenticels, knots) exist from the start;
* a label-area term in the occurrence cost (:class:`barkgen.synth.LabelBalance`,
  histogram matching after Kopf et al. 2007) makes labels the output has too much of dearer and
  the missing ones cheaper, judged at every level on the full-resolution label shares under the
  referenced pixels.

The ``"joint"`` strategy, the pipeline's default, also matches the photo the label map was made
from: each exemplar pixel's features are its CIELAB colour and its soft label channels together,
solved with plain synthesis' own configuration, so the output label map is the label map of a
synthesis of the photo. Its pieces then fit together in the photo's colours as well as in their
labels, and texture-by-numbers started from its references (:mod:`barkgen.pipeline`) has
coherent photo pieces to refine instead of label-exact ones that may not fit in colour. Its
start is the best of several runs of the coarse levels (:func:`start_score`), so that the area
term seldom has to move whole regions. On the ten bark photos (1024x1024, medians over three
seeds), texture coherence is within 1.25x plain synthesis' on all ten (oak 1.24x; 1.60x with a
single run and the full area term from the coarsest level); with the label-only engine, whose
large uniform label regions give the solver nothing to choose by, on six (lichen 1.67x, oak
1.55x, peeling 1.47x, fir 1.26x).

An edited level is resumed as texture-by-numbers of the label map on the edit (laitoch2018 §1:
the artist sets the large-scale layout, barkgen the detail): the edit, brought to full size with
smooth boundaries, is the target label map that guides every level from the edited one down
(:class:`barkgen.synth.Guidance`), the edited level starts from the smart initialisation on
it, and no area term pulls against it (the edit sets the areas). Without the guide the free
solver drifts back to a layout of its own below the edited level: a stroke painted at level 3 of
a 512 px map of the oak photo kept 2-39 % of its pixels, 93-97 % with the guide (and 87-89 % of
the whole level's layout instead of about 50 %), while the boundaries take exemplar detail
(``tests/shapes/test_shapes.py::test_an_edit_keeps_its_layout_down_to_the_finest_level``).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import numpy as np

from barkgen._shared.canvas import Budget, Canvas
from barkgen._shared.memory import BASE_BYTES
from barkgen._shared.threads import side_by_side
from barkgen.pyramid import count_levels, gaussian_pyramid, level_shape
from barkgen.synth import (
    AnalysisCache,
    Guidance,
    LabelBalance,
    SolverInputs,
    SynthesisConfig,
    by_windows,
    cut_straight_seams,
    exemplar_grid,
    expand_pieces,
    guide_channels,
    label_pyramid,
    level_guide,
    matching_features,
    smart_initialization,
    solve,
    upsample_references,
)

#: the solver for label maps: the pyramid stops where label regions still exist (as for
#: texture-by-numbers); one-hot channels need few appearance dimensions; no expansion moves
#: (one-hot borders have one cost wherever they run)
LABEL_ENGINE_CONFIG = SynthesisConfig(coarsest_exemplar=32, pca_components=6, seam_expansion_band=0)
#: weight of the label-area term (:class:`barkgen.synth.LabelBalance`)
BALANCE_WEIGHT = 64.0
#: side of the squares of the coarsest level's random patchwork start
INIT_BLOCK = 8
#: the joint strategy's solver: plain synthesis' configuration (it is a synthesis of the photo),
#: with two rounds of expansion moves on the finest level's up-sampled references
#: (:func:`_move_finest_seams`; generate's texture step ratio across seams on the sample, seed 0:
#: 1.56 without them, 1.43 with two rounds)
JOINT_CONFIG = SynthesisConfig(seam_expansion_rounds=2)
#: joint strategy: the label channels' total variance, in units of the photo's colour variance
JOINT_LABEL_WEIGHT = 1.0
#: joint strategy: weight of the label-area term (:class:`~barkgen.synth.LabelBalance`)
#: from the chosen start down; the candidate starts run with :data:`JOINT_CANDIDATE_BALANCE` of
#: it. (32 at every level of a single run, the previous default, moved whole regions at the
#: coarse levels and cost oak 1.2-2.3x plain synthesis' coherence; free candidates and 16 from
#: the start left willow's 512 px label maps 3.6-6.2 points off.)
JOINT_BALANCE_WEIGHT = 32.0
#: joint strategy: share of :data:`JOINT_BALANCE_WEIGHT` the candidate starts run with (on oak,
#: texture coherence 1.28x plain with the full weight, 1.24x with half)
JOINT_CANDIDATE_BALANCE = 0.5
#: joint strategy: coarse starts tried (each a run of the coarsest levels with its own seed)
JOINT_CANDIDATES = 8
#: joint strategy: levels run below the coarsest before the candidates are compared (label
#: areas are settled there: without an area term, oak's moved by at most 0.6 points from
#: level 3 of 7 to level 0)
JOINT_SELECT_DEPTH = 3
#: joint strategy: the finest pyramid level it solves; below it its references are up-sampled
#: exactly (every output pixel an exemplar label pixel, as always) and texture-by-numbers,
#: which matches colour and labels too, refines the finest level (:mod:`barkgen.pipeline`).
#: Solving the finest level twice, here and there, cost the quickstart 1.2 s of its 11.8
#: (its analysis 0.8 s, its iterations 0.4 s), and the ten photos' texture figures are the same
JOINT_FINEST_LEVEL = 1
#: px read round each window of the finest level's seam moves (``synthesize_codes(window=...)``):
#: twice the expansion moves' reach and the straight-seam cuts' band, so that a core's moves see
#: what lies beyond its edge
FINEST_MOVES_HALO = 32
#: joint strategy: bytes per output pixel of its finest level (the up-sampled references and
#: their seams moved; measured over the process's base with the 1024x1024 sample: 60 at
#: 4096x4096, 49 at 8192x8192)
JOINT_FINEST_BYTES_PER_PIXEL = 64
#: weights of the label-area error and of the seams in :func:`start_score` (one percentage
#: point of area weighs as two of coverage and half a point of seams)
START_AREA_WEIGHT = 2.0
START_SEAM_WEIGHT = 4.0


def engine_levels(
    exemplar_shape: tuple[int, int],
    out_shape: tuple[int, int],
    config: SynthesisConfig | None = None,
    *,
    joint: bool = False,
) -> int:
    """Pyramid levels of the engine (or, ``joint``, the joint) strategy."""
    config = config or (JOINT_CONFIG if joint else LABEL_ENGINE_CONFIG)
    return count_levels(exemplar_shape, out_shape, config.coarsest_exemplar)


def finest_level(n_levels: int, *, joint: bool, resumed: bool = False) -> int:
    """The finest level the strategy solves (:data:`JOINT_FINEST_LEVEL` for the joint one,
    unless an edit is resumed: the edit guides every level)."""
    return min(JOINT_FINEST_LEVEL, n_levels - 1) if joint and not resumed else 0


def label_shares(codes: np.ndarray, n_labels: int, n_levels: int) -> list[np.ndarray]:
    """Per level, each pixel's share of every label: the label indicators reduced by the
    image pyramid (:func:`barkgen.pyramid.gaussian_pyramid`), ``(h_l * w_l, n_labels)``."""
    onehot = (codes[:, :, None] == np.arange(n_labels)).astype(np.float32)
    return [np.ascontiguousarray(lvl.reshape(-1, n_labels)) for lvl in gaussian_pyramid(onehot, n_levels)]


def block_initialization(
    exemplar_shape: tuple[int, int], out_shape: tuple[int, int], block: int, rng: np.random.Generator
) -> np.ndarray:
    """References of a random patchwork: the output is cut into ``block`` x ``block`` squares,
    each copying an exemplar square at a random place (flat indices into the exemplar). Unlike
    independent random pixels, small isolated label regions (lenticels, knots) survive it."""
    h, w = exemplar_shape
    bh, bw = min(block, h), min(block, w)
    ny, nx = -(-out_shape[0] // bh), -(-out_shape[1] // bw)
    y0 = rng.integers(0, h - bh + 1, size=(ny, nx))
    x0 = rng.integers(0, w - bw + 1, size=(ny, nx))
    yy, xx = np.mgrid[0 : out_shape[0], 0 : out_shape[1]]
    by, bx = yy // bh, xx // bw
    return ((y0[by, bx] + yy % bh) * w + x0[by, bx] + xx % bw).astype(np.int32)


def synthesize_codes(
    codes: np.ndarray,
    n_labels: int,
    canvas: Canvas,
    budget: Budget,
    *,
    start: tuple[int, np.ndarray] | None = None,
    on_level: Callable[[int, np.ndarray], None] | None = None,
    config: SynthesisConfig | None = None,
    balance_weight: float | None = None,
    photo: np.ndarray | None = None,
    window: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Synthesize label codes ``canvas.shape`` from the exemplar's ``codes`` with the core
    solver; returns them and their reference map ``(H, W, 2)`` (exemplar ``(y, x)`` per pixel).

    ``canvas``: the output's shape, its tile and the exemplar's resolved ``exemplar_wrap``
    ``(rows, columns)`` (:func:`barkgen.synth.exemplar_wraps`). ``budget``: the seed, the
    progress callback and the :class:`AnalysisCache` holding (or to keep) the exemplar's
    k-coherence analysis (:func:`analyse_codes`).

    ``photo``: the photo the codes label (same height and width); given, the joint strategy
    matches its colour along the labels (:func:`joint_features`), with :data:`JOINT_CONFIG`,
    starting from the best of several runs of the coarse levels (:func:`_choose_coarse_start`),
    with :data:`JOINT_BALANCE_WEIGHT` from there down.

    ``start``: ``(level, codes)`` of an edited level: its reference map is made by the smart
    initialisation of texture-by-numbers (coherent exemplar pieces whose labels match the edit,
    laitoch2018 §3.4.2) and the solver continues from that level. ``on_level(level, codes)``
    receives each level's result.

    ``window``: the large finest levels solved window by window (``SynthesisConfig.window``) and
    the joint strategy's finest seam moves made so too (:func:`_move_finest_seams`): the
    working memory a window's, not the output's (issue 69).
    """
    joint = photo is not None
    out_shape, exemplar_wrap = canvas.shape, canvas.exemplar_wrap
    cache = budget.cache if budget.cache is not None else AnalysisCache()
    features, config = _solver_inputs(codes, n_labels, photo, config, exemplar_wrap, cache)
    config = dataclasses.replace(config, window=int(window)) if window else config
    n_levels = engine_levels(codes.shape, out_shape, config)
    ex = codes.astype(np.uint8)[:, :, None]
    rng = np.random.default_rng([int(budget.seed), 1])
    guidance = balance = None
    resume: tuple[int, np.ndarray] | None
    if start is not None:
        # an edit sets the layout, and its own label areas: no area term pulls against it, and
        # the edit guides every finer level
        resume, guidance = _edited_start(codes, features, n_labels, n_levels, start, canvas, rng)
    else:
        shares = label_shares(codes, n_labels, n_levels)
        fractions = np.bincount(codes.ravel(), minlength=n_labels) / codes.size
        if balance_weight is None:
            balance_weight = JOINT_BALANCE_WEIGHT if joint else BALANCE_WEIGHT
        balance = LabelBalance(shares=shares, fractions=fractions, weight=balance_weight)
        if joint:
            resume, coarse_levels = _choose_coarse_start(
                ex, features, n_levels, config, balance, canvas, rng, budget.replace(cache=cache)
            )
            if on_level is not None:
                for lvl, image in coarse_levels:
                    on_level(lvl, image)
        else:
            # labels alone need the patchwork start to keep small regions
            level = n_levels - 1
            resume = (
                level,
                block_initialization(level_shape(codes.shape, level), level_shape(out_shape, level), INIT_BLOCK, rng),
            )

    def debug(name: str, image: np.ndarray) -> None:
        if on_level is not None and name.endswith("_result"):
            on_level(int(name[5:-7]), image.astype(np.int32))

    finest = finest_level(n_levels, joint=joint, resumed=start is not None)
    result = solve(
        SolverInputs(ex, features, n_levels, config, seam_channels=features.shape[2] - n_labels if joint else None),
        canvas.replace(links=None),
        Budget(seed=int(budget.seed), progress=budget.progress, cache=cache, debug=debug),
        guidance=guidance,
        start=resume,
        balance=balance,
        stop_level=finest,
    )
    references = result.references
    del result
    for lvl in reversed(range(finest)):
        references = upsample_references(
            references, level_shape(out_shape, lvl), level_shape(codes.shape, lvl), exemplar_wrap
        )
    if finest > 0 and joint:
        # (handed over as flat indices: the (H, W, 2) map is not held through the moves)
        flat = references[..., 0] * codes.shape[1] + references[..., 1]
        del references
        references = _move_finest_seams(flat, features[..., : features.shape[2] - n_labels], canvas, config, rng)
    out_codes = codes[references[..., 0], references[..., 1]].astype(np.int32)
    if finest > 0 and on_level is not None:
        on_level(0, out_codes)
    return out_codes, references


def _edited_start(
    codes: np.ndarray,
    features: np.ndarray,
    n_labels: int,
    n_levels: int,
    start: tuple[int, np.ndarray],
    canvas: Canvas,
    rng: np.random.Generator,
) -> tuple[tuple[int, np.ndarray], Guidance]:
    """Where an edited level resumes (its smart initialisation, laitoch2018 §3.4.2) and the
    guide that keeps the edit's layout down to the finest level (:func:`edit_guidance`)."""
    level, edited = start
    ex_levels = label_pyramid(codes, n_labels, n_levels)
    # (the exemplar's boundary distances not across its edges, as an edit's start always had them)
    resume = (
        level,
        smart_initialization(ex_levels[level], edited.astype(np.int32), rng, Canvas(canvas.shape, canvas.tile)),
    )
    guidance = edit_guidance(
        codes,
        features,
        upsample_codes(edited, canvas, n_labels),
        n_labels,
        n_levels,
        canvas,
        softness=EDIT_SOFTNESS * 2.0**level,
        exemplar_levels=ex_levels,
    )
    return resume, guidance


def _move_finest_seams(
    flat: np.ndarray,
    colour: np.ndarray,
    canvas: Canvas,
    config: SynthesisConfig,
    rng: np.random.Generator,
) -> np.ndarray:
    """The finest level's reference map (given as flat exemplar indices ``(H, W)``, returned as
    ``(H, W, 2)``), up-sampled from the level above, with its seams moved
    onto the photo's low-error paths: expansion moves on the photo's colour
    (:func:`barkgen.synth.expand_pieces`) take them off the up-sampling's 2x2 grid,
    then graph cuts re-cut the straight stretches left (:func:`cut_straight_seams`, with
    meanders). The label map's piece borders are then the photo's own, and texture-by-numbers,
    which follows them and may not move a label border, need not cut the bark along a staircase
    or a straight line. The straight ones are mostly where a piece ends at the photo's edge
    (its last row or column is straight and nothing continues it); the coarser level's cuts
    leave them half as long, and the up-sampling doubles them (peeling crop, 1024x1024, seed 0:
    79 px before this level's cuts)."""
    h, w = colour.shape[:2]
    exemplar_wrap = canvas.exemplar_wrap
    # a large level's moves window by window (``config.window``; issue 69), each window an output
    # that does not tile; the cuts' windows are shifted by half a window, so that their cores
    # hold the moves' window borders
    side = config.window if config.window and min(flat.shape) > config.window + 2 * FINEST_MOVES_HALO else 0

    def on(shape: tuple[int, int]) -> Canvas:
        return Canvas(shape, tile=False, exemplar_wrap=exemplar_wrap) if side else canvas

    def expanded(refs: np.ndarray) -> np.ndarray:
        return expand_pieces(
            refs,
            exemplar_grid((h, w), exemplar_wrap),
            colour,
            on(refs.shape),
            np.full((1, 1), -1, np.int64),  # no offset forbidden anywhere
            (np.zeros(1, np.int32), np.zeros((1, 1), np.int32)),  # unguided
            band=config.seam_expansion_band,
            rounds=config.seam_expansion_rounds,
        )

    def cut(refs: np.ndarray) -> np.ndarray:
        return cut_straight_seams(refs, colour, on(refs.shape[:2]), min_run=config.seam_cut_run, rng=rng)

    if config.seam_expansion_band:
        flat = by_windows(flat, side, expanded, tile=canvas.tile, halo=FINEST_MOVES_HALO) if side else expanded(flat)
    references = np.empty(flat.shape + (2,), np.int32)
    np.floor_divide(flat, w, out=references[..., 0])
    np.remainder(flat, w, out=references[..., 1])
    del flat
    if config.seam_cut_run and side:
        return by_windows(references, side, cut, tile=canvas.tile, halo=FINEST_MOVES_HALO, offset=side // 2)
    return cut(references) if config.seam_cut_run else references


def start_score(references: np.ndarray, exemplar_width: int, shares: np.ndarray, fractions: np.ndarray) -> float:
    """How far a level's references ``(h, w)`` (flat indices into an exemplar level of
    ``exemplar_width`` columns) are from a good start, the sum of:

    * :data:`START_AREA_WEIGHT` x the largest label-area error, as a fraction;
    * the share of the level's exemplar pixels that no output pixel references (of those an
      output this size could reference): regions missing here stay missing below (on lichen,
      two levels below the coarsest, the candidate covering 91 % of the level ended with
      texeval completeness 1.20, those covering 81-86 % with 1.8-2.6);
    * :data:`START_SEAM_WEIGHT` x the share of neighbouring output pixels whose references are
      not neighbours in the exemplar (seams): on oak, candidates with 3.5 % seams ended with
      texture coherence 0.44-0.46, those with 5.6 % with 0.62-0.69.
    """
    flat = references.ravel()
    area_error = float(np.abs(shares[flat].mean(axis=0) - fractions).max())
    coverage = np.unique(flat).size / min(shares.shape[0], flat.size)
    ry, rx = np.divmod(references, exemplar_width)
    across = ((ry[:, 1:] != ry[:, :-1]) | (rx[:, 1:] != rx[:, :-1] + 1)).mean()
    down = ((ry[1:] != ry[:-1] + 1) | (rx[1:] != rx[:-1])).mean()
    seams = float(across + down) / 2.0
    return START_AREA_WEIGHT * area_error + (1.0 - coverage) + START_SEAM_WEIGHT * seams


def _choose_coarse_start(
    ex: np.ndarray,
    features: np.ndarray,
    n_levels: int,
    config: SynthesisConfig,
    balance: LabelBalance,
    canvas: Canvas,
    rng: np.random.Generator,
    budget: Budget,
) -> tuple[tuple[int, np.ndarray] | None, list]:
    """The joint strategy's start: :data:`JOINT_CANDIDATES` runs of the coarsest levels down to
    :data:`JOINT_SELECT_DEPTH` below the coarsest, each from its own seed and with
    :data:`JOINT_CANDIDATE_BALANCE` of the area term; the one with the lowest
    :func:`start_score` is where the full solve resumes. Label areas and the large-scale layout
    are settled at those levels; a run that gets close to the exemplar's areas with a gentle
    area term has not had to move whole regions (which costs coherence) to get there, and the
    score also prefers few seams and a well-covered exemplar. Returns ``(level, references)``
    (``None`` when the pyramid is too short to choose) and the chosen run's results of the
    levels above it, coarsest first, as ``(level, codes)``.

    The runs are independent (their own seeds, the analysis in ``budget.cache`` made first and
    only read): they run side by side, one per core of ``budget.threads``, whose small levels
    keep a core busy each better than one run keeps both; the choice is the same."""
    level = n_levels - 1 - JOINT_SELECT_DEPTH
    if level < 1:
        return None, []
    gentle = dataclasses.replace(balance, weight=balance.weight * JOINT_CANDIDATE_BALANCE)
    inputs = SolverInputs(ex, features, n_levels, config)
    budget.cache.analyse(features, n_levels, config, wrap=canvas.exemplar_wrap, finest=level)

    def candidate(seed: int) -> tuple[float, np.ndarray, list]:
        results: list = []

        def keep(name: str, image: np.ndarray) -> None:
            if name.endswith("_result"):
                results.append((int(name[5:-7]), image.astype(np.int32)))

        run = solve(
            inputs,
            canvas.replace(links=None),
            Budget(seed=int(seed), cache=budget.cache, debug=keep),
            stop_level=level,
            balance=gentle,
        )
        references = run.references[..., 0] * run.exemplar_shape[1] + run.references[..., 1]
        score = start_score(references, run.exemplar_shape[1], balance.shares[level], balance.fractions)
        return score, references.astype(np.int32), results[:-1]

    seeds = rng.integers(0, 2**31, size=JOINT_CANDIDATES)
    runs = side_by_side([functools.partial(candidate, seed) for seed in seeds], budget.threads)
    best = min(runs, key=lambda run: run[0])  # the first of equal scores, as one after the other
    return (level, best[1]), best[2]


#: weight of an edit's guide, as texture-by-numbers' label weight (a pixel whose soft label
#: differs completely from the edit costs this many times the label channels' variance)
EDIT_WEIGHT = 20.0
#: blur of the edit's guide, in pixels of the edited level (its boundaries are that uncertain)
EDIT_SOFTNESS = 0.5
#: weight of E-step votes whose label differs from the edit's (1: they count fully)
EDIT_VOTE_DISCOUNT = 1.0


def upsample_codes(edited: np.ndarray, canvas: Canvas, n_labels: int) -> np.ndarray:
    """An edited level brought to ``canvas.shape`` with smooth boundaries: each label's
    indicator resized bilinearly (wrapping when the canvas tiles), then the largest one per
    pixel (nearest resizing would give staircase boundaries of the level's pixel size)."""
    import cv2

    out_shape = canvas.shape
    h, w = out_shape
    pad = 2 if canvas.tile else 0
    best = np.zeros(out_shape, np.float32) - 1.0
    result = np.zeros(out_shape, np.int32)
    for label in range(n_labels):
        ind = (edited == label).astype(np.float32)
        if pad:
            ind = np.pad(ind, pad, mode="wrap")
        scale_y, scale_x = h / edited.shape[0], w / edited.shape[1]
        big = cv2.resize(
            ind,
            (int(round(ind.shape[1] * scale_x)), int(round(ind.shape[0] * scale_y))),
            interpolation=cv2.INTER_LINEAR,
        )
        if pad:
            oy, ox = int(round(pad * scale_y)), int(round(pad * scale_x))
            big = big[oy : oy + h, ox : ox + w]
        big = cv2.resize(big, (w, h), interpolation=cv2.INTER_LINEAR) if big.shape != (h, w) else big
        better = big > best
        best[better] = big[better]
        result[better] = label
    return result


def edit_guidance(
    codes: np.ndarray,
    features: np.ndarray,
    target: np.ndarray,
    n_labels: int,
    n_levels: int,
    canvas: Canvas,
    *,
    softness: float = 0.0,
    exemplar_levels: list | None = None,
) -> Guidance:
    """The :class:`~barkgen.synth.Guidance` that makes the label engine follow a target
    label map (texture-by-numbers of the label map itself, laitoch2018 §3.3) as a soft guide:
    the target's channels are blurred by ``softness`` px (boundaries may move that much to take
    exemplar shapes), votes of other labels count, and no label is enforced afterwards. The
    exemplar's channels wrap round where it tiles (``canvas.exemplar_wrap``), the target's
    where the output does (``canvas.tile``)."""
    import cv2

    tile, exemplar_wrap = canvas.tile, canvas.exemplar_wrap
    variance = float(features.reshape(-1, features.shape[-1]).var(axis=0).sum())
    guide_a, guide_b = guide_channels(
        codes, target, n_labels, np.sqrt(EDIT_WEIGHT * variance / 2.0), exemplar_wrap=exemplar_wrap, target_wrap=tile
    )
    if softness > 0:
        pad = int(np.ceil(3 * softness)) if tile else 0  # OpenCV blurs cannot wrap: pad first
        padded = np.pad(guide_b, ((pad, pad), (pad, pad), (0, 0)), mode="wrap") if pad else guide_b
        blurred = np.stack(
            [
                cv2.GaussianBlur(padded[..., c], (0, 0), softness, borderType=cv2.BORDER_REFLECT_101)
                for c in range(padded.shape[-1])
            ],
            axis=-1,
        )
        h, w = guide_b.shape[:2]
        guide_b = np.ascontiguousarray(blurred[pad : pad + h, pad : pad + w], dtype=np.float32)
    pyr_a = exemplar_levels or label_pyramid(codes, n_labels, n_levels)
    pyr_b = label_pyramid(target, n_labels, n_levels)

    def initial(a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return smart_initialization(a, b, rng, canvas)

    return Guidance(
        levels=[level_guide(a, b, n_labels) for a, b in zip(pyr_a, pyr_b)],
        exemplar_guides=gaussian_pyramid(guide_a, n_levels),
        target_guides=gaussian_pyramid(guide_b, n_levels),
        initial_references=initial,
        vote_discount=EDIT_VOTE_DISCOUNT,
        cleanup_passes=0,
    )


def estimate_engine_memory(
    exemplar_shape: tuple[int, int], out_shape: tuple[int, int], n_labels: int, *, joint: bool
) -> int:
    """Estimated peak memory (bytes) of :func:`synthesize_codes`: the solver's
    (:func:`barkgen.synth.estimate_memory`) on the label channels (and the photo's three
    colour channels when ``joint``), plus the label pyramids and tables. Measured peaks from
    the 1024x1024 sample's label map: 1024x1024 out 0.39 GiB, 2048x2048 0.53 GiB (joint alike).
    The joint strategy solves down to :data:`JOINT_FINEST_LEVEL` only, then moves the finest
    level's seams: the larger of that solve's and :data:`JOINT_FINEST_BYTES_PER_PIXEL` of the
    output."""
    from barkgen.synth import estimate_memory

    config = JOINT_CONFIG if joint else LABEL_ENGINE_CONFIG
    features = n_labels + (3 if joint else 0)
    n_ex, n_out = exemplar_shape[0] * exemplar_shape[1], out_shape[0] * out_shape[1]
    if not joint:
        return estimate_memory(exemplar_shape, out_shape, 1, 1, features, config) + 24 * (n_ex + n_out)
    finest = finest_level(engine_levels(exemplar_shape, out_shape, config, joint=True), joint=True)
    solved = level_shape(out_shape, finest)
    solve = estimate_memory(exemplar_shape, solved, 1, 1, features, config) + 24 * (n_ex + solved[0] * solved[1])
    return max(solve, int(BASE_BYTES + JOINT_FINEST_BYTES_PER_PIXEL * n_out + 24 * n_ex))


def _features(codes: np.ndarray, n_labels: int, wrap: tuple[bool, bool]) -> np.ndarray:
    """What the engine matches: the soft one-hot label channels (blurred round the exemplar's
    ``wrap``)."""
    return guide_channels(codes, codes[:1, :1], n_labels, 1.0, exemplar_wrap=wrap)[0]


def joint_features(
    codes: np.ndarray, n_labels: int, photo: np.ndarray, wrap: tuple[bool, bool] = (False, False)
) -> np.ndarray:
    """What the joint strategy matches: the photo's CIELAB colour and the soft one-hot label
    channels (blurred round the photo's ``wrap``), scaled so that their total variance is
    :data:`JOINT_LABEL_WEIGHT` times the colour's."""
    colour = matching_features(photo, None, 0.0)
    labels = _features(codes, n_labels, wrap)
    colour_var = float(colour.reshape(-1, colour.shape[-1]).var(axis=0).sum())
    label_var = float(labels.reshape(-1, labels.shape[-1]).var(axis=0).sum())
    scale = np.sqrt(JOINT_LABEL_WEIGHT * colour_var / max(label_var, 1e-12))
    return np.ascontiguousarray(np.concatenate([colour, labels * np.float32(scale)], axis=2), dtype=np.float32)


def analyse_codes(
    codes: np.ndarray,
    n_labels: int,
    out_shape: tuple[int, int],
    cache: AnalysisCache,
    config: SynthesisConfig | None = None,
    photo: np.ndarray | None = None,
    exemplar_wrap: tuple[bool, bool] = (False, False),
) -> AnalysisCache:
    """The k-coherence analysis that :func:`synthesize_codes` needs for outputs of
    ``out_shape`` (with ``photo``: the joint strategy's), run into ``cache`` ahead of any
    synthesis."""
    features, config = _solver_inputs(codes, n_labels, photo, config, exemplar_wrap, cache)
    n_levels = engine_levels(codes.shape, out_shape, config)
    cache.analyse(
        features, n_levels, config, wrap=exemplar_wrap, finest=finest_level(n_levels, joint=photo is not None)
    )
    return cache


def _solver_inputs(
    codes: np.ndarray,
    n_labels: int,
    photo: np.ndarray | None,
    config: SynthesisConfig | None,
    wrap: tuple[bool, bool],
    cache: AnalysisCache,
) -> tuple[np.ndarray, SynthesisConfig]:
    """What the solver matches and its configuration: the engine's (no ``photo``) or the joint
    strategy's, unless ``config`` is given; round the exemplar's ``wrap``; made once per
    exemplar and kept in ``cache`` (every seed matches the same features)."""
    if photo is None:
        features = cache.features("engine", (codes, n_labels, wrap), lambda: _features(codes, n_labels, wrap))
        return features, config or LABEL_ENGINE_CONFIG
    features = cache.features(
        "joint", (codes, n_labels, photo, wrap), lambda: joint_features(codes, n_labels, photo, wrap)
    )
    return features, config or JOINT_CONFIG
