"""The material set of a run (wang2003 §3.3-3.4): the photo's own, made from its analysis, and
the output's, carried through the texture's reference map."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from barkgen.pipeline.options import GenerateOptions
from barkgen.pipeline.variants import ANALYSIS_SEED

if TYPE_CHECKING:
    from barkgen._shared.canvas import Canvas
    from barkgen.io import ScannedSet
    from barkgen.material import MaterialOptions, MaterialSet


@dataclass(frozen=True)
class WindowedMaterial:
    """The output's material set before it is made: the photo's set, the reference map and the
    canvas that :func:`barkgen.pipeline.write_material_streamed` resolves window by window as it
    writes the set's files (issue 69; laitoch2018 §3.3.1, the maps carried through the reference
    map; wang2003 §3.4), so that no map of the output's size is held. :func:`generate`'s
    ``material`` in a windowed run (``GenerateOptions(windowed=...)``).

    Attributes
    ----------
    source : MaterialSet
        The photo's set (along a flow field, cut as its turned copies).
    references : ndarray of int32, shape (H, W, 2)
        The output's reference map.
    canvas : Canvas
        The output's (``shape``, ``tile``, the resolved ``exemplar_wrap``).
    blend : {"gradient", "none"}
        How the colour is carried (``GenerateOptions.blend``).
    width_m : float or None
        The set's real-world width in metres (``GenerateOptions.width_m``).
    """

    source: MaterialSet
    references: np.ndarray
    canvas: Canvas
    blend: str = "gradient"
    width_m: float | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """The output's ``(H, W)``."""
        return self.canvas.shape

    @property
    def light(self):
        """The light the photo's shading was taken out for (the output's set keeps it)."""
        return self.source.light

    def whole(self) -> MaterialSet:
        """The whole set in memory, as ``windowed="no"`` makes it."""
        from barkgen.material import transfer_material

        material = transfer_material(self.source, self.references, self.canvas, blend=self.blend)
        return material.with_width_m(self.width_m)

    def write(self, folder, /, name: str, preset: str = "ambientcg", **options) -> dict[str, str]:
        """Its files written into ``folder``: :func:`~barkgen.pipeline.write_material_streamed`
        (``options`` are its keywords); every file -> its SHA-256."""
        from barkgen.pipeline.streamed import write_material_streamed

        return write_material_streamed(
            self.source,
            self.references,
            self.canvas,
            folder,
            name,
            preset,
            blend=self.blend,
            width_m=self.width_m,
            **options,
        )


def output_material(photo, options: GenerateOptions, canvas: Canvas, scan, analysis, result, windowed: bool = False):
    """The output's material set: the photo's (from its ``analysis``, or made now) carried
    through the texture's reference map onto the ``canvas``; along a flow field, the photo's
    maps cut as its turned copies first. ``windowed``: a :class:`WindowedMaterial`, made as its
    files are written."""
    from barkgen.material import transfer_material

    source, wrap = analysis.material, canvas.exemplar_wrap
    if source is None:
        source = photo_material(photo, analysis.labels_in, options, wrap, scan, analysis.illumination)
    if result.orientation is not None:
        source, wrap = source.oriented(result.orientation), (False, False)
    canvas = canvas.replace(exemplar_wrap=wrap)
    if windowed:
        return WindowedMaterial(source, result.references, canvas, options.blend, options.width_m)
    material = transfer_material(source, result.references, canvas, blend=options.blend)
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
