"""The library's records as Python values: an :class:`Exemplar` (a row of ``exemplars``) and a
:class:`Result` (a row of ``results`` with its files)."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["EXEMPLAR_SELECT", "Exemplar", "Result"]

#: the exemplars' rows with the kinds of their set's maps (``maps``, comma-separated); add a
#: ``WHERE`` on ``e``
EXEMPLAR_SELECT = (
    "SELECT e.*, (SELECT group_concat(m.kind, ',') FROM exemplar_maps m "
    "WHERE m.exemplar_id = e.id AND m.kind != 'color') AS maps, "
    "COALESCE((SELECT m.file_hash FROM exemplar_maps m WHERE m.exemplar_id = e.id AND m.kind = 'color'), "
    "e.image_hash) AS photo_hash FROM exemplars e"
)


@dataclass(frozen=True)
class Exemplar:
    """A bark photo of the library (a row of ``exemplars``).

    Attributes
    ----------
    id, width, height : int
        Its id and the photo's size in pixels.
    name : str
    species, bark_type, licence, source : str or None
        What the user said about it.
    image_hash : str
        Its identity: SHA-256 of the image file's bytes (its name in ``objects/``) for a photo,
        the set's digest for a scanned set (:func:`barkgen.library.store.set_digest`).
    created : str
        When it was added (ISO 8601, UTC).
    maps : tuple of str
        The kinds of the maps beside the photo when it is a scanned material set (``normal_gl``,
        ``roughness``, ``ao``, ...; :func:`barkgen.io.recognise_set`), else empty.
    photo_hash : str
        SHA-256 of its photo's file (its name in ``objects/``): ``image_hash`` for a photo, the
        set's colour file for a scanned set.
    """

    id: int
    name: str
    species: str | None
    bark_type: str | None
    licence: str | None
    source: str | None
    image_hash: str
    width: int
    height: int
    created: str
    maps: tuple[str, ...] = ()
    photo_hash: str = ""

    @classmethod
    def from_row(cls, row) -> Exemplar:
        """The record of a row of :data:`EXEMPLAR_SELECT`."""
        fields = dict(row)
        kinds = fields.pop("maps", None)
        photo_hash = fields.pop("photo_hash", None) or fields["image_hash"]
        return cls(**fields, maps=tuple(sorted(kinds.split(","))) if kinds else (), photo_hash=photo_hash)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class Result:
    """A generated texture and its files (a row of ``results``).

    Attributes
    ----------
    id, exemplar_id, seed : int
        Its id, the exemplar it was made from and its seed.
    params, timings : dict
        The parameters of the run and its seconds per stage.
    created : str
        When it was recorded (ISO 8601, UTC).
    parent_id : int or None
        The result it was continued from (painted labels), if any.
    files : dict of str to str
        File name -> content hash.
    """

    id: int
    exemplar_id: int
    params: dict
    seed: int
    timings: dict
    created: str
    parent_id: int | None = None
    files: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}
