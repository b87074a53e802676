"""The library's SQLite database as its :class:`~barkgen.library.Library` uses it: connections
(read-only ones for a library that cannot be written), write transactions, reads, the schema's
migrations (:mod:`.schema`) and damage told in one line."""

from __future__ import annotations

import os
import sqlite3
from contextlib import closing, contextmanager
from pathlib import Path

from barkgen.library.errors import LibraryError, _ReadOnly
from barkgen.library.schema import MIGRATIONS, SCHEMA_VERSION


class Database:
    """The database of a library folder: ``path`` (the folder), ``db_path`` (its
    ``library.sqlite``) and ``read_only`` (why it cannot be written, else None) are set by the
    subclass before any query."""

    path: Path
    db_path: Path
    read_only: str | None

    def _read_only_reason(self) -> str | None:
        if not os.access(self.path, os.W_OK):
            return "its folder is read-only"
        if self.db_path.exists() and not os.access(self.db_path, os.W_OK):
            return "library.sqlite is read-only"
        return None

    def _check_readable(self) -> None:
        """A read-only library is listed as it is: no migration, no sample added."""
        if not self.db_path.exists():
            raise LibraryError(f"{self.path}: no library here, and {self.read_only}")
        try:
            with closing(self._connect()) as conn:
                version = conn.execute("PRAGMA user_version").fetchone()[0]
        except sqlite3.DatabaseError as exc:
            raise LibraryError(f"{self.db_path}: not a barkgen library database ({exc})") from None
        if not 1 <= version <= SCHEMA_VERSION:
            raise LibraryError(
                f"{self.db_path}: not a barkgen library this barkgen can read "
                f"(schema {version}; it is read-only, so it cannot be upgraded)"
            )

    def _connect(self) -> sqlite3.Connection:
        if self.read_only is not None:
            # a WAL database in a folder that cannot be written: read it as it stands
            mode = "immutable=1" if not os.access(self.path, os.W_OK) else "mode=ro"
            uri = f"{self.db_path.resolve().as_uri()}?{mode}"
            try:
                conn = sqlite3.connect(uri, uri=True, timeout=30.0, isolation_level=None)
            except sqlite3.Error as exc:
                raise LibraryError(f"{self.db_path}: cannot open the library database ({exc})") from None
            conn.row_factory = sqlite3.Row
            return conn
        try:
            conn = sqlite3.connect(self.db_path, timeout=30.0, isolation_level=None)
        except sqlite3.Error as exc:
            raise LibraryError(f"{self.db_path}: cannot open the library database ({exc})") from None
        conn.row_factory = sqlite3.Row
        conn.execute("PRAGMA foreign_keys = ON")
        return conn

    @contextmanager
    def _transaction(self):
        if self.read_only is not None:
            raise LibraryError(
                f"{self.path}: the library is read-only ({self.read_only}); copy it somewhere writable to change it"
            )
        with closing(self._connect()) as conn, self._damage_said():
            conn.execute("BEGIN IMMEDIATE")
            try:
                yield conn
            except BaseException:
                conn.execute("ROLLBACK")
                raise
            conn.execute("COMMIT")

    @contextmanager
    def _damage_said(self):
        """A damaged database file (a torn page, another program's writes) as one line, not
        an internal error."""
        try:
            yield
        except sqlite3.DatabaseError as exc:
            if not any(word in str(exc) for word in ("malformed", "not a database", "corrupt")):
                raise  # (a busy database, a constraint: not damage)
            raise LibraryError(
                f"{self.db_path}: the library database is damaged ({exc}); restore "
                "it from a backup, or move the library folder away to start a new "
                "one"
            ) from None

    def _read(self, sql: str, args: tuple = ()) -> list[sqlite3.Row]:
        if any(isinstance(a, int) and not -(2**63) <= a < 2**63 for a in args):
            return []  # an id beyond SQLite's 64-bit integers is in no row (not an error)
        with closing(self._connect()) as conn, self._damage_said():
            return conn.execute(sql, args).fetchall()

    def _migrate(self) -> None:
        try:
            with closing(self._connect()) as conn:
                conn.execute("PRAGMA journal_mode = WAL")
                # read under the write lock: two processes opening a new library migrate once
                conn.execute("BEGIN IMMEDIATE")
                try:
                    version = conn.execute("PRAGMA user_version").fetchone()[0]
                    if version > SCHEMA_VERSION:
                        raise LibraryError(
                            f"{self.db_path}: made by a newer barkgen (schema {version}, "
                            f"this one knows {SCHEMA_VERSION}); upgrade barkgen"
                        )
                    for target in range(version + 1, SCHEMA_VERSION + 1):
                        for statement in MIGRATIONS[target].split(";"):
                            if statement.strip():
                                conn.execute(statement)
                        conn.execute(f"PRAGMA user_version = {target}")
                except BaseException:
                    conn.execute("ROLLBACK")
                    raise
                conn.execute("COMMIT")
        except sqlite3.OperationalError as exc:
            if "readonly" in str(exc) or "read-only" in str(exc):
                raise _ReadOnly(f"the disk is read-only ({exc})") from None
            raise LibraryError(f"{self.db_path}: not a barkgen library database ({exc})") from None
        except sqlite3.DatabaseError as exc:
            raise LibraryError(f"{self.db_path}: not a barkgen library database ({exc})") from None
