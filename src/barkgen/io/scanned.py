"""Scanned material sets as exemplars: a folder of maps recognised by their file names.

Artists own scanned PBR sets (ambientCG, Poly Haven, Megascans, their own photogrammetry) and
want the *whole set* made bigger. The maps are told apart by the last word of their file names,
case-insensitive, after any resolution or format tag (``_2K``, ``_4k``, ``_1K-PNG``, ``_2048``):

========================  =============================================================
map                       names (ambientCG / Poly Haven / Megascans and common others)
========================  =============================================================
colour                    ``Color``, ``diff``, ``Albedo``, ``BaseColor``, ``Diffuse``, ``col``
normal, OpenGL            ``NormalGL``, ``nor_gl``, ``Normal`` and ``nor`` (see below)
normal, DirectX           ``NormalDX``, ``nor_dx``
height                    ``Displacement``, ``disp``, ``Height``
roughness                 ``Roughness``, ``rough``; ``Gloss`` / ``Smoothness`` (1 - roughness)
ambient occlusion         ``AmbientOcclusion``, ``ao``, ``Occlusion``
metalness                 ``Metalness``, ``Metallic``, ``metal``
opacity                   ``Opacity``, ``Alpha``
AO, roughness, metalness  ``arm`` (Poly Haven's packed R, G, B)
cavity                    ``Cavity`` (recognised; barkgen's AO stands for it)
========================  =============================================================

A plain ``Normal`` is read as OpenGL (the glTF, Blender and Poly Haven convention) unless
``normal_convention="dx"``. An image whose name carries no map word is the colour when the set
has no colour map (``birch.jpg`` beside ``birch_normal.jpg``), and the set's preview otherwise
(ambientCG's ``Bark001.png``; left out). Files that are not images (``.txt``, ``.mtlx``,
``.usda``, ``.json``) are left out. Everything else — an image of no known map, two maps of one
kind, maps of two sets, maps of different sizes — is refused in one line.

A set may come as a folder (:func:`read_scanned_set`) or as file bytes, a zip's
(:func:`read_set_zip`, :func:`scanned_set_from_files`). This module only reads: :func:`barkgen.material.scanned_material` makes the set's
:class:`~barkgen.material.MaterialSet`.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import numpy as np

from barkgen.errors import ImageReadError, InvalidInputError

#: the image files a set may hold
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".webp")
#: map kinds, each with the (lower-case, separator-free) names that mean it
MAP_WORDS: dict[str, tuple[str, ...]] = {
    "color": ("color", "colour", "diff", "diffuse", "albedo", "basecolor", "basecolour", "col", "basemap"),
    "normal_gl": ("normalgl", "norgl", "normalopengl", "nrmgl"),
    "normal_dx": ("normaldx", "nordx", "normaldirectx", "nrmdx"),
    "normal": ("normal", "nor", "nrm", "normals", "norm"),
    "height": ("displacement", "disp", "height", "heightmap", "bump"),
    "roughness": ("roughness", "rough"),
    "gloss": ("gloss", "glossiness", "smoothness"),
    "ao": ("ambientocclusion", "ao", "occlusion", "occ"),
    "metalness": ("metalness", "metallic", "metal"),
    "opacity": ("opacity", "alpha"),
    "arm": ("arm",),
    "cavity": ("cavity",),
}
_WORD_KIND = {word: kind for kind, words in MAP_WORDS.items() for word in words}
#: resolution and format tags that may follow or precede the map word
_TAG = re.compile(r"^(\d+k|\d{3,5}(px)?|\d+x\d+|png|jpe?g|tiff?|exr|webp|hq|lq)$", re.IGNORECASE)
_SPLIT = re.compile(r"[_\-\s.]+")
#: map kinds read and how many channels they keep
NORMAL_CONVENTIONS = ("gl", "dx")


def map_kind(filename: str) -> tuple[str, str | None]:
    """``(set stem, map kind)`` of a file name; kind ``None`` when no map word is found.

    >>> map_kind("bark_willow_02_nor_gl_2k.png")
    ('bark_willow_02', 'normal_gl')
    >>> map_kind("Bark001_1K-PNG_Color.png")
    ('Bark001', 'color')
    >>> map_kind("birch_smooth_lenticels_01.jpg")
    ('birch_smooth_lenticels_01', None)
    """
    stem = Path(filename).stem
    tokens = [t for t in _SPLIT.split(stem) if t]
    words = [t for t in tokens if not _TAG.match(t)]
    for n in (3, 2, 1):  # the longest name first: "normal_gl" before "gl"
        if len(words) > n - 1 and "".join(words[-n:]).lower() in _WORD_KIND:
            kind = _WORD_KIND["".join(words[-n:]).lower()]
            return "_".join(words[:-n]), kind
    return "_".join(words), None


def recognise_set(filenames, *, folder: str = "the set") -> tuple[str, dict[str, str]]:
    """The set's stem and its maps, ``kind -> file name``, from a folder's file names.

    Parameters
    ----------
    filenames : iterable of str
        The folder's file names.
    folder : str
        The folder, as named in errors.

    Returns
    -------
    stem : str
    maps : dict of str to str
        At least ``"color"``; any of :data:`MAP_WORDS`' kinds.

    Raises
    ------
    InvalidInputError
        An image of no known map, two maps of one kind, maps of two sets, or no colour map.
    """
    kinds: dict[str, str] = {}
    stems: dict[str, str] = {}
    bare: list[tuple[str, str]] = []
    for name in sorted(filenames):
        if Path(name).suffix.lower() not in IMAGE_EXTENSIONS or name.startswith("."):
            continue
        stem, kind = map_kind(name)
        if kind is None:
            bare.append((stem, name))
            continue
        if kind in kinds:
            raise InvalidInputError(f"{folder}: two {kind} maps ({kinds[kind]}, {name}); keep one")
        kinds[kind] = name
        stems[name] = stem
    if len({s.lower() for s in stems.values()}) > 1:
        first, other = sorted({s for s in stems.values()}, key=str.lower)[:2]
        raise InvalidInputError(f"{folder}: holds maps of two sets ({first}, {other}); give a folder with one set")
    stem = next(iter(stems.values()), bare[0][0] if bare else "")
    for bare_stem, name in bare:
        if bare_stem.lower() != stem.lower():
            raise InvalidInputError(
                f"{folder}/{name}: not a map of {stem or 'a set'} (its name "
                "names no colour, normal, height, roughness, AO, metalness "
                "or opacity map)"
            )
        if "color" not in kinds:
            kinds["color"] = name
        # else: the set's preview picture (ambientCG's NAME.png), left out
    if "color" not in kinds:
        raise InvalidInputError(f"{folder}: no colour map (NAME_Color, _diff, _Albedo ...) found")
    normals = [k for k in ("normal_gl", "normal_dx", "normal") if k in kinds]
    if len(normals) > 1:  # both conventions of one map: the OpenGL one is read
        for k in normals[1:]:
            kinds.pop(k)
    return stem, kinds


@dataclass
class ScannedSet:
    """The maps of a scanned set, decoded, all of one size.

    Attributes
    ----------
    name : str
        The set's stem (``Bark001``).
    files : dict of str to str
        ``kind -> file name`` of the maps read.
    color : ndarray, shape (h, w, 3)
        The colour as read (uint8 or uint16): the synthesis' exemplar.
    normals : ndarray of float32, shape (h, w, 3), or None
        Unit normals, OpenGL convention (a DirectX map is converted).
    height : ndarray of float32, shape (h, w), or None
        The displacement in [0, 1] (0 = deepest), at its file's precision.
    roughness, ao, metalness, opacity : ndarray of float32, shape (h, w), or None
        In [0, 1]; a gloss map is read as ``1 - gloss``.
    bits : dict of str to int
        Bits per channel of each map's file.
    """

    name: str
    files: dict[str, str]
    color: np.ndarray
    normals: np.ndarray | None = None
    height: np.ndarray | None = None
    roughness: np.ndarray | None = None
    ao: np.ndarray | None = None
    metalness: np.ndarray | None = None
    opacity: np.ndarray | None = None
    bits: dict[str, int] = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int]:
        return self.color.shape[:2]

    @property
    def maps(self) -> tuple[str, ...]:
        """The maps the scan has, of ``normals, height, roughness, ao, metalness, opacity``."""
        return tuple(
            k for k in ("normals", "height", "roughness", "ao", "metalness", "opacity") if getattr(self, k) is not None
        )


def is_set_folder(path: str | os.PathLike) -> bool:
    """The path is a folder (read as a scanned set by :func:`read_scanned_set`)."""
    return Path(path).is_dir()


def _grey(image: np.ndarray) -> np.ndarray:
    scale = 65535.0 if image.dtype == np.uint16 else 255.0
    return image[..., 0].astype(np.float32) / scale


def read_scanned_set(folder: str | os.PathLike, *, normal_convention: str = "gl") -> ScannedSet:
    """Read a scanned material set from a folder (see the module for the names it knows).

    Parameters
    ----------
    folder : str or PathLike
        The set's folder.
    normal_convention : {"gl", "dx"}, default "gl"
        How a normal map named only ``Normal`` is read (``NormalGL`` / ``NormalDX`` say it).

    Returns
    -------
    ScannedSet

    Raises
    ------
    ImageReadError
        Not a folder, or an unreadable map.
    InvalidInputError
        Unknown or mismatched files, maps of different sizes, a normal map that is not RGB.
    """
    from barkgen.io.images import read_image_bytes

    folder = Path(folder)
    if not folder.is_dir():
        raise ImageReadError(f"{folder}: not a folder")
    names = [p.name for p in folder.iterdir() if p.is_file()]
    _, files = recognise_set(names, folder=str(folder))
    data = {name: read_image_bytes(folder / name) for name in files.values()}
    return scanned_set_from_files(data, normal_convention=normal_convention, where=str(folder))


def scanned_set_files(files: Mapping[str, bytes], *, where: str = "the set") -> dict[str, bytes]:
    """The files of ``files`` that :func:`scanned_set_from_files` reads (its maps), by name.

    Parameters
    ----------
    files : mapping of str to bytes
        File name -> file bytes (a folder's or a zip's).
    where : str
        What errors call the set.

    Returns
    -------
    dict of str to bytes

    Raises
    ------
    InvalidInputError
        Unknown or mismatched files (:func:`recognise_set`).
    """
    _, kinds = recognise_set(files, folder=where)
    return {name: files[name] for name in kinds.values()}


def scanned_set_from_files(
    files: Mapping[str, bytes], *, normal_convention: str = "gl", where: str = "the set"
) -> ScannedSet:
    """A scanned set from its files' bytes, by file name (what :func:`read_scanned_set` reads
    from a folder and :func:`read_set_zip` from a zip).

    Parameters
    ----------
    files : mapping of str to bytes
        File name -> file bytes; files that are not maps are left out as
        :func:`recognise_set` says.
    normal_convention : {"gl", "dx"}, default "gl"
        How a normal map named only ``Normal`` is read.
    where : str
        What errors call the set.

    Returns
    -------
    ScannedSet

    Raises
    ------
    ImageReadError
        An unreadable map.
    InvalidInputError
        Unknown or mismatched files, maps of different sizes, a normal map that is not RGB.
    """
    from barkgen.io.images import decode_image
    from barkgen.material.maps import decode_normals

    if normal_convention not in NORMAL_CONVENTIONS:
        raise InvalidInputError(f"normal convention must be gl or dx, not {normal_convention!r}")
    stem, kinds = recognise_set(files, folder=where)
    images = {kind: decode_image(files[name], f"{where}/{name}") for kind, name in kinds.items()}
    sizes = {kind: im.shape[:2] for kind, im in images.items()}
    if len(set(sizes.values())) > 1:
        listing = ", ".join(f"{kinds[k]} {s[1]}x{s[0]}" for k, s in sizes.items())
        raise InvalidInputError(f"{where}: the maps differ in size ({listing}); give maps of one size")
    bits = {kind: 16 if im.dtype == np.uint16 else 8 for kind, im in images.items()}
    color = images.pop("color")
    if color.shape[2] == 1:
        color = np.repeat(color, 3, axis=2)
    scan = ScannedSet(name=stem, files=kinds, color=color, bits=bits)
    for kind in ("normal_gl", "normal_dx", "normal"):
        if kind not in images:
            continue
        rgb = images.pop(kind)
        if rgb.shape[2] < 3:
            raise InvalidInputError(f"{where}/{kinds[kind]}: a normal map must be RGB")
        normals = decode_normals(rgb)
        if kind == "normal_dx" or (kind == "normal" and normal_convention == "dx"):
            normals[..., 1] *= -1.0
        scan.normals = normals
    if "arm" in images:  # Poly Haven's packed R = AO, G = roughness, B = metalness
        arm = images.pop("arm")
        if arm.shape[2] >= 3:
            for channel, kind in enumerate(("ao", "roughness", "metalness")):
                if kind not in images and not (kind == "roughness" and "gloss" in images):
                    images[kind] = arm[..., channel : channel + 1]
    if "gloss" in images:
        gloss = _grey(images.pop("gloss"))
        if "roughness" not in images:
            scan.roughness = 1.0 - gloss
    images.pop("cavity", None)
    for kind in ("height", "roughness", "ao", "metalness", "opacity"):
        if kind in images:
            setattr(scan, kind, _grey(images.pop(kind)))
    return scan


def read_set_zip(data: bytes, *, max_unpacked_bytes: int, where: str = "the zip") -> dict[str, bytes]:
    """The image files of a zip holding one scanned set (as ambientCG and Poly Haven ship
    them), by file name, checked before anything is unpacked.

    Folders inside the zip are flattened (Poly Haven's ``textures/``); macOS's ``__MACOSX``
    copies, hidden files and files that are not images are left out.

    Parameters
    ----------
    data : bytes
        The zip file.
    max_unpacked_bytes : int
        Refuse a zip whose images would unpack to more (a zip bomb, or a 16K set).
    where : str
        What errors call it.

    Returns
    -------
    dict of str to bytes
        File name -> bytes; pass it to :func:`scanned_set_from_files`.

    Raises
    ------
    InvalidInputError
        Not a zip, a damaged or encrypted one, one that unpacks too large, two images of one
        name, or no image.
    """
    import io
    import zipfile

    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
    except (zipfile.BadZipFile, OSError, ValueError):
        raise InvalidInputError(f"{where}: not a zip file") from None
    with archive:
        members = []
        for info in archive.infolist():
            parts = PurePosixPath(info.filename.replace("\\", "/")).parts
            name = parts[-1] if parts else ""
            if info.is_dir() or "__MACOSX" in parts or name.startswith("."):
                continue
            if Path(name).suffix.lower() in IMAGE_EXTENSIONS:
                members.append((name, info))
        if not members:
            raise InvalidInputError(f"{where}: holds no image (PNG, JPEG, TIFF or WebP)")
        total = sum(info.file_size for _, info in members)
        if total > max_unpacked_bytes:
            raise InvalidInputError(
                f"{where}: its images unpack to {total / 2**20:.0f} MB, more than the "
                f"{max_unpacked_bytes / 2**20:.0f} MB allowed; give a smaller set (2K or 4K)"
            )
        files: dict[str, bytes] = {}
        for name, info in members:
            if name in files:
                raise InvalidInputError(f"{where}: holds two files named {name}; give a zip of one set")
            if info.flag_bits & 0x1:
                raise InvalidInputError(f"{where}: {name} is encrypted")
            try:
                with archive.open(info) as member:
                    content = member.read(info.file_size + 1)
            except (zipfile.BadZipFile, OSError, RuntimeError, NotImplementedError, EOFError):
                raise InvalidInputError(f"{where}: {name} cannot be unpacked (a damaged zip?)") from None
            if len(content) != info.file_size:
                raise InvalidInputError(f"{where}: {name} is not the size the zip says (a damaged zip?)")
            files[name] = content
    return files
