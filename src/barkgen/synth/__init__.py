"""Texture synthesis: the k-coherence discrete solver and what is built on it."""

from barkgen.synth.config import SynthesisConfig
from barkgen.synth.solver import (
    LevelAnalysis,
    SynthesisResult,
    analyse_exemplar,
    apply_references,
    estimate_memory,
    matching_features,
    synthesize,
)
from barkgen.synth.tbn import texture_by_numbers

__all__ = [
    "LevelAnalysis",
    "SynthesisConfig",
    "SynthesisResult",
    "analyse_exemplar",
    "apply_references",
    "estimate_memory",
    "matching_features",
    "synthesize",
    "texture_by_numbers",
]
