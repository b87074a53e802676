"""The one-click pipeline, photo -> new bark (laitoch2018 §1): :func:`generate` (arrays in,
arrays out; :mod:`barkgen.pipeline.core`) and the files of one run, encoded
(:func:`encode_generate`; :mod:`barkgen.pipeline.files`), which ``barkgen generate``,
``barkgen batch`` and the web app write, with an edit list's depth and light given to the set
(:func:`adjusted_result`), and :func:`warm_up`, which compiles the numba kernels
of a run ahead (:mod:`barkgen.pipeline.warmup`); :func:`cached_analysis`, a photo's analysis
once per photo on disk (:class:`AnalysisStore`, :mod:`barkgen.pipeline.analysis_cache`); :func:`make_tree`, bark for a whole tree mesh
(:mod:`barkgen.pipeline.tree`)."""

from barkgen._shared.lazy import lazy_getattr, stub_names

# the names and their modules are in __init__.pyi; each module is imported on first use (the
# CLI's start-up imports this package for its options, not its kernels)
_LAZY = stub_names(__file__)
__all__ = sorted(_LAZY)
__getattr__ = lazy_getattr(__name__, _LAZY)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
