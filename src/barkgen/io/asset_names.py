"""The names a material set carries into an artist's library, as ambientCG and Poly Haven
give them: ``ASSET_VARIANT_2K_Color.png``.

- ``ASSET``: the photo's (or the scanned set's) own name made file-safe (:func:`asset_slug`),
  or the name the user gave (``--name``);
- ``VARIANT``: what tells two sets of one photo apart (``seed7``; ``seed7-edit3f9a1c`` for a
  relief-edited one), left out when the user named the set;
- the size tag (:func:`size_tag`): ``1K``, ``2K``, ... for power-of-two widths from 1024, the
  exact ``WIDTHxHEIGHT`` otherwise.

Every file of the set starts with ``ASSET_VARIANT_SIZE`` (:func:`material_set_name`), so sets
of several photos, seeds and sizes can share one folder without a collision.
"""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import PurePath

#: the longest asset name taken from a file name (the whole set name stays within 64)
ASSET_NAME_CHARS = 40
#: the asset name of a photo whose name has nothing file-safe in it
FALLBACK_ASSET = "bark"
#: the licence of the bundled sample photo (``barkgen/data/SAMPLE_LICENSE.txt``)
SAMPLE_LICENCE = "MIT (ez-tree 1.1.0's pine bark; see barkgen/data/SAMPLE_LICENSE.txt)"


def asset_slug(text: str, fallback: str = FALLBACK_ASSET) -> str:
    """A photo's or a set's name as a file-name part: letters, digits, ``_`` and ``-`` as they
    are (``oak_furrowed_moss_01``), every other run of characters one ``-``, at most
    :data:`ASSET_NAME_CHARS`; ``fallback`` when nothing is left.

    >>> asset_slug("Oak bark (moss) #1")
    'Oak-bark-moss-1'
    >>> asset_slug("écorce")
    'corce'
    """
    slug = re.sub(r"[^A-Za-z0-9_-]+", "-", text).strip("-_")[:ASSET_NAME_CHARS].strip("-_")
    return slug or fallback


def photo_asset_name(path: str | PurePath, fallback: str = FALLBACK_ASSET) -> str:
    """The asset name of a photo file: its name without the extension
    (:func:`set_asset_name`)."""
    return set_asset_name(PurePath(path).stem, fallback)


def set_asset_name(stem: str, fallback: str = FALLBACK_ASSET) -> str:
    """The asset name of a photo's or a scanned set's stem, made file-safe
    (:func:`asset_slug`), without a resolution tag at its end (``Bark001_2K-PNG`` ->
    ``Bark001``, ``rock_4096px`` -> ``rock``).

    >>> set_asset_name("Bark001_2K-PNG"), set_asset_name("bark_willow_02")
    ('Bark001', 'bark_willow_02')
    """
    stem = re.sub(r"[_-](\d+k(-(png|jpg|exr))?|\d{3,5}px)$", "", stem, flags=re.IGNORECASE)
    return asset_slug(stem, fallback)


def size_tag(width: int, height: int) -> str:
    """A set's resolution tag: ``1K`` for a width of 1024 px, ``2K``, ``4K``, ... (ambientCG's
    and Poly Haven's, for any height), the exact ``WIDTHxHEIGHT`` for a width that is no power
    of two from 1024.

    >>> size_tag(2048, 2048), size_tag(1024, 512), size_tag(768, 768), size_tag(3072, 1536)
    ('2K', '1K', '768x768', '3072x1536')
    """
    if width >= 1024 and width & (width - 1) == 0:
        return f"{width // 1024}K"
    return f"{width}x{height}"


def edit_tag(edits) -> str:
    """A short, stable tag of a list of relief edits (``edit3f9a1c``): the first six hex digits
    of the SHA-256 of their JSON document (:func:`barkgen.material.edits_document`)."""
    text = json.dumps(edits, sort_keys=True, separators=(",", ":"), default=repr)
    return "edit" + hashlib.sha256(text.encode()).hexdigest()[:6]


def variant_name(seed: int | None = None, edits=None) -> str | None:
    """What tells a set apart from the photo's other sets: ``seed7``, ``seed7-edit3f9a1c``
    (:func:`edit_tag`); ``None`` for neither."""
    parts = [f"seed{seed}"] if seed is not None else []
    if edits:
        parts.append(edit_tag(edits))
    return "-".join(parts) or None


def base_name(asset: str, variant: str | None = None) -> str:
    """``ASSET_VARIANT`` (``ASSET`` without a variant): a set's name before its size tag."""
    return f"{asset}_{variant}" if variant else asset


def material_set_name(base: str, shape: tuple[int, int]) -> str:
    """The name of a set of ``shape`` (``(h, w)``): ``BASE_SIZE`` (:func:`size_tag`), the prefix
    of every file of the set (``BASE_SIZE_Color.png``, ``BASE_SIZE.json``)."""
    return f"{base}_{size_tag(int(shape[1]), int(shape[0]))}"


def sized_shapes(shape: tuple[int, int], widths=()) -> list[tuple[int, int]]:
    """The ``(h, w)`` of each set of a run: one per width in ``widths``, the height in
    ``shape``'s proportion, or ``shape`` itself without widths."""
    h, w = int(shape[0]), int(shape[1])
    if not widths:
        return [(h, w)]
    return [(max(1, round(h * width / w)), int(width)) for width in sorted(set(widths))]


def material_set_names(base: str, shape: tuple[int, int], widths=()) -> list[str]:
    """The set names of a run whose output has ``shape``, written at ``widths`` (or its own
    size): ``[BASE_1K, BASE_2K]``."""
    return [material_set_name(base, s) for s in sized_shapes(shape, widths)]


def library_file_name(set_name: str, file_name: str) -> str:
    """A run's own file (``texture.png``, ``report.json``, ``trunk.glb``) as it goes into an
    artist's library beside the set: ``SET_texture.png``; a file of the set itself
    (``SET_Color.png``, ``SET.json``) as it is."""
    if file_name.startswith((f"{set_name}_", f"{set_name}.")):
        return file_name
    return f"{set_name}_{file_name}"
