"""Texture synthesis: the k-coherence discrete solver and what is built on it; this module is
the package's one face, the names every other package uses.

The fronts: :func:`synthesize` and :func:`apply_references` (mazzolini2012 §4.1, laitoch2018
§3.3), texture-by-numbers (:func:`texture_by_numbers`, laitoch2018 §3.1-3.4); both run through
one set-up (``_setup``: inputs, memory budget, the exemplar's wrap, features, levels). For the
packages that drive the solver themselves (:mod:`barkgen.shapes`): :func:`solve` with its
:class:`SolverInputs`, the output's :class:`Canvas` and the run's :class:`Budget`, a
:class:`Guidance`, a :class:`LabelBalance` or an :class:`AnalysisCache`, and what makes a guide
from label maps and moves seams.

Inside, private: the solver's core (``_config``, ``_analysis``: what is matched and the
per-exemplar analysis; ``_solver``: the coarse-to-fine iterations; ``_occurrence``: costs that
spread references over the exemplar; ``_edges``: the exemplar's wrap; ``_kernels``), and two
wings used only within synth: :mod:`.seams` (copy-size control and border seams, graph cuts,
expansion moves, the gradient-domain blend; kwatra2003) and :mod:`.guides` (texture-by-numbers'
guide channels, guidance, initialisation).
"""

from barkgen._shared.canvas import Budget, Canvas
from barkgen.synth._analysis import AnalysisCache, LevelAnalysis, analyse_exemplar, matching_features
from barkgen.synth._config import SynthesisConfig
from barkgen.synth._edges import check_wrap_mode, exemplar_wraps, resolve_exemplar_wrap
from barkgen.synth._flow import FLOW_SCALE_RANGE, OrientedExemplar, check_flow, orient_exemplar
from barkgen.synth._links import OutputLinks
from barkgen.synth._occurrence import LabelBalance
from barkgen.synth._setup import estimate_memory
from barkgen.synth._solver import DebugCallback, SolverInputs, SynthesisResult, solve, upsample_references
from barkgen.synth._synthesize import apply_references, synthesize
from barkgen.synth._tbn import TBN_CONFIG, analyse_texture_by_numbers, texture_by_numbers
from barkgen.synth.guides.channels import MAX_LABELS, guide_channels, label_pyramid, level_guide
from barkgen.synth.guides.guidance import Guidance
from barkgen.synth.guides.initialization import smart_initialization
from barkgen.synth.seams.cuts import cut_straight_seams
from barkgen.synth.seams.expansion import exemplar_grid, expand_pieces
from barkgen.synth.seams.gradient import (
    blend_seams,
    check_blend,
    piece_borders,
    resolve_continuous,
    resolve_local,
    screened_poisson,
)

__all__ = [
    "FLOW_SCALE_RANGE",
    "MAX_LABELS",
    "TBN_CONFIG",
    "AnalysisCache",
    "Budget",
    "Canvas",
    "DebugCallback",
    "Guidance",
    "LabelBalance",
    "LevelAnalysis",
    "OrientedExemplar",
    "OutputLinks",
    "SolverInputs",
    "SynthesisConfig",
    "SynthesisResult",
    "analyse_exemplar",
    "analyse_texture_by_numbers",
    "apply_references",
    "blend_seams",
    "check_blend",
    "check_flow",
    "check_wrap_mode",
    "cut_straight_seams",
    "estimate_memory",
    "exemplar_grid",
    "exemplar_wraps",
    "expand_pieces",
    "guide_channels",
    "label_pyramid",
    "level_guide",
    "matching_features",
    "orient_exemplar",
    "piece_borders",
    "resolve_continuous",
    "resolve_local",
    "screened_poisson",
    "resolve_exemplar_wrap",
    "smart_initialization",
    "solve",
    "synthesize",
    "texture_by_numbers",
    "upsample_references",
]
