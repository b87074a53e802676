"""The exemplar library (laitoch2018 §1: bark photos and their label maps, by species; the
designer picks one or adds their own): an SQLite database plus content-addressed files in one
folder.

``LIBRARY/library.sqlite`` holds these tables, migrated by schema version (``PRAGMA
user_version``, :mod:`.schema`): ``exemplars`` (name, species, bark type, licence, source, image
hash, size), ``analyses`` (label maps, thumbnails and other cached analysis of an exemplar, keyed
by kind and parameters), ``results`` (exemplar, parameters, seed, timings, created, and the
output files in ``result_files``) and ``jobs`` (the web app's queue, kept across restarts).
The bytes live once each in ``LIBRARY/objects`` (:mod:`.store`). The bundled sample photo is
added on first use. The folder is ``--library PATH``,
``$BARKGEN_LIBRARY`` or, by default, ``barkgen/library`` under the user's data directory.

Every method opens its own connection, so one :class:`Library` serves any number of threads;
processes share a library through SQLite's locking (WAL journal). A library that cannot be
written (read-only folder, file or disk) is opened as it stands: it lists and shows, and every
change raises :class:`LibraryError` saying it is read-only."""

from barkgen.library.library import (
    SCHEMA_VERSION,
    Exemplar,
    Library,
    LibraryError,
    NotFoundError,
    Result,
    default_library_path,
)

__all__ = ["Exemplar", "Library", "LibraryError", "NotFoundError", "Result", "default_library_path", "SCHEMA_VERSION"]
