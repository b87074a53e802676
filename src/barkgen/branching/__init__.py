"""Branching structures (sibbing2010): extract crack networks, grow new ones, render them.

- :mod:`~barkgen.branching.structure`: the data model (polylines with thickness, furcations,
  merges) and its JSON form (§3, §4.1);
- :mod:`~barkgen.branching.extract`: the crack network of an image, automatically (the crack
  mask in :mod:`~barkgen.branching.mask`, its skeleton graph in :mod:`~barkgen.branching.graph`);
- :mod:`~barkgen.branching.model` and :mod:`~barkgen.branching.grow`: the statistical model and
  growth (§4) with merges;
- :mod:`~barkgen.branching.render`: fragment-based image synthesis (§5) with the gaps filled by
  the core engine;
- :mod:`~barkgen.branching.stats`: the Fig. 7 evaluation as numbers and a plot;
- :mod:`~barkgen.branching.edit`: the user's edits of §6 (extend a branch, add a furcation,
  delete a sub-branch) and a photo's perspective rectified before extraction (Fig. 8).
"""

from barkgen._shared.lazy import lazy_getattr, stub_names

# the names and their modules are in __init__.pyi; each module is imported on first use (the
# CLI's start-up imports this package for its options, not its kernels)
_LAZY = stub_names(__file__)
__all__ = sorted(_LAZY)
__getattr__ = lazy_getattr(__name__, _LAZY)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
