"""barkgen: turn one photograph of tree bark into unlimited new, seamless, varied bark.

The public API is imported lazily so that ``import barkgen`` (and the CLI's start-up) stays
cheap: numba kernels compile (once, cached on disk) only when first used.

Public names
------------
Synthesis (:mod:`barkgen.synth`)
    :func:`synthesize`, :func:`texture_by_numbers`, :func:`apply_references`,
    :class:`SynthesisConfig`, :class:`SynthesisResult`; :class:`Canvas` (the output: its
    shape, tiling, the exemplar's wrap, flow fields, links) and :class:`Budget` (the run's
    seed, threads, memory, progress, cache), the two objects a run hands down its stages.
The one-click pipeline (:mod:`barkgen.pipeline`)
    :func:`generate`, :class:`GenerateOptions`, :class:`GenerateResult`; :func:`warm_up`
    compiles the numba kernels ahead (about 30 s once per install; the first run that has to
    compile them logs a warning on the ``barkgen`` logger naming it).
Label maps (:mod:`barkgen.shapes`, :mod:`barkgen.labels`)
    :func:`synthesize_label_map`.
Material maps and the trunk (:mod:`barkgen.material`, :mod:`barkgen.render`)
    :func:`make_material`, :class:`MaterialOptions`, :class:`MaterialSet`,
    :class:`HeightEditor`, :func:`render_trunk`, :func:`trunk_mesh`.
Files (:mod:`barkgen.io`) and data
    :func:`read_image`, :func:`write_png`, :func:`sample_exemplar_path`.
Errors (:mod:`barkgen.errors`)
    :class:`BarkgenError`.
``__version__``
    The package version.

More in the subpackages: :mod:`barkgen.labels`, :mod:`barkgen.bilayer`,
:mod:`barkgen.branching`, :mod:`barkgen.batch` (``[batch]`` extra), :mod:`barkgen.library`;
``examples/`` in the repository has one script per feature, and ``docs/references.bib`` the
papers the docstrings cite (laitoch2018, mazzolini2012, wang2003, guingo2017, sibbing2010, ...).

Examples
--------
>>> import barkgen
>>> exemplar = barkgen.read_image(barkgen.sample_exemplar_path())[:64, :64]
>>> barkgen.synthesize(exemplar, (48, 80), seed=1).image.shape
(48, 80, 3)
"""

from __future__ import annotations

from barkgen._shared.lazy import lazy_getattr, stub_names
from barkgen._version import __version__


def _watch_compiles() -> None:
    """A word if the kernels of the module just imported compile (once numba is loaded)."""
    import sys

    if "numba" in sys.modules:
        from barkgen._shared.compile_notice import watch

        watch()


#: public name -> its module, from ``__init__.pyi`` (the one list of public names)
_LAZY = stub_names(__file__, skip=("barkgen._version",))

__all__ = sorted(_LAZY) + ["__version__"]


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__getattr__ = lazy_getattr(__name__, _LAZY, on_import=_watch_compiles)
