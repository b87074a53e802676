"""barkgen's own quality measures of a result against its photo: what a user or a researcher
wants to know of a synthesised bark texture (``barkgen evaluate OUT --photo P``).

- :func:`coherence` and :func:`completeness`: the two halves of the bidirectional patch
  similarity (every part of the result looks like some part of the photo; the result shows all
  of the photo), CIELAB units;
- :func:`sharpness_ratio` and :func:`colour_distance`: as sharp as the photo, the same colours;
- from a reference map: :func:`largest_copy` (the largest piece pasted whole),
  :func:`seam_mask`, :func:`longest_seam` (the longest straight border between pieces),
  :func:`border_step_ratio` (how visible the borders are in an image or map),
  :func:`border_distance` and :func:`stacked_pieces` (borders that stack two pieces of one
  photo column or row, so the photo's straight edges there run on);
- from a reference map and both label maps: :func:`label_share` (a label's pixels filled from
  that label of the photo) and :func:`direction_agreement` (copied thin lines, a crack
  network's, run the way the target's do);
- from the pixels alone: :func:`longest_line`, the longest straight line in any image or map,
  :func:`wrap_step_ratio`, how visible a tiling image's border is when it repeats, and
  :func:`grid_step_ratio`, how visible a grid of windows or tiles is;
- :func:`evaluate` and :func:`evaluate_folder`: all of them at once, as an :class:`Evaluation`.

The guide is ``docs/guide/evaluate.md``.
"""

from barkgen.evaluate.labels import direction_agreement, label_share
from barkgen.evaluate.lines import grid_step_ratio, line_mask, longest_line, wrap_step_ratio
from barkgen.evaluate.patches import (
    as_lab,
    coherence,
    colour_distance,
    completeness,
    gradient_energy,
    nearest_patch_distances,
    sharpness_ratio,
)
from barkgen.evaluate.report import Evaluation, MapEvaluation, evaluate, evaluate_folder, read_folder
from barkgen.evaluate.seams import (
    border_distance,
    border_step_ratio,
    largest_copy,
    longest_run,
    longest_seam,
    piece_borders,
    piece_labels,
    seam_mask,
    stacked_pieces,
)

__all__ = [
    "Evaluation",
    "MapEvaluation",
    "as_lab",
    "border_distance",
    "border_step_ratio",
    "coherence",
    "colour_distance",
    "completeness",
    "direction_agreement",
    "evaluate",
    "evaluate_folder",
    "gradient_energy",
    "grid_step_ratio",
    "label_share",
    "largest_copy",
    "line_mask",
    "longest_line",
    "longest_run",
    "longest_seam",
    "nearest_patch_distances",
    "piece_borders",
    "piece_labels",
    "read_folder",
    "seam_mask",
    "sharpness_ratio",
    "stacked_pieces",
    "wrap_step_ratio",
]
