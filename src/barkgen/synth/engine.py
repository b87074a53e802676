"""The solver's face for the packages built on it (:mod:`barkgen.shapes`, texture-by-numbers):
the discrete solver itself and what drives it, without the checks of the public API.

:func:`solve` runs the coarse-to-fine k-coherence solver (mazzolini2012 §4.1, laitoch2018 §3.3)
on features made by :func:`matching_features`; a :class:`Guidance` turns it into
texture-by-numbers, a :class:`LabelBalance` keeps the label areas of a label map, an
:class:`AnalysisCache` shares the exemplar analysis between runs. :func:`validate_inputs` and
:func:`check_memory` are the public API's checks, for callers that build their own front
(:func:`estimate_memory` the solver's estimate they check);
:func:`label_pyramid`, :func:`level_guide`, :func:`guide_channels` and
:func:`smart_initialization` make a guide from label maps (laitoch2018 §3.3-3.4);
:func:`expand_pieces` moves a reference map's seams onto low-error paths (kwatra2003 §3,
boykov2001), on an exemplar grid made by :func:`exemplar_grid`, and :func:`cut_straight_seams`
re-cuts the straight stretches left (kwatra2003 §3).
"""

from barkgen.synth.analysis import AnalysisCache, LevelAnalysis, matching_features
from barkgen.synth.api import check_memory, estimate_memory, validate_inputs
from barkgen.synth.config import SynthesisConfig
from barkgen.synth.cuts import cut_straight_seams
from barkgen.synth.edges import resolve_exemplar_wrap
from barkgen.synth.expansion import exemplar_grid, expand_pieces
from barkgen.synth.guide import guide_channels, label_pyramid, level_guide
from barkgen.synth.initialization import smart_initialization
from barkgen.synth.occurrence import LabelBalance
from barkgen.synth.solver import DebugCallback, Guidance, SynthesisResult, solve, upsample_references

__all__ = [
    "AnalysisCache",
    "DebugCallback",
    "Guidance",
    "LabelBalance",
    "LevelAnalysis",
    "SynthesisConfig",
    "SynthesisResult",
    "check_memory",
    "cut_straight_seams",
    "estimate_memory",
    "exemplar_grid",
    "expand_pieces",
    "guide_channels",
    "label_pyramid",
    "level_guide",
    "matching_features",
    "resolve_exemplar_wrap",
    "smart_initialization",
    "solve",
    "upsample_references",
    "validate_inputs",
]
