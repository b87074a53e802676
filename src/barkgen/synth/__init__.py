"""Texture synthesis: the k-coherence discrete solver and what is built on it."""

from barkgen.synth.config import SynthesisConfig
from barkgen.synth.edges import exemplar_wraps
from barkgen.synth.solver import (
    AnalysisCache,
    LevelAnalysis,
    SynthesisResult,
    analyse_exemplar,
    apply_references,
    estimate_memory,
    matching_features,
    synthesize,
)
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
