"""Material maps from a bark photo: height, normals, ambient occlusion, roughness and albedo
(wang2003 §3.3-3.4; laitoch2018 §3.3.1; mazzolini2012 §7.1).

Arrays in, arrays out: :func:`make_material` for a photo, :func:`scanned_material` for a
scanned set (its own maps), :func:`transfer_material` for a
texture synthesized from it, :class:`HeightEditor` for self-similarity height editing; the
files (ambientCG names) are encoded by :func:`barkgen.io.encode_material` and written by the
front ends. A run's
filters read the photo round its edges as its :class:`Boundary` says (where it wraps), built
once by :func:`make_material` (or taken from a set, :attr:`MaterialSet.boundary`).
"""

from barkgen._shared.arrays import Boundary
from barkgen.material.edited import adjust_material, edit_material
from barkgen.material.editor import EditList, HeightEdit, HeightEditor, edits_document, parse_edit_list, parse_edits
from barkgen.material.height import HeightConfig, estimate_height
from barkgen.material.illumination import (
    decode_illumination,
    encode_illumination,
    equalize_light,
    estimate_illumination,
)
from barkgen.material.maps import (
    ambient_occlusion,
    decode_normals,
    encode_normals,
    flip_green,
    normal_map,
    photo_cavities,
    roughness_map,
    to_directx,
)
from barkgen.material.materialset import (
    MaterialOptions,
    MaterialSet,
    derived_maps,
    make_material,
)
from barkgen.material.scanned import integrate_normals, scanned_material
from barkgen.material.shading import Light, estimate_light, parse_light, remove_shading, shading, shape_from_shading
from barkgen.material.transfer import transfer_material

__all__ = [
    "Boundary",
    "adjust_material",
    "EditList",
    "HeightConfig",
    "HeightEdit",
    "HeightEditor",
    "Light",
    "MaterialOptions",
    "MaterialSet",
    "ambient_occlusion",
    "decode_normals",
    "derived_maps",
    "edit_material",
    "edits_document",
    "encode_normals",
    "estimate_height",
    "estimate_light",
    "flip_green",
    "integrate_normals",
    "make_material",
    "normal_map",
    "parse_edit_list",
    "parse_edits",
    "parse_light",
    "photo_cavities",
    "remove_shading",
    "roughness_map",
    "scanned_material",
    "shading",
    "shape_from_shading",
    "to_directx",
    "transfer_material",
    "equalize_light",
    "encode_illumination",
    "decode_illumination",
    "estimate_illumination",
]
