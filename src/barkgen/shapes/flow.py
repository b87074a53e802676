"""Label maps along a flow field: the engine and joint strategies of
:func:`barkgen.shapes.synthesize_label_map` when the output carries an orientation (and scale)
field (mazzolini2012 §3.1.3).

The solver runs on the atlas of the exemplar's turned copies (:mod:`barkgen.synth._flow`),
matching the photo's colour with the labels (joint) or the labels alone (engine, as label
colours), the labels as one channel each; the output label map is the exemplar's labels through
the references, exactly (nearest pixel of each copy), so texture-by-numbers can start from the
same references.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.canvas import Budget, Canvas
from barkgen.synth import SynthesisResult


def codes_along_flow(
    codes: np.ndarray, n_labels: int, canvas: Canvas, budget: Budget, photo: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, SynthesisResult]:
    """Label codes ``(H, W)`` along the fields, their reference map into the atlas of
    turned copies (``(H, W, 2)``; the atlas is :func:`barkgen.synth.orient_exemplar`'s of the
    same fields, whatever the seed, with room for the labels: the one texture-by-numbers
    makes after it), and the synthesis they come from (its ``extras`` without the labels).
    ``canvas`` carries the fields, the links, the tile and the photo's resolved wrap;
    ``budget`` the seed and the progress callback."""
    from barkgen.labels import label_colour_map
    from barkgen.synth import MAX_LABELS, check_flow, orient_exemplar, synthesize

    # the atlas texture-by-numbers will use after it (its labels paired with these copies)
    out_shape, exemplar_wrap = canvas.shape, canvas.exemplar_wrap
    fields = check_flow(canvas.flow, canvas.flow_scale, out_shape)
    oriented = orient_exemplar(codes.shape, *fields, wrap=exemplar_wrap, max_copies=(MAX_LABELS - 1) // n_labels)
    one_hot = (codes[..., None] == np.arange(n_labels)[None, None, :]).astype(np.float32)
    exemplar = photo if photo is not None else label_colour_map(codes.astype(np.uint8))
    # the label map's own budget: its seed, threads and progress (not the label map's analysis)
    result = synthesize(
        exemplar,
        extra={"labels": one_hot},
        canvas=canvas.replace(oriented=oriented),
        budget=Budget(seed=int(budget.seed), threads=budget.threads, progress=budget.progress),
    )
    atlas_codes = result.orientation.atlas(codes.astype(np.int32), kind="labels")
    refs = result.references
    result.extras.pop("labels", None)
    result.extra_wraps.pop("labels", None)
    return atlas_codes[refs[..., 0], refs[..., 1]], refs, result
