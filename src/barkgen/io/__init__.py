"""Image and reference-map input/output: the only place where barkgen touches image files."""

from barkgen.io.generate import (
    GENERATE_FILES,
    encode_generate,
    remove_staging,
    write_folder_atomic,
)
from barkgen.io.images import (
    AlphaDroppedWarning,
    decode_image,
    encode_png,
    read_image,
    read_image_bytes,
    read_png_text,
    to_bits,
    write_bytes_atomic,
    write_files_atomic,
    write_png,
)
from barkgen.io.material import MAP_SUFFIXES, check_material_name, encode_glb, encode_material, find_material, read_material
from barkgen.io.references import encode_reference, read_reference, write_reference

__all__ = [
    "AlphaDroppedWarning",
    "GENERATE_FILES",
    "encode_generate",
    "remove_staging",
    "write_folder_atomic",
    "MAP_SUFFIXES",
    "check_material_name",
    "encode_glb",
    "encode_material",
    "find_material",
    "read_material",
    "decode_image",
    "encode_png",
    "encode_reference",
    "read_image",
    "read_image_bytes",
    "read_png_text",
    "read_reference",
    "to_bits",
    "write_bytes_atomic",
    "write_files_atomic",
    "write_png",
    "write_reference",
]
