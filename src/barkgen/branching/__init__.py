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

from barkgen.branching.edit import (
    add_furcation,
    delete_branch,
    extend_branch,
    nearest_branch,
    rectify_perspective,
)
from barkgen.branching.extract import extract_structure, overlay_structure
from barkgen.branching.grow import grow_structure
from barkgen.branching.growth_options import GrowOptions, check_grow_size, estimate_grow_memory
from barkgen.branching.mask import crack_mask
from barkgen.branching.model import BranchModel, ModelOptions, fit_model
from barkgen.branching.render import RenderOptions, RenderResult, render_branches
from barkgen.branching.stats import (
    StructureComparison,
    compare_structures,
    comparison_plot,
    self_intersections,
)
from barkgen.branching.structure import (
    STRUCTURE_VERSION,
    Branch,
    Structure,
    rasterize,
    resample_polyline,
    turning_angles,
)

__all__ = [
    "STRUCTURE_VERSION",
    "Branch",
    "BranchModel",
    "GrowOptions",
    "ModelOptions",
    "RenderOptions",
    "RenderResult",
    "Structure",
    "StructureComparison",
    "add_furcation",
    "check_grow_size",
    "compare_structures",
    "comparison_plot",
    "crack_mask",
    "delete_branch",
    "estimate_grow_memory",
    "extend_branch",
    "extract_structure",
    "fit_model",
    "grow_structure",
    "nearest_branch",
    "overlay_structure",
    "rasterize",
    "rectify_perspective",
    "render_branches",
    "resample_polyline",
    "self_intersections",
    "turning_angles",
]
