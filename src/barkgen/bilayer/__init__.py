"""Bi-layer textures (guingo2017): a structure layer plus spatially varying Gaussian noise,
analysed from one photo and synthesized window by window over an unbounded plane.

:func:`analyze` makes a :class:`BilayerModel` (options: :class:`AnalysisOptions`);
:meth:`BilayerModel.window` synthesizes any window (options: :class:`SynthesisOptions`,
:class:`Deformation`); :func:`tune_sheet` and :func:`analysis_preview` are pictures for the
user; the model's file is written and read by :mod:`barkgen.io`.

References
----------
.. [1] guingo2017: Guingo, Sauvage, Dischler, Cani (2017), Bi-Layer textures: a model for
   synthesis and deformation of composite textures, Computer Graphics Forum 36(4).

Examples
--------
>>> import barkgen
>>> from barkgen.bilayer import analyze, AnalysisOptions
>>> photo = barkgen.read_image(barkgen.sample_exemplar_path())[:64, :64]
>>> model = analyze(photo, AnalysisOptions(k=2, tloc=8))
>>> model.window(0, 0, 96, 64, seed=1).shape
(64, 96, 3)
"""

from barkgen.bilayer.analysis import analyze
from barkgen.bilayer.model import BilayerModel, single_layer
from barkgen.bilayer.options import AnalysisOptions, SynthesisOptions
from barkgen.bilayer.sheets import analysis_preview, tune_sheet
from barkgen.bilayer.spectra import TLOC_CHOICES, estimate_spectrum, local_spectra
from barkgen.bilayer.tiles import Deformation

__all__ = [
    "AnalysisOptions",
    "BilayerModel",
    "Deformation",
    "SynthesisOptions",
    "TLOC_CHOICES",
    "analysis_preview",
    "analyze",
    "estimate_spectrum",
    "local_spectra",
    "single_layer",
    "tune_sheet",
]
