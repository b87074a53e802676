"""The solver's face for the packages built on it (:mod:`barkgen.shapes`, texture-by-numbers):
the discrete solver itself and what drives it, without the checks of the public API.

:func:`solve` runs the coarse-to-fine k-coherence solver (mazzolini2012 §4.1, laitoch2018 §3.3)
on features made by :func:`matching_features`; a :class:`Guidance` turns it into
texture-by-numbers, a :class:`LabelBalance` keeps the label areas of a label map, an
:class:`AnalysisCache` shares the exemplar analysis between runs. :func:`validate_inputs` and
:func:`check_memory` are the public API's checks, for callers that build their own front.
"""

from barkgen.synth.analysis import AnalysisCache, LevelAnalysis, matching_features
from barkgen.synth.api import check_memory, validate_inputs
from barkgen.synth.occurrence import LabelBalance
from barkgen.synth.solver import DebugCallback, Guidance, SynthesisResult, solve

__all__ = [
    "AnalysisCache",
    "DebugCallback",
    "Guidance",
    "LabelBalance",
    "LevelAnalysis",
    "SynthesisResult",
    "check_memory",
    "matching_features",
    "solve",
    "validate_inputs",
]
