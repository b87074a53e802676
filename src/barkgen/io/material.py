"""Material sets on disk (ambientCG's file names) and
the trunk as glTF 2.0 binary.

A set folder holds ``NAME_Color.png`` (sRGB), ``NAME_NormalGL.png`` / ``NAME_NormalDX.png``,
``NAME_Displacement.png`` (16-bit, 0 = deepest), ``NAME_Roughness.png``,
``NAME_AmbientOcclusion.png`` (linear), ``NAME.json`` (size, tileable, seed, source photo,
displacement depth scale, real-world size, barkgen version) and ``NAME_blender.py`` (the set
set up in Blender at its real-world size, :mod:`barkgen.io.blender`); a set in UDIM tiles
has each map once a tile, ``NAME_Color.1001.png`` ... (:mod:`barkgen.io.udim`).
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterable
from functools import partial
from pathlib import Path

import numpy as np

from barkgen.errors import ImageReadError, InvalidInputError
from barkgen.io.blender import blender_script_name, blender_setup_script
from barkgen.io.images import encode_concurrently, encode_png, read_image
from barkgen.io.udim import UDIM_TOKEN, UdimGrid, udim_file_name, udim_grid

#: the map suffixes of a set, in the order they are listed
MAP_SUFFIXES = ("Color", "NormalGL", "NormalDX", "Displacement", "Roughness", "AmbientOcclusion")


def check_material_name(name: str) -> str:
    """Check a set name: letters, digits, ``_`` or ``-``, at most 100 (it becomes file names:
    ``ASSET_VARIANT_SIZE``, :mod:`barkgen.io.asset_names`).

    Parameters
    ----------
    name : str
        The name.

    Returns
    -------
    str
        ``name``.

    Raises
    ------
    InvalidInputError
        Any other name.
    """
    if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_-]{0,99}", name):
        raise InvalidInputError(f"--name must be letters, digits, _ or - (at most 100), not {name!r}")
    return name


def utf8_text(text: str) -> str:
    """``text`` as valid UTF-8 for a JSON record: a path's undecodable bytes (which Python keeps
    as lone surrogates) become U+FFFD, so ``report.json`` and ``NAME.json`` stay valid JSON for
    every reader."""
    return text.encode("utf-8", "surrogateescape").decode("utf-8", "replace")


def material_file_names(name: str, preset: str = "ambientcg", udim: UdimGrid | None = None) -> list[str]:
    """The files a set called ``name`` may have in ``preset``'s layout (:func:`encode_material`
    writes these, the metalness and opacity maps only where the set has them, the EXR only
    with ``exr_height``, each map once a tile of ``udim``; every set has its
    ``NAME_blender.py``), known before the set is made: a command refuses, before any work,
    to write one that is an input."""
    from barkgen.material.presets import preset_file_names

    maps = preset_file_names(name, preset) + [f"{name}_Displacement.exr"]  # (the EXR with --exr-height)
    if udim is not None:
        maps = [udim_file_name(file, number) for file in maps for number in udim.numbers]
    return maps + [blender_script_name(name), f"{name}.json"]


def encode_material(
    material,
    name: str,
    preset: str = "ambientcg",
    *,
    exr_height: bool = False,
    udim: tuple[int, int] | None = None,
    **metadata,
) -> dict[str, bytes]:
    """Every file of a :class:`~barkgen.material.MaterialSet`, encoded before any is written.

    Parameters
    ----------
    material : MaterialSet
        The set.
    name : str
        Its ``NAME`` (:func:`check_material_name`).
    preset : {"ambientcg", "blender", "unreal", "unity", "gltf"}, default "ambientcg"
        The engine whose names and packing the files follow
        (:mod:`barkgen.material.presets`); ``blender`` adds ``NAME.mtlx``, a MaterialX document
        wiring the maps, with the displacement's scale and midlevel set.
    exr_height : bool, default False
        Also ``NAME_Displacement.exr``: the displacement as 32-bit float (0 = deepest, 1 =
        highest, as the 16-bit PNG, without its rounding; the ``[exr]`` extra).
    udim : (int, int), optional
        ``(columns, rows)``: each map written as that grid of UDIM tiles
        (``NAME_Color.1001.png``, ``NAME_Color.1002.png``, ...; :mod:`barkgen.io.udim`), the
        set's size cut into equal tiles; ``NAME.json`` lists them (``udim``), the MaterialX
        document and the Blender set-up read them as one tiled image.
    **metadata
        Added to ``NAME.json`` (asset, variant, seed, source photo, its licence, ...). The record
        always states the width and height in pixels (``width_px``, ``height_px``) and, where
        the pixel size is known, in metres (``width_m``, ``height_m``), and the ``preset``.

    Returns
    -------
    dict of str to bytes
        The preset's images, ``NAME.json``, ``NAME_blender.py`` (the set made in Blender at its
        real-world size, :mod:`barkgen.io.blender`) (and ``NAME.mtlx``). ``ambientcg``:
        ``NAME_Color.png``, ``NAME_NormalGL.png``, ``NAME_NormalDX.png``,
        ``NAME_Displacement.png``, ``NAME_Roughness.png``, ``NAME_AmbientOcclusion.png``.

    Raises
    ------
    InvalidInputError
        A bad name or preset.
    MissingExtraError
        ``blender`` without the ``[materialx]`` extra.
    """
    from barkgen.material.presets import check_preset, preset_images

    check_material_name(name)
    check_preset(preset)
    grid = None if udim is None else udim_grid(material.shape, udim)
    images = preset_images(material, name, preset)
    files = encode_concurrently({fname: partial(encode_png, pixels) for fname, pixels in _tiled(images, grid).items()})
    if exr_height:
        height = {f"{name}_Displacement.exr": material.displacement().astype(np.float32)}
        files.update({file: encode_exr(values) for file, values in _tiled(height, grid).items()})
    files.update(encode_set_records(material, name, preset, images, list(files), udim=grid, **metadata))
    return files


def encode_set_records(
    material, name: str, preset: str, images: Iterable[str], written: Iterable[str], *, udim=None, **metadata
) -> dict[str, bytes]:
    """The records of a set whose image files are ``written`` (each map's or each UDIM tile's,
    the EXR): ``NAME.json`` (listing them and the records), ``NAME_blender.py`` and, for the
    ``blender`` preset, ``NAME.mtlx``, as :func:`encode_material` writes them.

    ``material`` gives the set's record (its :meth:`~barkgen.material.MaterialSet.metadata`,
    shape, depth and midlevel: the whole set, or an outline of it whose maps were written
    window by window, :mod:`barkgen.pipeline.streamed`); ``images`` the whole maps' file names
    (``NAME_Color.png`` ...), ``udim`` the :class:`~barkgen.io.UdimGrid` they were cut into,
    ``metadata`` as :func:`encode_material`'s.
    """
    from barkgen.material.presets import NORMAL_FILES, PACKING

    images = list(images)
    metadata = {k: utf8_text(v) if isinstance(v, str) else v for k, v in metadata.items()}
    meta = material.metadata(name=name, **metadata)
    meta["width_px"], meta["height_px"] = meta["size"]
    meta["preset"] = preset
    if preset != "ambientcg":
        meta["normal_convention"] = NORMAL_FILES[preset]
        if preset in PACKING:
            meta["packing"] = PACKING[preset]
    if udim is not None:
        meta["udim"] = udim.to_dict()
    records: dict[str, bytes] = {}
    if preset == "blender":
        records[f"{name}.mtlx"] = _mtlx(material, name, images, udim)
    records[blender_script_name(name)] = blender_setup_script(material, name, images, preset, udim=udim).encode()
    meta["files"] = sorted([*written, *records])
    records[f"{name}.json"] = (json.dumps(meta, indent=2) + "\n").encode()
    return records


def encode_exr(values: np.ndarray) -> bytes:
    """A one-channel float32 map as an OpenEXR file (channel ``Y``, ZIP compression; the
    ``[exr]`` extra, PyPI ``openexr``)."""
    import tempfile

    from barkgen._shared.extras import require_extra

    require_extra("exr", "32-bit EXR maps")
    import OpenEXR

    with tempfile.TemporaryDirectory(prefix="barkgen-exr-") as folder:
        path = os.path.join(folder, "map.exr")
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        with OpenEXR.File(header, {"Y": np.ascontiguousarray(values, np.float32)}) as exr:
            exr.write(path)
        with open(path, "rb") as f:
            return f.read()


def _tiled(images: dict[str, np.ndarray], grid: UdimGrid | None) -> dict[str, np.ndarray]:
    """The images as they are written: each cut into ``grid``'s UDIM tiles (named
    ``NAME_Color.1001.png`` ...), or whole without one."""
    if grid is None:
        return images
    return {
        udim_file_name(file, number): np.ascontiguousarray(tile)
        for file, image in images.items()
        for number, tile in grid.tiles(image).items()
    }


def _mtlx(material, name: str, images: Iterable[str], grid: UdimGrid | None = None) -> bytes:
    """The Blender preset's ``NAME.mtlx`` wiring the set's images."""
    from barkgen.io.materialx import encode_mtlx

    suffixes = {
        "color": "Color",
        "normal": "NormalGL",
        "roughness": "Roughness",
        "displacement": "Displacement",
        "metalness": "Metalness",
        "opacity": "Opacity",
    }
    files = {key: f"{name}_{suffix}.png" for key, suffix in suffixes.items() if f"{name}_{suffix}.png" in images}
    if grid is not None:  # (MaterialX reads a tiled image through the <UDIM> token)
        files = {key: udim_file_name(file, UDIM_TOKEN) for key, file in files.items()}
    # in metres on a surface as wide as the set where its real-world size is known (else in
    # texture widths: a surface one unit wide per repeat)
    depth = material.physical_size().get("displacement_depth_m", material.depth / material.shape[1])
    return encode_mtlx(name, files, depth=depth, midlevel=material.midlevel)


def find_material(folder: str | os.PathLike) -> tuple[str, dict]:
    """The material set in ``folder``: its name and its ``NAME.json``.

    The set is the one JSON file with a ``size`` and a ``displacement_depth_px``.

    Parameters
    ----------
    folder : str or PathLike
        The set's folder.

    Returns
    -------
    name : str
    meta : dict
        The parsed ``NAME.json``.

    Raises
    ------
    ImageReadError
        Not a folder, no set, several sets, or an unreadable record.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ImageReadError(f"{folder}: not a folder")
    found, unreadable = [], []
    for path in sorted(folder.glob("*.json")):
        try:
            meta = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            if (folder / f"{path.stem}_Color.png").exists():
                unreadable.append(path.name)
            continue
        if isinstance(meta, dict) and "displacement_depth_px" in meta and "size" in meta:
            found.append((path.stem, meta))
    if not found and unreadable:
        raise ImageReadError(f"{folder}/{unreadable[0]}: unreadable material record (not UTF-8 JSON)")
    if not found:
        raise ImageReadError(
            f"{folder}: no material set (NAME.json with NAME_Color.png ...) found; "
            "make one with `barkgen material` or `barkgen generate --material`"
        )
    if len(found) > 1:
        raise ImageReadError(
            f"{folder}: holds several material sets ({', '.join(n for n, _ in found)}); give a folder with one"
        )
    return found[0]


def _unit(image: np.ndarray) -> np.ndarray:
    return image.astype(np.float32) / (65535.0 if image.dtype == np.uint16 else 255.0)


def _record_number(meta: dict, key: str, where: str, default: float | None = None) -> float:
    value = meta.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise InvalidInputError(f"{where}: {key!r} must be a finite number, not {value!r}")
    return float(value)


def read_material(folder: str | os.PathLike):
    """A :class:`~barkgen.material.MaterialSet` read back from a set folder, and its metadata.

    Parameters
    ----------
    folder : str or PathLike
        A folder written from :func:`encode_material`'s files.

    Returns
    -------
    material : MaterialSet
        Colour, height (from the displacement, its depth and midlevel), normals (from
        ``NAME_NormalGL.png``), AO and roughness.
    meta : dict
        The parsed ``NAME.json``.

    Raises
    ------
    ImageReadError
        No readable set in the folder.
    InvalidInputError
        Maps of different sizes, a displacement that is not 16-bit, a bad record.
    """
    from barkgen.material import MaterialSet, decode_normals

    folder = Path(folder)
    name, meta = find_material(folder)
    where = f"{folder}/{name}.json"
    depth = _record_number(meta, "displacement_depth_px", where)
    midlevel = _record_number(meta, "displacement_midlevel", where, 0.5)
    if depth < 0 or not 0 <= midlevel <= 1:
        raise InvalidInputError(f"{where}: displacement depth must be >= 0 and midlevel in [0, 1]")
    tileable = meta.get("tileable", False)
    if not isinstance(tileable, bool):
        raise InvalidInputError(f"{where}: 'tileable' must be true or false, not {tileable!r}")
    maps = {suffix: read_image(folder / f"{name}_{suffix}.png") for suffix in MAP_SUFFIXES if suffix != "NormalDX"}
    shapes = {s: m.shape[:2] for s, m in maps.items()}
    if len(set(shapes.values())) != 1:
        listing = ", ".join(f"{s} {v[1]}x{v[0]}" for s, v in shapes.items())
        raise InvalidInputError(f"{folder}: the maps of {name} differ in size ({listing})")
    disp = maps["Displacement"]
    if disp.dtype != np.uint16:
        raise InvalidInputError(f"{folder}/{name}_Displacement.png must be a 16-bit grey PNG")
    if maps["NormalGL"].shape[2] < 3:
        raise InvalidInputError(f"{folder}/{name}_NormalGL.png must be an RGB normal map")
    color = maps["Color"]
    if color.shape[2] == 1:
        color = np.repeat(color, 3, axis=2)
    material = MaterialSet(
        color=_unit(color[..., :3]),
        height=(_unit(disp[..., 0]) - midlevel) * depth,
        normals=decode_normals(maps["NormalGL"]),
        ao=_unit(maps["AmbientOcclusion"][..., 0]),
        roughness=_unit(maps["Roughness"][..., 0]),
        tile=tileable,
    )
    if "width_m" in meta:  # (a set written before the real-world size has none)
        width_m = _record_number(meta, "width_m", where)
        if width_m <= 0:
            raise InvalidInputError(f"{where}: 'width_m' must be > 0")
        material.pixel_size_m = width_m / material.shape[1]
        material.size_given = meta.get("real_size") == "given"
    return material, meta
