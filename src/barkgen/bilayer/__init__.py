"""Bi-layer textures (guingo2017): a structure layer plus spatially varying Gaussian noise,
analysed from one photo and synthesized window by window over an unbounded plane.

    >>> from barkgen.bilayer import analyze, AnalysisOptions
    >>> model = analyze(photo, AnalysisOptions(k=2, tloc=8))
    >>> texture = model.window(0, 0, 1024, 1024, seed=1)

References:
    Guingo, Sauvage, Dischler, Cani (2017), Bi-Layer textures: a model for synthesis and
    deformation of composite textures, Computer Graphics Forum 36(4).
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
