"""The photo's label map as a run makes it (laitoch2018 §3.5), and the edge label (§3.5.5) added
to the photo's and the output's maps once both are made; the output label map is the structure
variant's (:mod:`barkgen.pipeline.variants`)."""

from __future__ import annotations

import numpy as np

from barkgen.pipeline.variants import ANALYSIS_SEED, Run

__all__ = ["ANALYSIS_SEED", "photo_label_map", "with_edge_labels"]


def photo_label_map(
    photo: np.ndarray, k: int, method: str = "color", *, wrap, equalize_light: float = 1.0, **regions_options
) -> np.ndarray:
    """The photo's label map as :func:`barkgen.pipeline.generate` makes it: the photo's broad
    light taken out first (``equalize_light``, :func:`barkgen.material.equalize_light`), then
    its colour regions or texton regions (laitoch2018 §3.5; ``method``), across its edges where
    it wraps; ``regions_options`` go to the regions' function (``seed``, default
    :data:`ANALYSIS_SEED`; ``merge_by`` for textons)."""
    from barkgen.labels import color_regions, texton_regions
    from barkgen.material import Boundary
    from barkgen.material.illumination import equalize_light as equalize

    equalised, _ = equalize(photo, equalize_light, boundary=Boundary(wrap))
    regions = color_regions if method == "color" else texton_regions
    regions_options.setdefault("seed", ANALYSIS_SEED)
    return regions(equalised, k, wrap=wrap, **regions_options)


def with_edge_labels(
    labels_in: np.ndarray, labels_out: np.ndarray, run: Run, tbn_labels_in: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The photo's and the output's label maps as texture-by-numbers matches them: with the
    run's ``options.edges``, both with the edge label (laitoch2018 §3.5.5: "performed on both
    input and output label maps after they are both generated"), numbered against the photo's
    labels so they share their grey values; else as they are. The photo's map wraps along the
    run's ``canvas.exemplar_wrap``, the output's where the canvas tiles. ``tbn_labels_in``: the
    photo's, already edged (its analysis')."""
    from barkgen.labels import add_edge_label

    edges = run.options.edges
    if not edges:
        return labels_in, labels_out
    if tbn_labels_in is None:
        tbn_labels_in = add_edge_label(labels_in, edges, wrap=run.canvas.exemplar_wrap)
    values = np.unique(labels_in)
    return tbn_labels_in, add_edge_label(labels_out, edges, wrap=run.canvas.tile, values=values)
