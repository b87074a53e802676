"""Codecs and file writes: images, reference maps, material sets, bi-layer models and folders
written as one step (the only place where barkgen touches files)."""

from barkgen.io.bilayer import encode_bilayer_model, read_bilayer_model, write_bilayer_model
from barkgen.io.blender import blender_setup_script
from barkgen.io.fields import read_field
from barkgen.io.folders import (
    check_replaceable,
    file_record,
    owned_files,
    remove_staging,
    write_folder_atomic,
)
from barkgen.io.gltf import add_tangents, encode_glb, vertex_tangents
from barkgen.io.images import (
    AlphaDroppedWarning,
    ImageContentWarning,
    decode_image,
    encode_concurrently,
    encode_png,
    image_size,
    read_centre_crop,
    read_image,
    read_image_bytes,
    read_png_text,
    to_bits,
    write_png,
)
from barkgen.io.material import (
    MAP_SUFFIXES,
    check_material_name,
    encode_material,
    find_material,
    read_material,
)
from barkgen.io.references import encode_reference, read_reference, read_reference_orientation, write_reference
from barkgen.io.scanned import (
    IMAGE_EXTENSIONS,
    ScannedSet,
    is_set_folder,
    map_kind,
    read_scanned_set,
    read_set_zip,
    recognise_set,
    scanned_set_files,
    scanned_set_from_files,
)
from barkgen.io.staging import (
    commit_staged,
    discard_staged,
    remove_stale_temporaries,
    stage_files,
    write_bytes_atomic,
    write_files_atomic,
)

__all__ = [
    "IMAGE_EXTENSIONS",
    "ScannedSet",
    "is_set_folder",
    "map_kind",
    "read_scanned_set",
    "read_set_zip",
    "scanned_set_files",
    "scanned_set_from_files",
    "recognise_set",
    "check_replaceable",
    "file_record",
    "owned_files",
    "AlphaDroppedWarning",
    "ImageContentWarning",
    "encode_bilayer_model",
    "read_bilayer_model",
    "write_bilayer_model",
    "remove_staging",
    "remove_stale_temporaries",
    "write_folder_atomic",
    "MAP_SUFFIXES",
    "check_material_name",
    "encode_glb",
    "add_tangents",
    "vertex_tangents",
    "encode_material",
    "blender_setup_script",
    "find_material",
    "read_material",
    "read_centre_crop",
    "decode_image",
    "encode_concurrently",
    "encode_png",
    "image_size",
    "encode_reference",
    "read_image",
    "read_image_bytes",
    "read_png_text",
    "read_field",
    "read_reference",
    "read_reference_orientation",
    "to_bits",
    "write_bytes_atomic",
    "commit_staged",
    "discard_staged",
    "stage_files",
    "write_files_atomic",
    "write_png",
    "write_reference",
]
