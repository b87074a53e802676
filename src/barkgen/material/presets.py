"""Material sets named and packed the way each engine reads them (``--preset``).

Each engine's conventions (its manuals; Node Wrangler's naming rules; glTF 2.0 §3.9):

=========  ====================================================================================
preset     files (``NAME_...png``)
=========  ====================================================================================
ambientcg  ``Color`` (sRGB), ``NormalGL``, ``NormalDX``, ``Displacement`` (16-bit),
           ``Roughness``, ``AmbientOcclusion``, and ``Metalness``, ``Opacity`` where the set
           has them: barkgen's own layout, ambientCG's names.
blender    ``Color``, ``NormalGL`` only (Node Wrangler's principled setup picks the one normal
           map there is), ``Displacement``, ``Roughness``, ``AmbientOcclusion`` (+ ``Metalness``,
           ``Opacity``), and ``NAME.mtlx``: a MaterialX document that wires them, with the
           displacement's scale and midlevel set (:func:`barkgen.io.materialx.encode_mtlx`).
unreal     ``BaseColor``, ``NormalDX`` (Unreal's green is DirectX's), ``ORM`` (R = AO,
           G = roughness, B = metalness), ``Displacement`` (+ ``Opacity``).
unity      ``BaseMap`` (alpha = opacity where there is one), ``NormalGL`` (Unity's normal maps
           are OpenGL), ``MaskMap`` (HDRP: R = metalness, G = AO, B = detail mask (white),
           A = smoothness = 1 - roughness), ``Height``.
gltf       ``BaseColor`` (alpha = opacity where there is one), ``NormalGL`` (glTF's), ``ORM``
           (glTF's occlusion in R and metallic-roughness in G and B share one image),
           ``Displacement`` (not in glTF itself; for the tools that take one).
=========  ====================================================================================

A packed map's channels are the very values of the separate maps (an 8-bit map in a 16-bit
pack is ``value * 257``, the same number), so a packed set and an unpacked one agree exactly.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.arrays import as_uint8
from barkgen.errors import InvalidInputError
from barkgen.material.maps import encode_normals, flip_green

PRESETS = ("ambientcg", "blender", "unreal", "unity", "gltf")
#: the normal-map convention of each preset's files
NORMAL_FILES = {
    "ambientcg": {"NormalGL": "OpenGL (+Y up, glTF)", "NormalDX": "DirectX (+Y down)"},
    "blender": {"NormalGL": "OpenGL (+Y up, glTF)"},
    "unreal": {"NormalDX": "DirectX (+Y down)"},
    "unity": {"NormalGL": "OpenGL (+Y up, glTF)"},
    "gltf": {"NormalGL": "OpenGL (+Y up, glTF)"},
}
#: what the channels of each preset's packed map hold
PACKING = {
    "unreal": {"ORM": "R ambient occlusion, G roughness, B metalness"},
    "gltf": {"ORM": "R ambient occlusion, G roughness, B metalness"},
    "unity": {"MaskMap": "R metalness, G ambient occlusion, B detail mask (1), A smoothness (1 - roughness)"},
}

#: where each preset keeps each map, for what reads a set back (its Blender set-up,
#: :func:`barkgen.io.blender_setup_script`): file stem, and how its value is read (``RGB`` the
#: colour, ``V`` a grey map's value, ``R``/``G``/``B``/``A`` one channel, ``1-A`` one minus the
#: alpha; the normal map's convention)
MAP_SOURCES: dict[str, dict[str, tuple[str, str]]] = {
    "ambientcg": {
        "color": ("Color", "RGB"),
        "normal": ("NormalGL", "OpenGL"),
        "roughness": ("Roughness", "V"),
        "metalness": ("Metalness", "V"),
        "opacity": ("Opacity", "V"),
        "displacement": ("Displacement", "V"),
    },
    "unreal": {
        "color": ("BaseColor", "RGB"),
        "normal": ("NormalDX", "DirectX"),
        "roughness": ("ORM", "G"),
        "metalness": ("ORM", "B"),
        "opacity": ("Opacity", "V"),
        "displacement": ("Displacement", "V"),
    },
    "unity": {
        "color": ("BaseMap", "RGB"),
        "normal": ("NormalGL", "OpenGL"),
        "roughness": ("MaskMap", "1-A"),
        "metalness": ("MaskMap", "R"),
        "opacity": ("BaseMap", "A"),
        "displacement": ("Height", "V"),
    },
    "gltf": {
        "color": ("BaseColor", "RGB"),
        "normal": ("NormalGL", "OpenGL"),
        "roughness": ("ORM", "G"),
        "metalness": ("ORM", "B"),
        "opacity": ("BaseColor", "A"),
        "displacement": ("Displacement", "V"),
    },
}
MAP_SOURCES["blender"] = MAP_SOURCES["ambientcg"]


def check_preset(preset: str) -> str:
    """``preset`` if it is one of :data:`PRESETS`, else :class:`InvalidInputError`."""
    if preset not in PRESETS:
        raise InvalidInputError(f"preset must be one of {', '.join(PRESETS)}, not {preset!r}")
    return preset


def encode_unit(values: np.ndarray, bits: int = 8) -> np.ndarray:
    """A map in [0, 1] as 8- or 16-bit pixels (rounded, clipped), as the ambientCG layout
    writes it (:meth:`~barkgen.material.MaterialSet.images`)."""
    if bits == 16:
        return np.round(np.clip(np.asarray(values, np.float64), 0.0, 1.0) * 65535.0).astype(np.uint16)
    return as_uint8(np.asarray(values, np.float32))


def _widen(channel: np.ndarray, dtype) -> np.ndarray:
    """An encoded channel as ``dtype`` (uint8 -> uint16 is ``* 257``: the same value)."""
    if channel.dtype == dtype:
        return channel
    return channel.astype(np.uint16) * np.uint16(257)


def pack_channels(*channels: np.ndarray) -> np.ndarray:
    """Encoded grey channels stacked into one image, 16-bit if any of them is."""
    dtype = np.uint16 if any(c.dtype == np.uint16 for c in channels) else np.uint8
    return np.stack([_widen(c, dtype) for c in channels], axis=-1)


def encoded_maps(material) -> dict[str, np.ndarray]:
    """Every map of a :class:`~barkgen.material.MaterialSet` as pixels, each at its
    :attr:`~barkgen.material.MaterialSet.bits`: ``color``, ``normal_gl``, ``displacement``
    (16-bit), ``roughness``, ``ao``, ``metalness`` (zeros where the set has none) and
    ``opacity`` (``None`` where it has none)."""
    bits = material.bits
    maps = {
        "color": encode_unit(material.color, bits.get("color", 8)),
        "normal_gl": encode_normals(material.normals, bits.get("normals", 8)),
        "displacement": np.round(material.displacement() * 65535).astype(np.uint16),
        "roughness": encode_unit(material.roughness, bits.get("roughness", 8)),
        "ao": encode_unit(material.ao, bits.get("ao", 8)),
    }
    maps["metalness"] = (
        encode_unit(material.metalness, bits.get("metalness", 8))
        if material.metalness is not None
        else np.zeros_like(maps["roughness"])
    )
    maps["opacity"] = encode_unit(material.opacity, bits.get("opacity", 8)) if material.opacity is not None else None
    return maps


def _with_alpha(color: np.ndarray, opacity: np.ndarray | None) -> np.ndarray:
    if opacity is None:
        return color
    return pack_channels(*(color[..., c] for c in range(3)), opacity)


def preset_file_names(name: str, preset: str) -> list[str]:
    """Every image file ``preset`` may write for a set called ``name`` (metalness and opacity
    where a set has them), and ``NAME.mtlx`` for Blender."""
    check_preset(preset)
    stems = {
        "ambientcg": (
            "Color",
            "NormalGL",
            "NormalDX",
            "Displacement",
            "Roughness",
            "AmbientOcclusion",
            "Metalness",
            "Opacity",
        ),
        "blender": ("Color", "NormalGL", "Displacement", "Roughness", "AmbientOcclusion", "Metalness", "Opacity"),
        "unreal": ("BaseColor", "NormalDX", "ORM", "Displacement", "Opacity"),
        "unity": ("BaseMap", "NormalGL", "MaskMap", "Height"),
        "gltf": ("BaseColor", "NormalGL", "ORM", "Displacement"),
    }[preset]
    return [f"{name}_{stem}.png" for stem in stems] + ([f"{name}.mtlx"] if preset == "blender" else [])


def preset_images(material, name: str, preset: str = "ambientcg") -> dict[str, np.ndarray]:
    """The image files of a material set as ``preset`` names and packs them (see the module).

    Parameters
    ----------
    material : MaterialSet
        The set.
    name : str
        Its ``NAME``.
    preset : {"ambientcg", "blender", "unreal", "unity", "gltf"}, default "ambientcg"
        The engine's layout.

    Returns
    -------
    dict of str to ndarray
        File name -> pixels (uint8 or uint16).
    """
    check_preset(preset)
    if preset == "ambientcg":  # barkgen's own layout, the files of every set it made before
        return material.images(name)
    m = encoded_maps(material)
    has_metal = material.metalness is not None
    files: dict[str, np.ndarray] = {}
    if preset == "blender":
        files[f"{name}_Color.png"] = m["color"]
        files[f"{name}_NormalGL.png"] = m["normal_gl"]
        files[f"{name}_Displacement.png"] = m["displacement"]
        files[f"{name}_Roughness.png"] = m["roughness"]
        files[f"{name}_AmbientOcclusion.png"] = m["ao"]
        if has_metal:
            files[f"{name}_Metalness.png"] = m["metalness"]
        if m["opacity"] is not None:
            files[f"{name}_Opacity.png"] = m["opacity"]
    elif preset == "unreal":
        files[f"{name}_BaseColor.png"] = m["color"]
        files[f"{name}_NormalDX.png"] = flip_green(m["normal_gl"])
        files[f"{name}_ORM.png"] = pack_channels(m["ao"], m["roughness"], m["metalness"])
        files[f"{name}_Displacement.png"] = m["displacement"]
        if m["opacity"] is not None:
            files[f"{name}_Opacity.png"] = m["opacity"]
    elif preset == "unity":
        files[f"{name}_BaseMap.png"] = _with_alpha(m["color"], m["opacity"])
        files[f"{name}_NormalGL.png"] = m["normal_gl"]
        top = np.iinfo(m["roughness"].dtype).max
        detail = np.full_like(m["roughness"], top)
        files[f"{name}_MaskMap.png"] = pack_channels(m["metalness"], m["ao"], detail, top - m["roughness"])
        files[f"{name}_Height.png"] = m["displacement"]
    else:  # gltf
        files[f"{name}_BaseColor.png"] = _with_alpha(m["color"], m["opacity"])
        files[f"{name}_NormalGL.png"] = m["normal_gl"]
        files[f"{name}_ORM.png"] = pack_channels(m["ao"], m["roughness"], m["metalness"])
        files[f"{name}_Displacement.png"] = m["displacement"]
    return files
