"""What a :func:`~barkgen.pipeline.generate` run reports: its JSON-ready parameters, label
areas and timings (:func:`run_report`), and its contact sheet (:func:`preview_sheet`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from barkgen.pipeline.options import GenerateOptions


def _fractions(label_map: np.ndarray, values: np.ndarray) -> dict[str, float]:
    return {str(int(v)): round(float(np.mean(label_map == v)), 4) for v in values}


def run_report(
    photo, options: GenerateOptions, wrap, labels_in, label_result, result, material, timings, *, referenced: bool
) -> dict:
    """The JSON-ready report of a :func:`generate` run: every option, from its declaration
    (:func:`barkgen._shared.options.option_values`: each field under its report key, so a new
    option is reported with no edit here), the options of the material set it made, and what
    the run found and took: the photo's size, its labels and their areas, the wraps, the light,
    the flow's copies and the timings. ``referenced``: texture-by-numbers started from the
    label map's references (handed over to it, the result no longer has them)."""
    from barkgen._shared.options import option_values
    from barkgen.pipeline.materials import photo_material_options
    from barkgen.pipeline.variants import bilayer_options, growth_options

    values = np.unique(labels_in)
    report = option_values(options)
    found = {
        "size": [options.size[1], options.size[0]],
        "photo_size": [int(np.asarray(photo).shape[1]), int(np.asarray(photo).shape[0])],
        "k": int(values.size),  # the labels found (a given label map has its own count)
        "layer_order": label_result.layer_order,
        "exemplar_wrap": [bool(wrap[0]), bool(wrap[1])],
        "texture_init": "label map references" if referenced else "smart",
        "extras": sorted(result.extras),
        "extra_wraps": {name: list(axes) for name, axes in sorted(result.extra_wraps.items())},
        "resumed_from_level": label_result.resumed_level,
        "label_fractions_in": _fractions(labels_in, values),
        "label_fractions_out": _fractions(label_result.label_map, values),
        # the light the shading removal took (given or estimated)
        "light": None
        if material is None or material.light is None
        else [material.light.azimuth, material.light.elevation],
        "flow": None
        if result.orientation is None
        else {
            "copies": result.orientation.n_copies,
            "angles": sorted(set(result.orientation.angles)),
            "scales": sorted(set(result.orientation.scales)),
        },
        "material_options": option_values(photo_material_options(options, wrap)) if options.material else None,
        "bilayer_options": option_values(bilayer_options(options)) if options.model == "bilayer" else None,
        "growth_options": option_values(growth_options(options)) if options.structure == "cracks" else None,
        "timings_s": {name: round(value, 3) for name, value in timings.items()},
    }
    return report | found


def preview_sheet(photo: np.ndarray, result, tile_size: int = 320) -> np.ndarray:
    """The contact sheet of a run: photo, input labels, output labels, result.

    Parameters
    ----------
    photo : ndarray
        The photo of the run.
    result : GenerateResult
        What :func:`generate` made of it.
    tile_size : int, default 320
        Width of each picture in the sheet, in pixels.

    Returns
    -------
    ndarray of uint8, shape (H, 4 * (tile_size + 6), 3)
        The sheet (:func:`barkgen.labels.contact_sheet`), captioned.
    """
    from barkgen._shared.arrays import as_uint8
    from barkgen.labels import contact_sheet, label_colour_map

    values = np.unique(result.labels_in)
    # a large output is taken a pixel in ``step`` first (a view: its tile is 4x finer than the
    # sheet's, then averaged down as any tile is): colouring a 16384² label map whole cost 2.5 GB
    step = max(1, min(result.labels_out.shape[:2]) // (4 * tile_size))
    tiles = [
        as_uint8(photo),
        label_colour_map(result.labels_in, values),
        label_colour_map(result.labels_out[::step, ::step], values),
        as_uint8(result.texture[::step, ::step]),
    ]
    return contact_sheet(tiles, ["photo", "labels in", "labels out", "result"], columns=4, tile_size=tile_size)
