"""The material set of a run (wang2003 §3.3-3.4): the photo's own, made from its analysis, and
the output's, carried through the texture's reference map."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from barkgen.pipeline.options import GenerateOptions
from barkgen.pipeline.variants import ANALYSIS_SEED

if TYPE_CHECKING:
    from barkgen._shared.canvas import Canvas
    from barkgen.io import ScannedSet
    from barkgen.material import MaterialOptions


def output_material(photo, options: GenerateOptions, canvas: Canvas, scan, analysis, result):
    """The output's material set: the photo's (from its ``analysis``, or made now) carried
    through the texture's reference map onto the ``canvas``; along a flow field, the photo's
    maps cut as its turned copies first."""
    from barkgen.material import transfer_material

    source, wrap = analysis.material, canvas.exemplar_wrap
    if source is None:
        source = photo_material(photo, analysis.labels_in, options, wrap, scan, analysis.illumination)
    if result.orientation is not None:
        source, wrap = source.oriented(result.orientation), (False, False)
    material = transfer_material(source, result.references, canvas.replace(exemplar_wrap=wrap), blend=options.blend)
    return material.with_width_m(options.width_m)


def photo_material(
    photo: np.ndarray,
    labels_in: np.ndarray,
    options: GenerateOptions,
    wrap: tuple[bool, bool],
    scan: ScannedSet | None = None,
    illumination: np.ndarray | None = None,
):
    """The photo's own material set, its label map as the height's structure cue; wrapping
    along the axes the photo wraps along (``wrap``), as the solvers use it, so the maps carried
    through the reference map meet where the pieces run on across the photo's edge. A scanned
    set's own maps where it has them."""
    from barkgen.labels.regions import to_codes
    from barkgen.material import make_material, scanned_material

    if scan is not None:
        return scanned_material(
            scan, wrap=wrap, relief=options.relief, seed=ANALYSIS_SEED, k=options.k, label_map=to_codes(labels_in)[0]
        )

    # (``photo`` is equalised already, as far as ``options`` says: its light goes with the set)
    return make_material(
        photo,
        photo_material_options(options, wrap),
        label_map=to_codes(labels_in)[0],
        illumination=illumination,
    )


def photo_material_options(options: GenerateOptions, wrap: tuple[bool, bool]) -> MaterialOptions:
    """The :class:`~barkgen.material.MaterialOptions` of a run's photo set (``report.json``
    lists them): generate's label count, light, relief and photo light, the analysis' seed,
    and the photo's wrap."""
    from barkgen.material import MaterialOptions

    return MaterialOptions(
        k=options.k,
        light=options.light,
        seed=ANALYSIS_SEED,
        relief=options.relief,
        exemplar_wrap=wrap,
        equalize_light=options.equalize_light,
    )
