"""Typed, validated configuration of the synthesizer (laitoch2018 §3.3): every field declared
with :func:`barkgen._shared.options.option`, the CLI's ``--threads``, ``--max-memory`` and
``--blend`` among them."""

from __future__ import annotations

from dataclasses import dataclass

from barkgen._shared.memory import check_budget_value, parse_memory
from barkgen._shared.options import check_options, option
from barkgen.errors import InvalidInputError

#: (neighbourhood size, iterations) pairs run at the coarsest, middle and finest levels.
Schedule = tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class SynthesisConfig:
    """Parameters of the k-coherence discrete solver.

    Defaults are tuned on the bark photos of the team's evaluation set (see the docs'
    benchmark pages); every field is validated once, here.

    Attributes
    ----------
    k
        size of each k-coherence set (Tong 2002).
    pca_components
        appearance-space dimensions (Lefebvre & Hoppe 2006).
    coarsest_exemplar
        short side, in pixels, of the exemplar's coarsest pyramid level.
    schedule_coarsest, schedule_middle, schedule_finest
        ``(size, iterations)`` pairs run at
        each level: several neighbourhood sizes per level, largest first (Kwatra 2005).
    vote_radius
        the E-step takes votes from matched neighbourhoods centred at most this far
        from the pixel (all that cover it when the neighbourhood is smaller); 3 is as good as
        the full 9x9 window on our bark set and 30 % faster.
    kset_cost
        extra cost of a non-coherent candidate, in units of the typical
        nearest-neighbour distance (favours coherent patches, Ashikhmin 2001).
    occurrence_weight
        weight of the occurrence cost: exemplar regions used more often than
        the uniform expectation are penalised, unused ones favoured (Kaspar 2015 occurrence
        maps), same units.
    max_copy
        largest piece copied verbatim from the exemplar, as a fraction of the
        exemplar's area; larger pieces are cut (1.0 disables the control).
    jitter
        after up-sampling to levels 2 and coarser, every reference is displaced by a
        seeded random offset of up to ``round(2 * jitter)`` pixels (Lefebvre & Hoppe 2005).
        Off by default: the random initialisation and per-level random grid offsets already
        give seeds independent results, and jitter measurably costs coherence.
    seam_sweeps
        sweeps of seam optimisation after each level's iterations (Kwatra et al.
        2003's seam cost, minimised by local moves: ``seams._kernels.refine_seams``); 0 disables.
    seam_cut_run
        straight seams at least this long are re-cut along minimum-cost paths
        (graph cuts, Kwatra et al. 2003: :mod:`barkgen.synth.seams.cuts`); 0 disables.
    seam_cut_levels
        how many of the finest levels get those cuts.
    seam_expansion_band
        at the finest level, every copied piece may move its border this far (pixels) where
        that lowers the seam cost (expansion moves, Boykov et al. 2001:
        :mod:`barkgen.synth.seams.expansion`); 0 disables.
    seam_expansion_rounds
        how many times every piece gets such a move.
    extra_weight
        weight of the extra channels relative to luminance in the matching.
    blend
        how the output's colour is made from its references: ``"gradient"`` blends the seams
        between pieces in the gradient domain (:func:`barkgen.synth.blend_seams`),
        ``"none"`` copies every pixel exactly (as :func:`apply_references` does).
    threads
        worker threads for numba/faiss (None: all cores).
    max_memory
        refuse jobs whose estimated peak memory exceeds this many bytes (None: what the
        machine has free when the job starts).
    window
        the finest levels larger than a window of this side (px) plus its halo are solved
        window by window, each core with a frozen halo of its neighbours
        (:mod:`barkgen.synth._windows`); 0: every level whole.
    """

    k: int = option(6, "Size of each k-coherence set (Tong 2002).", kind=int, minimum=1, maximum=32, fronts=())
    pca_components: int = option(
        8, "Appearance-space dimensions (Lefebvre & Hoppe 2006).", kind=int, minimum=1, maximum=64, fronts=()
    )
    coarsest_exemplar: int = option(
        16, "Short side, px, of the exemplar's coarsest pyramid level.", kind=int, minimum=8, fronts=()
    )
    schedule_coarsest: Schedule = option(
        ((9, 5), (7, 3), (5, 2)), "(size, iterations) pairs of the coarsest level (Kwatra 2005).", fronts=()
    )
    schedule_middle: Schedule = option(((9, 2), (5, 1)), "(size, iterations) pairs of the middle levels.", fronts=())
    schedule_finest: Schedule = option(((5, 1),), "(size, iterations) pairs of the finest level.", fronts=())
    vote_radius: int = option(
        3, "The E-step's votes from neighbourhoods centred at most this far.", kind=int, minimum=1, maximum=7, fronts=()
    )
    kset_cost: float = option(
        2.0, "Extra cost of a non-coherent candidate (Ashikhmin 2001).", kind=float, minimum=0, fronts=()
    )
    occurrence_weight: float = option(
        1.0, "Weight of the occurrence cost (Kaspar 2015).", kind=float, minimum=0, fronts=()
    )
    max_copy: float = option(
        0.2,
        "Largest piece copied verbatim, a fraction of the exemplar's area.",
        kind=float,
        minimum=0,
        maximum=1,
        fronts=(),
    )
    jitter: float = option(
        0.0, "Jitter of the up-sampled references (Lefebvre & Hoppe 2005).", kind=float, minimum=0, fronts=()
    )
    seam_sweeps: int = option(
        4, "Sweeps of seam optimisation after each level (Kwatra 2003).", kind=int, minimum=0, maximum=64, fronts=()
    )
    seam_cut_run: int = option(
        24,
        "Straight seams at least this long re-cut by graph cuts; 0: off.",
        kind=int,
        minimum=0,
        maximum=4096,
        fronts=(),
    )
    seam_cut_levels: int = option(2, "Finest levels that get those cuts.", kind=int, minimum=0, maximum=16, fronts=())
    seam_expansion_band: int = option(
        8, "Expansion moves' reach, px (Boykov 2001); 0: off.", kind=int, minimum=0, maximum=64, fronts=()
    )
    seam_expansion_rounds: int = option(
        1, "Expansion moves of every piece.", kind=int, minimum=1, maximum=16, fronts=()
    )
    extra_weight: float = option(
        0.5, "Weight of the extra channels relative to luminance.", kind=float, minimum=0, fronts=()
    )
    blend: str = option(
        "gradient",
        "gradient: the colour's seams between copied pieces blended in the gradient "
        "domain (Pérez et al. 2003); none: every pixel an exact copy of the photo's.",
        choices=("gradient", "none"),
        fronts=("cli",),
    )
    threads: int | None = option(None, "Worker threads (default: all cores).", kind=int, minimum=1, fronts=("cli",))
    window: int = option(
        0, "Side, px, of the windows large levels are solved in; 0: whole.", kind=int, minimum=0, fronts=()
    )
    max_memory: int | None = option(
        None,
        "Refuse jobs estimated to need more memory than this, e.g. 8G (default: what the machine has free).",
        parse=parse_memory,
        fronts=("cli",),
    )

    def __post_init__(self) -> None:
        if not 1 <= self.k <= 32:
            raise InvalidInputError(f"k must be between 1 and 32, not {self.k}")
        if not 1 <= self.pca_components <= 64:
            raise InvalidInputError("pca_components must be between 1 and 64")
        if self.coarsest_exemplar < 8:
            raise InvalidInputError("coarsest_exemplar must be at least 8 px")
        for name in ("schedule_coarsest", "schedule_middle", "schedule_finest"):
            sched = getattr(self, name)
            if not sched:
                raise InvalidInputError(f"{name} must list at least one (size, iterations) pair")
            for size, iters in sched:
                if size < 3 or size % 2 == 0 or size > 15:
                    raise InvalidInputError(f"{name}: neighbourhood size must be odd, 3..15, not {size}")
                if iters < 0:
                    raise InvalidInputError(f"{name}: iterations must be >= 0")
        if not 1 <= self.vote_radius <= 7:
            raise InvalidInputError("vote_radius must be between 1 and 7")
        if self.window != 0 and self.window < 64:
            raise InvalidInputError(f"window must be 0 (whole levels) or at least 64 px, not {self.window}")
        for name in ("kset_cost", "occurrence_weight", "jitter", "extra_weight"):
            if getattr(self, name) < 0:
                raise InvalidInputError(f"{name} must be >= 0")
        if not 0 <= self.seam_sweeps <= 64:
            raise InvalidInputError("seam_sweeps must be between 0 and 64")
        if self.seam_cut_run != 0 and not 4 <= self.seam_cut_run <= 4096:
            raise InvalidInputError("seam_cut_run must be 0 (off) or between 4 and 4096")
        if not 0 <= self.seam_cut_levels <= 16:
            raise InvalidInputError("seam_cut_levels must be between 0 and 16")
        if not 0 <= self.seam_expansion_band <= 64:
            raise InvalidInputError("seam_expansion_band must be between 0 and 64")
        if not 1 <= self.seam_expansion_rounds <= 16:
            raise InvalidInputError("seam_expansion_rounds must be between 1 and 16")
        if not 0.0 < self.max_copy <= 1.0:
            raise InvalidInputError("max_copy must be in (0, 1]")
        from barkgen.synth.seams.gradient import check_blend

        check_blend(self.blend)
        if self.threads is not None and self.threads < 1:
            raise InvalidInputError("threads must be >= 1")
        check_budget_value(self.max_memory)
        check_options(self)

    def schedule_for(self, level: int, n_levels: int) -> Schedule:
        """The (size, iterations) pairs of pyramid level ``level`` (0 = finest)."""
        if level == n_levels - 1:
            return self.schedule_coarsest
        if level == 0:
            return self.schedule_finest
        return self.schedule_middle


#: solver defaults for texture-by-numbers: label structure needs a coarsest level where the
#: label regions still exist, so the pyramid stops at 32 px instead of 16; the initialisation
#: and the guide already set the layout, so fewer and smaller iterations per level and 6
#: appearance dimensions give the same quality (measured on the bark set, benchmarks/bench_tbn.py);
#: label boundaries break its seams into short stretches, so stretches from 8 px are re-cut
#: (the texture's step ratio across seams on the sample, seeds 0/1: 1.54/1.47 -> 1.51/1.45);
#: no expansion moves: the labels pin most borders (generate's texture step ratio, sample seed
#: 0: 1.43 with them, 1.40 without, once the label map's own seams have had them)
TBN_CONFIG = SynthesisConfig(
    coarsest_exemplar=32,
    schedule_coarsest=((9, 3), (7, 2), (5, 2)),
    schedule_middle=((7, 1), (5, 1)),
    pca_components=6,
    seam_cut_run=8,
    seam_expansion_band=0,
)
