"""Texture synthesis: the k-coherence discrete solver and what is built on it.

The public API is :func:`synthesize` and :func:`apply_references` (:mod:`.api`) and
texture-by-numbers (:mod:`.tbn`); :mod:`.engine` is the solver's face for the packages built on
it. Inside: :mod:`.analysis` (what is matched, the per-exemplar analysis), :mod:`.solver` (the
coarse-to-fine iterations), :mod:`.occurrence` (costs that spread references over the
exemplar), :mod:`.pieces` (copy-size control, border seams, seam cuts), :mod:`.cuts`,
:mod:`.gradient`, :mod:`.edges`, :mod:`.guide`, :mod:`.initialization` and the numba kernels.
"""

from barkgen.synth.config import SynthesisConfig
from barkgen.synth.edges import exemplar_wraps
from barkgen.synth.analysis import AnalysisCache, LevelAnalysis, analyse_exemplar, matching_features
from barkgen.synth.api import apply_references, estimate_memory, synthesize
from barkgen.synth.solver import SynthesisResult
from barkgen.synth.tbn import analyse_texture_by_numbers, texture_by_numbers

__all__ = [
    "AnalysisCache",
    "LevelAnalysis",
    "SynthesisConfig",
    "SynthesisResult",
    "analyse_exemplar",
    "analyse_texture_by_numbers",
    "apply_references",
    "estimate_memory",
    "exemplar_wraps",
    "matching_features",
    "synthesize",
    "texture_by_numbers",
]
