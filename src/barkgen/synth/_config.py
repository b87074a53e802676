"""Typed, validated configuration of the synthesizer."""

from __future__ import annotations

from dataclasses import dataclass

from barkgen._shared.memory import check_budget_value
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
    """

    k: int = 6
    pca_components: int = 8
    coarsest_exemplar: int = 16
    schedule_coarsest: Schedule = ((9, 5), (7, 3), (5, 2))
    schedule_middle: Schedule = ((9, 2), (5, 1))
    schedule_finest: Schedule = ((5, 1),)
    vote_radius: int = 3
    kset_cost: float = 2.0
    occurrence_weight: float = 1.0
    max_copy: float = 0.2
    jitter: float = 0.0
    seam_sweeps: int = 4
    seam_cut_run: int = 24
    seam_cut_levels: int = 2
    seam_expansion_band: int = 8
    seam_expansion_rounds: int = 1
    extra_weight: float = 0.5
    blend: str = "gradient"
    threads: int | None = None
    max_memory: int | None = None

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

    def schedule_for(self, level: int, n_levels: int) -> Schedule:
        """The (size, iterations) pairs of pyramid level ``level`` (0 = finest)."""
        if level == n_levels - 1:
            return self.schedule_coarsest
        if level == 0:
            return self.schedule_finest
        return self.schedule_middle
