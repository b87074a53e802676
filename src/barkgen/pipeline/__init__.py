"""The one-click pipeline, photo -> new bark (laitoch2018 §1): :func:`generate` (arrays in,
arrays out; :mod:`barkgen.pipeline.core`) and the files of one run, encoded
(:func:`encode_generate`; :mod:`barkgen.pipeline.files`), which ``barkgen generate``,
``barkgen batch`` and the web app write, with an edit list's depth and light given to the set
(:func:`adjusted_result`), and :func:`warm_up`, which compiles the numba kernels
of a run ahead (:mod:`barkgen.pipeline.warmup`); :func:`cached_analysis`, a photo's analysis
once per photo on disk (:class:`AnalysisStore`, :mod:`barkgen.pipeline.analysis_cache`); :func:`make_tree`, bark for a whole tree mesh
(:mod:`barkgen.pipeline.tree`)."""

from barkgen.pipeline.adjusted import adjusted_result, check_edit_list
from barkgen.pipeline.analysis_cache import AnalysisStore, cached_analysis, open_store
from barkgen.pipeline.core import (
    ANALYSIS_SEED,
    GenerateResult,
    PhotoAnalysis,
    analyze_photo,
    generate,
)
from barkgen.pipeline.files import (
    GENERATE_FILES,
    LAYOUTS,
    check_generate_names,
    encode_generate,
    parse_sizes,
    run_file_names,
    sized_options,
)
from barkgen.pipeline.options import LABEL_METHODS, GenerateOptions, analysis_key
from barkgen.pipeline.progress import stage_at, stage_span
from barkgen.pipeline.report import preview_sheet
from barkgen.pipeline.tree import TreeResult, encode_tree, make_tree
from barkgen.pipeline.warmup import warm_up

__all__ = [
    "LAYOUTS",
    "run_file_names",
    "ANALYSIS_SEED",
    "adjusted_result",
    "AnalysisStore",
    "cached_analysis",
    "open_store",
    "check_edit_list",
    "GENERATE_FILES",
    "check_generate_names",
    "LABEL_METHODS",
    "GenerateOptions",
    "GenerateResult",
    "PhotoAnalysis",
    "TreeResult",
    "analysis_key",
    "analyze_photo",
    "encode_generate",
    "encode_tree",
    "generate",
    "make_tree",
    "parse_sizes",
    "preview_sheet",
    "sized_options",
    "stage_at",
    "stage_span",
    "warm_up",
]
