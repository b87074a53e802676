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

from barkgen._shared.lazy import lazy_getattr, stub_names

# the names and their modules are in __init__.pyi; each module is imported on first use (the
# CLI's start-up imports this package for its options, not its solver)
_LAZY = stub_names(__file__)
__all__ = sorted(_LAZY)
__getattr__ = lazy_getattr(__name__, _LAZY)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
