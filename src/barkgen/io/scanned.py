"""Scanned material sets as exemplars: a folder of maps recognised by their file names.

Artists own scanned PBR sets (ambientCG, Poly Haven, Megascans, Substance exports, game packs,
their own photogrammetry) and want the *whole set* made bigger. The maps are told apart as
Blender's Node Wrangler tells a folder's textures apart: a file's name (without its extension)
is cut into words at ``_ - .``, spaces and camelCase steps (``BaseColor`` -> ``Base Color``),
case-insensitive; resolution and format tags (``1K``, ``2k``, ``4096``, ``2048px``, ``PNG``)
are no words; the last word, or two or three words run together (``nor gl``, ``Ambient
Occlusion``), that names a map says which (:data:`MAP_WORDS`), and the words before it are the
set's name:

=================  ==========================================================================
map                words (ambientCG / CC0 Textures, Poly Haven, Megascans / Quixel Bridge,
                   Substance, game packs, Node Wrangler's defaults)
=================  ==========================================================================
colour             ``Color``, ``col``, ``diff``, ``Diffuse``, ``Albedo``, ``BaseColor``, ``cc``
normal, OpenGL     ``NormalGL``, ``nor_gl``, ``Normal_OpenGL``
normal, DirectX    ``NormalDX``, ``nor_dx``, ``Normal_DirectX``
normal             ``Normal``, ``nor``, ``nrm``, ``nm`` (the convention: see below)
height             ``Displacement``, ``disp``, ``Height``, ``hm``, ``bump`` (a second one left out)
roughness          ``Roughness``, ``rough``, ``rgh``
gloss              ``Gloss``, ``Glossiness``, ``Smoothness``: roughness = 1 - gloss
specular           ``Specular``, ``spec``, ``sc``: roughness from its level
                   (:func:`~barkgen.io.scanned_maps.specular_roughness`)
ambient occlusion  ``AmbientOcclusion``, ``ao``, ``Occlusion``, ``Mixed_AO``
metalness          ``Metalness``, ``Metallic``, ``metal``
opacity            ``Opacity``, ``Alpha``
packed             ``arm`` / ``ORM``: AO, roughness, metalness in R, G, B
cavity             ``Cavity`` (recognised; barkgen's AO stands for it)
=================  ==========================================================================

The roughness is the set's roughness map, else the packed one's, else ``1 - gloss``, else the
specular map's. The normals' green convention is told from the height where the set has both
(:func:`~barkgen.io.scanned_maps.normal_convention_evidence`), else from the name (``GL``,
``DX``), else ``normal_convention`` (OpenGL by default: glTF, Blender, Poly Haven); a name the
height contradicts is said in one line. Maps of another size than the colour are resampled to
it (:func:`~barkgen.io.scanned_maps.resample_map`), each wrapping where it tiles itself.

An image whose name carries no map word is the colour when the set has no colour map
(``birch.jpg`` beside ``birch_normal.jpg``), and the set's preview otherwise (ambientCG's
``Bark001.png``; left out). Files that are not images (``.txt``, ``.mtlx``, ``.usda``,
``.json``) are left out. An image that cannot be placed (a map barkgen does not read, of another
set, a second map of one kind, of another aspect ratio) is named in one line
(:class:`UnplacedFileWarning`) and the set made from the rest; only a set without a colour map,
or with two, is refused.

A set may come as a folder (:func:`read_scanned_set`) or as file bytes, a zip's
(:func:`read_set_zip`, :func:`scanned_set_from_files`). This module only reads: :func:`barkgen.material.scanned_material` makes the set's
:class:`~barkgen.material.MaterialSet`.
"""

from __future__ import annotations

import os
import re
import warnings
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np

from barkgen.errors import ImageReadError, InvalidInputError

#: the image files a set may hold
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".webp", ".tga", ".exr", ".hdr", ".ppm", ".pgm")
#: map kinds, each with the (lower-case, separator-free) words that mean it, the preferred first
#: (of two height maps, the displacement is kept and the bump left out)
MAP_WORDS: dict[str, tuple[str, ...]] = {
    "color": ("color", "colour", "basecolor", "basecolour", "albedo", "diffuse", "diff", "col", "basemap", "cc"),
    "normal_gl": ("normalgl", "norgl", "normalopengl", "nrmgl", "nmgl"),
    "normal_dx": ("normaldx", "nordx", "normaldirectx", "nrmdx", "nmdx"),
    "normal": ("normal", "normals", "nor", "nrm", "nrml", "norm", "normalmap", "nm"),
    "height": ("displacement", "disp", "dsp", "height", "heightmap", "hm", "bump", "bmp"),
    "roughness": ("roughness", "rough", "rgh"),
    "gloss": ("gloss", "glossiness", "glossy", "smoothness"),
    "specular": ("specular", "specularity", "spec", "spc", "sc"),
    "ao": ("ambientocclusion", "ao", "occlusion", "occ", "mixedao"),
    "metalness": ("metalness", "metallic", "metal", "mtl"),
    "opacity": ("opacity", "alpha"),
    "arm": ("arm", "orm"),
    "cavity": ("cavity",),
}
_WORD_KIND = {word: kind for kind, words in MAP_WORDS.items() for word in words}
#: resolution and format tags that are no words of a name
_TAG = re.compile(r"^(\d+k|\d{3,5}(px)?|\d+x\d+|png|jpe?g|tiff?|exr|webp|hq|lq)$", re.IGNORECASE)
_WORD = re.compile(r"[^_\-\s.]+")
_CAMEL = re.compile(r"(?<=[a-z])(?=[A-Z])|(?<=[A-Z])(?=[A-Z][a-z])")
#: how a normal map named only ``Normal`` is read when the set has no height to tell
NORMAL_CONVENTIONS = ("gl", "dx")


class UnplacedFileWarning(UserWarning):
    """An image of a scanned set's folder or zip that is none of its maps (one line naming it)."""


def _words(stem: str) -> list[tuple[int, int, str]]:
    """``(start, end, word)`` of a name's words: cut at ``_ - .``, spaces and camelCase steps."""
    words = []
    for token in _WORD.finditer(stem):
        cuts = [0] + [m.start() for m in _CAMEL.finditer(token.group())] + [len(token.group())]
        for a, b in zip(cuts[:-1], cuts[1:]):
            if b > a:
                words.append((token.start() + a, token.start() + b, token.group()[a:b]))
    return words


def _name_of(stem: str, words: list[tuple[int, int, str]]) -> str:
    """The stem's text from its first word to its last that is no tag (``""``: none)."""
    kept = [w for w in words if not _TAG.match(w[2])]
    return stem[kept[0][0] : kept[-1][1]] if kept else ""


def _key(name: str) -> str:
    """A set name as compared: its words that are no tags, lower-case, run together."""
    return "".join(w.lower() for _, _, w in _words(name) if not _TAG.match(w))


def _match(filename: str) -> tuple[str, str | None, str]:
    """``(set stem, map kind, the map's word)`` of a file name (see :func:`map_kind`)."""
    stem = Path(filename).stem
    words = _words(stem)
    plain = [i for i, w in enumerate(words) if not _TAG.match(w[2])]
    for end in range(len(plain), 0, -1):
        for n in (3, 2, 1):  # the longest name first: "nor_gl" before "gl"
            if end - n < 0:
                continue
            run = "".join(words[i][2] for i in plain[end - n : end]).lower()
            if run in _WORD_KIND:
                return _name_of(stem, words[: plain[end - n]]), _WORD_KIND[run], run
    return _name_of(stem, words), None, ""


def map_kind(filename: str) -> tuple[str, str | None]:
    """``(set stem, map kind)`` of a file name; kind ``None`` when no map word is found.

    The last word, or two or three words run together (the longest first), that is one of
    :data:`MAP_WORDS`' names the kind; the words before it name the set (tags left out).

    >>> map_kind("bark_willow_02_nor_gl_2k.png")
    ('bark_willow_02', 'normal_gl')
    >>> map_kind("Bark001_1K-PNG_Color.png")
    ('Bark001', 'color')
    >>> map_kind("OakBarkBaseColor.png")
    ('OakBark', 'color')
    >>> map_kind("birch_smooth_lenticels_01.jpg")
    ('birch_smooth_lenticels_01', None)
    """
    stem, kind, _ = _match(filename)
    return stem, kind


def _unplaced(where: str, name: str, why: str) -> None:
    warnings.warn(f"{where}/{name}: left out, {why}", UnplacedFileWarning, stacklevel=3)


def _colour_of(found: list[tuple[str, str, str | None, str]], folder: str) -> tuple[str, str]:
    """``(set name, colour file)`` of the images' ``(file, stem, kind)``: the one colour map,
    else the image with no map word named like the other maps (or the only such image)."""
    colours = [(name, stem) for name, stem, kind, _ in found if kind == "color"]
    if len(colours) > 1:
        keys = sorted({_key(stem) for _, stem in colours})
        if len(keys) > 1:
            first, other = (next(s for _, s in colours if _key(s) == k) for k in keys[:2])
            raise InvalidInputError(f"{folder}: holds maps of two sets ({first}, {other}); give a folder with one set")
        raise InvalidInputError(f"{folder}: two color maps ({colours[0][0]}, {colours[1][0]}); keep one")
    if colours:
        return colours[0][1], colours[0][0]
    bare = [(name, stem) for name, stem, kind, _ in found if kind is None]
    counts = Counter(_key(stem) for _, stem, kind, _ in found if kind is not None)
    if counts:
        key = counts.most_common(1)[0][0]
        match = [(name, stem) for name, stem in bare if _key(stem) == key]
        if match:
            return match[0][1], match[0][0]
    elif len(bare) == 1:
        return bare[0][1], bare[0][0]
    elif len(bare) > 1:
        raise InvalidInputError(
            f"{folder}: holds maps of two sets ({bare[0][1]}, {bare[1][1]}); give a folder with one set"
        )
    raise InvalidInputError(f"{folder}: no colour map (NAME_Color, _diff, _Albedo, _BaseColor ...) found")


def recognise_set(filenames, *, folder: str = "the set") -> tuple[str, dict[str, str]]:
    """The set's stem and its maps, ``kind -> file name``, from a folder's file names.

    Images that are none of the set's maps (a map barkgen does not read, one of another set,
    a second map of one kind) are named in one :class:`UnplacedFileWarning` line each and left
    out; the preview picture named like the set (ambientCG's) silently.

    Parameters
    ----------
    filenames : iterable of str
        The folder's file names.
    folder : str
        The folder, as named in errors and warnings.

    Returns
    -------
    stem : str
    maps : dict of str to str
        At least ``"color"``; any of :data:`MAP_WORDS`' kinds.

    Raises
    ------
    InvalidInputError
        No colour map, or two (of one set or of two).
    """
    found = []
    for name in sorted(filenames):
        if Path(name).suffix.lower() not in IMAGE_EXTENSIONS or name.startswith("."):
            continue
        found.append((name, *_match(name)))
    stem, colour = _colour_of(found, folder)
    kinds: dict[str, str] = {"color": colour}
    rank: dict[str, int] = {}
    for name, file_stem, kind, word in found:
        if name == colour:
            continue
        if _key(file_stem) != _key(stem):
            what = "names no map barkgen reads" if kind is None else f"a {kind} map of another set than {stem}"
            _unplaced(folder, name, what)
            continue
        if kind is None:  # the set's preview picture (ambientCG's NAME.png)
            continue
        order = MAP_WORDS[kind].index(word)
        if kind in kinds:
            kept, dropped = (name, kinds[kind]) if order < rank[kind] else (kinds[kind], name)
            _unplaced(folder, dropped, f"a second {kind} map (kept {kept})")
            if kept == kinds[kind]:
                continue
        kinds[kind], rank[kind] = name, order
    normals = [k for k in ("normal_gl", "normal_dx", "normal") if k in kinds]
    for k in normals[1:]:  # both conventions of one map: the OpenGL one is read
        kinds.pop(k)
    return stem, kinds


@dataclass
class ScannedSet:
    """The maps of a scanned set, decoded, all of the colour's size.

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
        In [0, 1]; from a gloss map ``1 - gloss``, from a specular map its level inverted.
    bits : dict of str to int
        Bits per channel of each map's file.
    wraps : dict of str to (bool, bool)
        ``(rows, columns)`` each map (of :attr:`maps`) tiles itself along, judged from its
        own pixels at its file's size (:func:`~barkgen.io.scanned_maps.own_wraps`).
    info : dict
        How the set was read, for the output's metadata: ``sizes`` (each file's ``[w, h]``,
        where it was resampled), ``normal_convention`` (``gl``/``dx``) and
        ``normal_convention_from`` (``height``, ``name`` or ``default``) with the height's
        ``normal_convention_correlation``, ``roughness_from`` (``roughness``, ``arm``,
        ``gloss``, ``specular``).
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
    wraps: dict[str, tuple[bool, bool]] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)

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


def _levels(image: np.ndarray) -> np.ndarray:
    """An image's channels as float32 in [0, 1], ``(h, w, C)``."""
    scale = 65535.0 if image.dtype == np.uint16 else 255.0
    return image.astype(np.float32) / scale


def read_scanned_set(folder: str | os.PathLike, *, normal_convention: str = "gl") -> ScannedSet:
    """Read a scanned material set from a folder (see the module for the names it knows).

    Parameters
    ----------
    folder : str or PathLike
        The set's folder.
    normal_convention : {"gl", "dx"}, default "gl"
        How a normal map named only ``Normal`` is read when the set has no height to tell
        (``NormalGL`` / ``NormalDX`` say it).

    Returns
    -------
    ScannedSet

    Raises
    ------
    ImageReadError
        Not a folder, or an unreadable map.
    InvalidInputError
        No colour map or two, a normal map that is not RGB.
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
        No colour map or two (:func:`recognise_set`).
    """
    _, kinds = recognise_set(files, folder=where)
    return {name: files[name] for name in kinds.values()}


def scanned_set_from_files(
    files: Mapping[str, bytes], *, normal_convention: str = "gl", where: str = "the set"
) -> ScannedSet:
    """A scanned set from its files' bytes, by file name (what :func:`read_scanned_set` reads
    from a folder and :func:`read_set_zip` from a zip).

    Every map is brought to the colour's size (:func:`~barkgen.io.scanned_maps.resample_map`:
    area-averaged down, bicubic up, wrapping along the axes that map tiles along itself,
    normals renormalised, in float so 16 bits stay 16); a map of another aspect ratio is left
    out in one line.

    Parameters
    ----------
    files : mapping of str to bytes
        File name -> file bytes; files that are not maps are left out as
        :func:`recognise_set` says.
    normal_convention : {"gl", "dx"}, default "gl"
        How a normal map named only ``Normal`` is read when the set has no height to tell.
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
        No colour map or two, a normal map that is not RGB.
    """
    from barkgen.io.images import decode_image
    from barkgen.io.scanned_maps import fits_aspect

    if normal_convention not in NORMAL_CONVENTIONS:
        raise InvalidInputError(f"normal convention must be gl or dx, not {normal_convention!r}")
    stem, kinds = recognise_set(files, folder=where)
    # a map of values (a height in an EXR) is read linear; the colour, tone-mapped if it is HDR
    images = {
        kind: decode_image(files[name], f"{where}/{name}", linear=kind != "color") for kind, name in kinds.items()
    }
    color = images.pop("color")
    if color.shape[2] == 1:
        color = np.repeat(color, 3, axis=2)
    for kind, image in list(images.items()):
        if not fits_aspect(image.shape[:2], color.shape[:2]):
            h, w = image.shape[:2]
            _unplaced(where, kinds[kind], f"{w}x{h} is not the shape of the colour's {color.shape[1]}x{color.shape[0]}")
            del images[kind]
            kinds.pop(kind)
    bits = {kind: 16 if im.dtype == np.uint16 else 8 for kind, im in images.items()}
    bits["color"] = 16 if color.dtype == np.uint16 else 8
    scan = ScannedSet(name=stem, files=kinds, color=color, bits=bits)
    sizes = {kinds[k]: [im.shape[1], im.shape[0]] for k, im in images.items() if im.shape[:2] != color.shape[:2]}
    if sizes:
        scan.info["sizes"] = sizes
    _read_levels(scan, images, where)
    _read_normals(scan, images, where, normal_convention)
    return scan


def _placed(scan: ScannedSet, kind: str, image: np.ndarray, *, normals: bool = False) -> np.ndarray:
    """A map's float pixels at the colour's size; its own wrap recorded as ``kind``'s."""
    from barkgen.io.scanned_maps import own_wraps, resample_map

    wraps = own_wraps(image)
    scan.wraps[kind] = wraps
    return resample_map(image, scan.shape, wraps=wraps, normals=normals)


def _read_levels(scan: ScannedSet, images: dict[str, np.ndarray], where: str) -> None:
    """The set's one-channel maps (height, roughness, AO, metalness, opacity) onto ``scan``:
    the roughness from the roughness map, else the packed ``arm``'s green, else ``1 - gloss``,
    else the specular map's level (:func:`~barkgen.io.scanned_maps.specular_roughness`)."""
    from barkgen.io.scanned_maps import specular_roughness

    levels = {k: _levels(images[k]) for k in images if not k.startswith("normal")}
    arm = levels.pop("arm", None)
    if arm is not None and arm.shape[2] >= 3:  # Poly Haven's packed R = AO, G = roughness, B = metalness
        for channel, kind in enumerate(("ao", "roughness", "metalness")):
            if kind not in levels:
                levels[kind] = arm[..., channel : channel + 1]
                scan.info.setdefault("from_arm", []).append(kind)
    gloss, specular = levels.pop("gloss", None), levels.pop("specular", None)
    levels.pop("cavity", None)
    if "roughness" in levels:
        scan.info["roughness_from"] = "arm" if "roughness" in scan.info.get("from_arm", ()) else "roughness"
    elif gloss is not None:
        levels["roughness"] = 1.0 - gloss[..., :1]
        scan.info["roughness_from"] = "gloss"
    elif specular is not None:
        levels["roughness"] = specular_roughness(specular)[..., None]
        scan.info["roughness_from"] = "specular"
    for kind in ("height", "roughness", "ao", "metalness", "opacity"):
        if kind in levels:
            setattr(scan, kind, _placed(scan, kind, levels[kind][..., 0]))


def _read_normals(scan: ScannedSet, images: dict[str, np.ndarray], where: str, default: str) -> None:
    """The set's normal map onto ``scan`` as OpenGL unit vectors: its green's convention from
    the height where the set has one, else its name, else ``default``; a name the height
    contradicts said in one line."""
    from barkgen.io.scanned_maps import normal_convention_evidence
    from barkgen.material.maps import decode_normals

    kind = next((k for k in ("normal_gl", "normal_dx", "normal") if k in images), None)
    if kind is None:
        return
    rgb = images[kind]
    if rgb.shape[2] < 3:
        raise InvalidInputError(f"{where}/{scan.files[kind]}: a normal map must be RGB")
    normals = _placed(scan, "normals", decode_normals(rgb), normals=True)
    named = {"normal_gl": "gl", "normal_dx": "dx"}.get(kind)
    convention, source = (named, "name") if named else (default, "default")
    if scan.height is not None:
        evidence, correlation = normal_convention_evidence(normals, scan.height)
        scan.info["normal_convention_correlation"] = round(correlation, 3)
        if evidence is not None:
            if named and evidence != named:
                warnings.warn(
                    f"{where}/{scan.files[kind]}: named {named.upper()} but its green follows "
                    f"{evidence.upper()} by the height (correlation {correlation:+.2f}); read as {evidence.upper()}",
                    UserWarning,
                    stacklevel=3,
                )
            convention, source = evidence, "height"
    if convention == "dx":
        normals[..., 1] *= -1.0
    scan.normals = normals
    scan.info["normal_convention"] = convention
    scan.info["normal_convention_from"] = source


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
            raise InvalidInputError(f"{where}: holds no image (PNG, JPEG, TIFF, WebP, TGA, EXR, HDR, PPM or PGM)")
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
