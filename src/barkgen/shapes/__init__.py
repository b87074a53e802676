"""Output label maps: new label maps of any size that look like the exemplar's (laitoch2018
§3.6, Rosenberger et al. 2009).

Three strategies:

* ``"engine"`` (default): the core k-coherence engine synthesizes the label map itself from
  soft one-hot label channels (:mod:`barkgen.shapes.engine`); every label keeps its area and its
  boundary shapes, for any number of labels.
* ``"joint"`` (the default of :mod:`barkgen.pipeline`): the same engine matching the photo's
  colours along the label channels, so the label map's pieces also fit together in the photo;
  it needs the photo (``photo=``).
* ``"layered"``: the thesis' method, layered binary shape synthesis by boundary-patch matching
  and shape adjustment (:mod:`barkgen.shapes.binary`, :mod:`barkgen.shapes.layered`), with an
  automatic layer order.

Both work coarse to fine over a pyramid whose levels can be returned (``result.levels``) and
resumed from after an edit (``resume=(level, label_map)``), and both can tile. The output's
shape, tile, exemplar wrap and flow field come in one :class:`Canvas`, the seed, progress,
cache and memory budget in one :class:`Budget`.
"""

from barkgen._shared.canvas import Budget, Canvas
from barkgen.shapes.api import (
    STRATEGIES,
    LabelMapResult,
    analyse_label_map,
    label_map_levels,
    synthesize_label_map,
)
from barkgen.shapes.binary import ShapeConfig
from barkgen.shapes.layered import automatic_layer_order
from barkgen.shapes.patches import (
    ROTATIONS,
    check_rotations,
    label_dissimilarity,
    shape_dissimilarity,
)

__all__ = [
    "Budget",
    "Canvas",
    "LabelMapResult",
    "ROTATIONS",
    "check_rotations",
    "STRATEGIES",
    "ShapeConfig",
    "analyse_label_map",
    "label_dissimilarity",
    "automatic_layer_order",
    "label_map_levels",
    "shape_dissimilarity",
    "synthesize_label_map",
]
