"""The library: exemplars (photos and scanned sets), their cached analyses and results (see
:mod:`barkgen.library`)."""

from __future__ import annotations

import json
import os
import sqlite3
from collections.abc import Mapping
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.library.database import Database
from barkgen.library.errors import LibraryError, NotFoundError, _ReadOnly
from barkgen.library.jobs import JobTable
from barkgen.library.records import EXEMPLAR_SELECT, Exemplar, Result
from barkgen.library.schema import SCHEMA_VERSION
from barkgen.library.store import ObjectStore, content_hash, default_library_path, set_digest

__all__ = ["Exemplar", "Library", "LibraryError", "NotFoundError", "Result", "default_library_path", "SCHEMA_VERSION"]

SAMPLE_NAME = "Sample pine bark"
#: every stored file a row refers to
_FILES_IN_USE = (
    "SELECT image_hash FROM exemplars UNION SELECT file_hash FROM exemplar_maps UNION SELECT file_hash FROM analyses "
    "UNION SELECT file_hash FROM result_files"
)


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _checked_photo(data: bytes, name: str, max_pixels: int | None, **fields: str | None) -> tuple[str, tuple[int, ...]]:
    """An exemplar's name (stripped) and its photo's shape, once the name, the other text
    ``fields`` and the photo are checked (:meth:`Library.add_exemplar`'s errors)."""
    from barkgen._shared.checks import MIN_SIDE
    from barkgen.io import decode_image

    name = (name or "").strip()
    if not name or len(name) > 200:
        raise InvalidInputError("an exemplar needs a name of 1 to 200 characters")
    for what, value in (("name", name), *fields.items()):
        if value is not None and len(value) > 500:
            raise InvalidInputError(f"the {what.replace('_', ' ')} must be at most 500 characters")
        if value is not None and not value.isprintable():  # a newline would break a listing
            raise InvalidInputError(f"the {what.replace('_', ' ')} must be one line of printable text")
    image = decode_image(data, name, max_pixels=max_pixels)
    if min(image.shape[:2]) < MIN_SIDE:  # a 1x1 upload is no bark (it failed later)
        raise InvalidInputError(
            f"{name}: {image.shape[1]}x{image.shape[0]} px; a bark photo needs at least {MIN_SIDE} px on each side"
        )
    return name, image.shape


def canonical_params(params: Mapping) -> str:
    """The one JSON text of a parameter dict (sorted keys), used as a key."""
    return json.dumps(dict(params), sort_keys=True, separators=(",", ":"))


class Library(Database):
    """The exemplar library in folder ``path`` (made when missing; see the module docstring).

    Parameters
    ----------
    path : str or PathLike, optional
        The folder (default: :func:`default_library_path`).
    add_sample : bool, default True
        Add the bundled sample photo the first time the library is opened.

    Attributes
    ----------
    path, db_path : Path
        The folder and its ``library.sqlite``.
    store : ObjectStore
        The content-addressed files (``path / "objects"``).

    Raises
    ------
    LibraryError
        The folder cannot be made or used, or the database is not a barkgen library.

    References
    ----------
    .. [1] laitoch2018, §1 (the designer picks a bark photo from a library or adds their own).

    Examples
    --------
    >>> import tempfile
    >>> library = Library(tempfile.mkdtemp())
    >>> [e.name for e in library.exemplars()]
    ['Sample pine bark']
    """

    def __init__(self, path: str | os.PathLike | None = None, *, add_sample: bool = True) -> None:
        self.path = Path(path).expanduser() if path is not None else default_library_path()
        if self.path.exists() and not self.path.is_dir():
            raise LibraryError(f"{self.path}: the library must be a folder, and this is a file")
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise LibraryError(f"{self.path}: cannot make the library folder ({exc.strerror or exc})") from None
        self.db_path = self.path / "library.sqlite"
        self.store = ObjectStore(self.path / "objects")
        #: why the library can only be read (a read-only folder, file or disk), else None
        self.read_only: str | None = self._read_only_reason()
        if self.read_only is None:
            try:
                self._migrate()
            except _ReadOnly as exc:  # the OS said yes, the disk said no (a read-only mount)
                self.read_only = str(exc)
        if self.read_only is not None:
            self._check_readable()
        elif add_sample:
            self._add_sample_once()

    def _add_sample_once(self) -> None:
        """The bundled sample, the first time this library is opened (removing it later is
        the user's choice: it is not added again)."""
        if self._read("SELECT 1 FROM settings WHERE key = 'sample_added'"):
            return
        from barkgen.data import sample_exemplar_path

        with self._transaction() as conn:  # check and add under one write lock
            if conn.execute("SELECT 1 FROM settings WHERE key = 'sample_added'").fetchone():
                return
            self._insert_exemplar(
                conn,
                sample_exemplar_path().read_bytes(),
                name=SAMPLE_NAME,
                species="pine",
                bark_type="plated",
                licence="MIT",
                source="barkgen's bundled sample (npm @dgreenheck/ez-tree 1.1.0, texturecan.com 588)",
            )
            conn.execute("INSERT OR REPLACE INTO settings VALUES ('sample_added', ?)", (_now(),))

    # -- exemplars ------------------------------------------------------------------------
    def add_exemplar(
        self,
        data: bytes,
        name: str,
        *,
        species: str | None = None,
        bark_type: str | None = None,
        licence: str | None = None,
        source: str | None = None,
        max_pixels: int | None = None,
    ) -> Exemplar:
        """Add the image file ``data``; the same bytes added twice give the same exemplar.

        Parameters
        ----------
        data : bytes
            The image file, checked by decoding it (any format :func:`barkgen.io.read_image` reads).
        name : str
            1 to 200 characters.
        species, bark_type, licence, source : str, optional
            At most 500 characters each.
        max_pixels : int, optional
            Refuse larger images (:class:`~barkgen.errors.ImageTooLargeError`).

        Returns
        -------
        Exemplar

        Raises
        ------
        InvalidInputError
            A bad name or field.
        ImageReadError
            Bytes that are not a readable image.
        """
        name, shape = _checked_photo(
            data, name, max_pixels, species=species, bark_type=bark_type, licence=licence, source=source
        )
        with self._transaction() as conn:
            exemplar_id = self._insert_exemplar(
                conn,
                data,
                name,
                species=species,
                bark_type=bark_type,
                licence=licence,
                source=source,
                shape=shape,
            )
        return self.exemplar(exemplar_id)

    def add_scanned_set(
        self,
        files: Mapping[str, bytes],
        name: str | None = None,
        *,
        species: str | None = None,
        bark_type: str | None = None,
        licence: str | None = None,
        source: str | None = None,
        max_pixels: int | None = None,
        where: str | None = None,
    ) -> Exemplar:
        """Add a scanned material set: its colour map is the exemplar's photo, its other maps
        are kept beside it (:meth:`set_files`) and make the material of its results.

        A set is its own entry, whatever else the library holds: a photo of the same colour or
        another set with it stays as it is (their results, analyses and maps apart). The same
        set added again (the same maps, byte for byte) gives its entry. The entry's
        :attr:`~barkgen.library.Exemplar.image_hash` is the set's digest (:func:`set_digest`);
        its photo is the set's colour file (:attr:`~barkgen.library.Exemplar.photo_hash`).

        Parameters
        ----------
        files : mapping of str to bytes
            The set's files by name (a folder's or a zip's, :func:`barkgen.io.read_set_zip`);
            what is not one of its maps is left out as :func:`barkgen.io.recognise_set` says.
        name : str, optional
            1 to 200 characters (default: the set's name, ``Bark001``).
        species, bark_type, licence, source, max_pixels
            As :meth:`add_exemplar`.
        where : str, optional
            What errors call the set (default: its name).

        Returns
        -------
        Exemplar

        Raises
        ------
        InvalidInputError
            No colour map, or two; a bad name or field (maps of other sizes are resampled to
            the colour's, files that are no map are left out with a warning).
        ImageReadError
            A map that is not a readable image.
        """
        from barkgen.io import recognise_set, scanned_set_files, scanned_set_from_files

        where = where or name or "the set"
        maps = scanned_set_files(files, where=where)
        stem, kinds = recognise_set(maps, folder=where)
        colour = maps[kinds["color"]]
        name, shape = _checked_photo(
            colour,
            name or stem or "scanned set",
            max_pixels,
            species=species,
            bark_type=bark_type,
            licence=licence,
            source=source,
        )
        scanned_set_from_files(maps, where=where)  # every map decodes, at the colour's size
        kind_of = {file_name: kind for kind, file_name in kinds.items()}
        digest = set_digest(maps)
        with self._transaction() as conn:
            row = conn.execute("SELECT id FROM exemplars WHERE image_hash = ?", (digest,)).fetchone()
            if row is not None:  # the same set again: its entry, as it is
                return self.exemplar(row[0])
            hashes = {file_name: self.store.put(data) for file_name, data in maps.items()}
            exemplar_id = conn.execute(
                "INSERT INTO exemplars (name, species, bark_type, licence, source, image_hash, width, height, "
                "created) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (name, species, bark_type, licence, source, digest, shape[1], shape[0], _now()),
            ).lastrowid
            for file_name, file_hash in hashes.items():
                conn.execute(
                    "INSERT INTO exemplar_maps (exemplar_id, name, kind, file_hash) VALUES (?, ?, ?, ?)",
                    (exemplar_id, file_name, kind_of[file_name], file_hash),
                )
        return self.exemplar(exemplar_id)

    def set_files(self, exemplar_id: int) -> dict[str, bytes]:
        """The files of an exemplar that is a scanned set, by name (its colour among them),
        ready for :func:`barkgen.io.scanned_set_from_files`; empty for a photo.

        Parameters
        ----------
        exemplar_id : int

        Returns
        -------
        dict of str to bytes

        Raises
        ------
        NotFoundError
            No such exemplar.
        """
        self.exemplar(exemplar_id)
        rows = self._read("SELECT name, file_hash FROM exemplar_maps WHERE exemplar_id = ?", (int(exemplar_id),))
        return {row["name"]: self.store.get(row["file_hash"]) for row in rows}

    def _insert_exemplar(
        self, conn, data: bytes, name: str, *, species=None, bark_type=None, licence=None, source=None, shape=None
    ) -> int:
        """Store the photo and insert its row (or find the row of the same bytes), under the
        caller's write lock."""
        if shape is None:
            from barkgen.io import decode_image

            shape = decode_image(data, name).shape
        digest = self.store.put(data)
        conn.execute(
            "INSERT OR IGNORE INTO exemplars (name, species, bark_type, licence, source, image_hash, "
            "width, height, created) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (name, species, bark_type, licence, source, digest, shape[1], shape[0], _now()),
        )
        return conn.execute("SELECT id FROM exemplars WHERE image_hash = ?", (digest,)).fetchone()[0]

    def find_exemplar(self, data: bytes) -> Exemplar | None:
        """The :class:`Exemplar` of exactly these image-file bytes, or None."""
        rows = self._read(f"{EXEMPLAR_SELECT} WHERE e.image_hash = ?", (content_hash(data),))
        return Exemplar.from_row(rows[0]) if rows else None

    def exemplars(self) -> list[Exemplar]:
        """Every exemplar (a list of :class:`Exemplar`), oldest first."""
        return [Exemplar.from_row(row) for row in self._read(f"{EXEMPLAR_SELECT} ORDER BY e.id")]

    def exemplar(self, exemplar_id: int) -> Exemplar:
        """One exemplar by its id.

        Parameters
        ----------
        exemplar_id : int

        Returns
        -------
        Exemplar

        Raises
        ------
        NotFoundError
            No such exemplar.
        """
        rows = self._read(f"{EXEMPLAR_SELECT} WHERE e.id = ?", (int(exemplar_id),))
        if not rows:
            raise NotFoundError(f"no exemplar {exemplar_id} in the library")
        return Exemplar.from_row(rows[0])

    def photo_bytes(self, exemplar_id: int) -> bytes:
        """The exemplar's image file (bytes) as it was added."""
        return self.store.get(self.exemplar(exemplar_id).photo_hash)

    def photo(self, exemplar_id: int) -> np.ndarray:
        """The exemplar's photo, decoded (:func:`barkgen.io.decode_image`).

        Parameters
        ----------
        exemplar_id : int

        Returns
        -------
        ndarray of uint8 or uint16, shape (H, W, C)
        """
        from barkgen.io import decode_image

        exemplar = self.exemplar(exemplar_id)
        return decode_image(self.store.get(exemplar.photo_hash), exemplar.name)

    def remove_exemplar(self, exemplar_id: int) -> None:
        """Remove an exemplar with its analyses and results (and the files nothing else uses).

        Parameters
        ----------
        exemplar_id : int

        Raises
        ------
        NotFoundError
            No such exemplar.
        """
        self.exemplar(exemplar_id)
        with self._transaction() as conn:
            conn.execute("DELETE FROM exemplars WHERE id = ?", (int(exemplar_id),))
            self._sweep(conn)

    # -- analyses -------------------------------------------------------------------------
    def analysis(self, exemplar_id: int, kind: str, params: Mapping) -> bytes | None:
        """The cached analysis file of ``kind`` with ``params``, or None.

        Parameters
        ----------
        exemplar_id : int
        kind : str
            What the analysis is (``labels``, ``thumbnail``, ...).
        params : mapping
            Its parameters (compared as canonical JSON).

        Returns
        -------
        bytes or None
        """
        rows = self._read(
            "SELECT file_hash FROM analyses WHERE exemplar_id = ? AND kind = ? AND params = ?",
            (int(exemplar_id), kind, canonical_params(params)),
        )
        if not rows or not self.store.exists(rows[0]["file_hash"]):
            return None
        return self.store.get(rows[0]["file_hash"])

    def put_analysis(self, exemplar_id: int, kind: str, params: Mapping, data: bytes) -> None:
        """Cache an analysis file of an exemplar, replacing one with the same kind and params.

        Parameters
        ----------
        exemplar_id : int
        kind : str
        params : mapping
        data : bytes
            The file.
        """
        self.exemplar(exemplar_id)
        with self._transaction() as conn:
            digest = self.store.put(data)
            conn.execute(
                "INSERT OR REPLACE INTO analyses (exemplar_id, kind, params, file_hash, "
                "created) VALUES (?, ?, ?, ?, ?)",
                (int(exemplar_id), kind, canonical_params(params), digest, _now()),
            )

    # -- results --------------------------------------------------------------------------
    def add_result(
        self,
        exemplar_id: int,
        params: Mapping,
        seed: int,
        files: Mapping[str, bytes],
        timings: Mapping | None = None,
        parent_id: int | None = None,
    ) -> Result:
        """Record a generated result and store its files.

        All files are stored before the row exists, so a listed result always has every file.

        Parameters
        ----------
        exemplar_id, seed : int
            The exemplar it was made from and the run's seed.
        params : mapping
            The run's parameters.
        files : mapping of str to bytes
            File name -> content.
        timings : mapping, optional
            Seconds per stage.
        parent_id : int, optional
            The result it continues (dropped if that result was removed meanwhile).

        Returns
        -------
        Result

        Raises
        ------
        NotFoundError
            No such exemplar.
        """
        self.exemplar(exemplar_id)
        with self._transaction() as conn:
            # files are stored under the write lock, so no removal can take one of them
            # between its store and this row (a rolled-back insert leaves them to the next
            # removal's sweep)
            hashes = {name: self.store.put(data) for name, data in files.items()}
            if (
                parent_id is not None
                and not conn.execute("SELECT 1 FROM results WHERE id = ?", (parent_id,)).fetchone()
            ):
                parent_id = None  # the parent was removed meanwhile
            cur = conn.execute(
                "INSERT INTO results (exemplar_id, params, seed, timings, parent_id, created) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (
                    int(exemplar_id),
                    canonical_params(params),
                    int(seed),
                    json.dumps(dict(timings or {})),
                    parent_id,
                    _now(),
                ),
            )
            result_id = cur.lastrowid
            conn.executemany(
                "INSERT INTO result_files VALUES (?, ?, ?)",
                [(result_id, name, digest) for name, digest in hashes.items()],
            )
        return self.result(result_id)

    def _result(self, row: sqlite3.Row, files: dict) -> Result:
        return Result(
            id=row["id"],
            exemplar_id=row["exemplar_id"],
            params=json.loads(row["params"]),
            seed=row["seed"],
            timings=json.loads(row["timings"]),
            created=row["created"],
            parent_id=row["parent_id"],
            files=files,
        )

    def result(self, result_id: int) -> Result:
        """One result by its id.

        Parameters
        ----------
        result_id : int

        Returns
        -------
        Result

        Raises
        ------
        NotFoundError
            No such result.
        """
        rows = self._read("SELECT * FROM results WHERE id = ?", (int(result_id),))
        if not rows:
            raise NotFoundError(f"no result {result_id} in the library")
        files = {
            r["name"]: r["file_hash"]
            for r in self._read(
                "SELECT name, file_hash FROM result_files WHERE result_id = ? ORDER BY name", (int(result_id),)
            )
        }
        return self._result(rows[0], files)

    def results(self, exemplar_id: int | None = None) -> list[Result]:
        """Results, newest first (of one exemplar when given).

        Parameters
        ----------
        exemplar_id : int, optional

        Returns
        -------
        list of Result
        """
        where, args = ("WHERE exemplar_id = ?", (int(exemplar_id),)) if exemplar_id is not None else ("", ())
        rows = self._read(f"SELECT * FROM results {where} ORDER BY id DESC", args)
        files: dict[int, dict] = {}
        for r in self._read("SELECT result_id, name, file_hash FROM result_files ORDER BY name"):
            files.setdefault(r["result_id"], {})[r["name"]] = r["file_hash"]
        return [self._result(row, files.get(row["id"], {})) for row in rows]

    def result_file(self, result_id: int, name: str) -> bytes:
        """One output file of a result by its name (``texture.png``, ...).

        Parameters
        ----------
        result_id : int
        name : str

        Returns
        -------
        bytes

        Raises
        ------
        NotFoundError
            No such result, or no such file in it.
        """
        digest = self.result(result_id).files.get(name)
        if digest is None:
            raise NotFoundError(f"result {result_id} has no file {name!r}")
        return self.store.get(digest)

    def remove_result(self, result_id: int) -> None:
        """Remove a result (and the files nothing else uses).

        Parameters
        ----------
        result_id : int

        Raises
        ------
        NotFoundError
            No such result.
        """
        self.result(result_id)
        with self._transaction() as conn:
            conn.execute("DELETE FROM results WHERE id = ?", (int(result_id),))
            self._sweep(conn)

    @property
    def jobs(self) -> JobTable:
        """The web app's job queue kept in this library (:class:`~barkgen.library.jobs.JobTable`)."""
        return JobTable(self._transaction, self._read)

    # -- housekeeping ---------------------------------------------------------------------
    def _sweep(self, conn) -> int:
        """Remove stored files no row refers to; returns how many. Runs under the caller's
        write lock, and every writer stores its files under that lock too, so a file stored
        for a row being inserted is never taken."""
        used = {r[0] for r in conn.execute(_FILES_IN_USE)}
        return self.store.remove_unused(used)
