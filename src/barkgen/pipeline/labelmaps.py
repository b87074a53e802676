"""The label maps of a run (laitoch2018 Figure 1.2): the output label map by strategy or a grown
crack network's raster, the checks of what goes together, and the edge label (§3.5.5) added to
the photo's and the output's maps once both are made."""

from __future__ import annotations

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.pipeline.options import GenerateOptions
from barkgen.pipeline.progress import stage_progress
from barkgen.pipeline.variants import crack_label_map

#: seed of the photo's own analysis (the k-means of its label map): the photo's labels belong to
#: the photo, not to a variant, so every seed's output of one photo shares one analysis
ANALYSIS_SEED = 0


def photo_label_map(
    photo: np.ndarray, k: int, method: str = "color", *, wrap, equalize_light: float = 1.0, **regions_options
) -> np.ndarray:
    """The photo's label map as :func:`barkgen.pipeline.generate` makes it: the photo's broad
    light taken out first (``equalize_light``, :func:`barkgen.material.equalize_light`), then
    its colour regions or texton regions (laitoch2018 §3.5; ``method``), across its edges where
    it wraps; ``regions_options`` go to the regions' function (``seed``, default
    :data:`ANALYSIS_SEED`; ``merge_by`` for textons)."""
    from barkgen.labels import color_regions, texton_regions
    from barkgen.material.illumination import equalize_light as equalize

    equalised, _ = equalize(photo, equalize_light, tile=wrap)
    regions = color_regions if method == "color" else texton_regions
    regions_options.setdefault("seed", ANALYSIS_SEED)
    return regions(equalised, k, wrap=wrap, **regions_options)


def output_label_map(labels_in, photo, options: GenerateOptions, analysis, wrap, resume, progress, fields):
    """The output label map (:func:`barkgen.shapes.synthesize_label_map` by ``options.strategy``,
    or a grown crack network's raster) and the grown network (None but for cracks)."""
    from barkgen.shapes import Budget, Canvas, synthesize_label_map

    flow, flow_scale, links = fields
    exemplar = analysis.exemplar
    if options.structure == "cracks":
        if exemplar is None or exemplar.cracks is None:
            raise InvalidInputError("the photo analysis has no crack network: analyse it with structure='cracks'")
        label_result, grown = crack_label_map(
            exemplar.cracks, options, stage_progress(progress, "label_map", options.material)
        )
    else:
        grown = None
        label_result = synthesize_label_map(
            labels_in,
            strategy=options.strategy,
            photo=photo,
            canvas=Canvas(options.size, options.tile, wrap, flow, flow_scale, links),
            budget=Budget(
                options.seed, progress=stage_progress(progress, "label_map", options.material), cache=analysis.cache
            ),
            rotations=options.rotations,
            resume=resume,
        )
    return label_result, grown


def check_variant(options: GenerateOptions, along: bool, resume: bool) -> None:
    """What goes together: cracks and bi-layer textures go their own ways
    (:mod:`barkgen.pipeline.variants`), and neither they nor the edge label follow a flow field;
    a crack network is not resumed."""
    variant = (
        "cracks" if options.structure == "cracks" else "a bi-layer texture" if options.model == "bilayer" else None
    )
    if variant and along:
        raise InvalidInputError(f"{variant} does not follow a flow field yet: leave out the flow field")
    if along and options.edges:
        raise InvalidInputError("the edge label does not follow a flow field yet: leave out edges or the flow field")
    if resume and options.structure == "cracks":
        raise InvalidInputError("a crack network is grown, not resumed: leave out the label map to resume from")


def with_edge_labels(
    labels_in: np.ndarray, labels_out: np.ndarray, options: GenerateOptions, *, wrap, tbn_labels_in=None
) -> tuple[np.ndarray, np.ndarray]:
    """The photo's and the output's label maps as texture-by-numbers matches them: with
    ``options.edges``, both with the edge label (laitoch2018 §3.5.5: "performed on both input
    and output label maps after they are both generated"), numbered against the photo's labels
    so they share their grey values; else as they are. ``wrap``: the photo's axes that wrap;
    the output wraps where it tiles. ``tbn_labels_in``: the photo's, already edged (its
    analysis')."""
    from barkgen.labels import add_edge_label

    if not options.edges:
        return labels_in, labels_out
    if tbn_labels_in is None:
        tbn_labels_in = add_edge_label(labels_in, options.edges, wrap=wrap)
    values = np.unique(labels_in)
    return tbn_labels_in, add_edge_label(labels_out, options.edges, wrap=options.tile, values=values)
