"""The batch manifest: one SQLite row per variant with its state, so that a re-run skips what
is done and retries what failed or never finished. Only the client process writes it."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

#: file name of the manifest inside the output folder
MANIFEST_NAME = "manifest.sqlite"
SCHEMA_VERSION = 1
STATES = ("pending", "running", "done", "failed")

#: the columns of barkgen's manifest (a database without them is another program's)
_COLUMNS = {"exemplar", "seed", "fingerprint", "state", "attempts", "error", "seconds", "worker", "updated"}
_SCHEMA = """
CREATE TABLE IF NOT EXISTS variants (
    exemplar    TEXT    NOT NULL,
    seed        INTEGER NOT NULL,
    fingerprint TEXT    NOT NULL,
    state       TEXT    NOT NULL CHECK (state IN ('pending', 'running', 'done', 'failed')),
    attempts    INTEGER NOT NULL DEFAULT 0,
    error       TEXT,
    seconds     REAL,
    worker      TEXT,
    updated     REAL    NOT NULL,
    PRIMARY KEY (exemplar, seed)
)
"""


class Manifest:
    """``OUTDIR/manifest.sqlite``: the state of every variant of the batches run into OUTDIR.

    A variant counts as done when its row says ``done`` with the same option fingerprint and
    its folder holds ``report.json`` (written last, in the same atomic step as the rest);
    anything else is made (again)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        from barkgen.errors import InvalidInputError

        try:
            self._db = sqlite3.connect(self.path, timeout=30, isolation_level=None)
            version = self._db.execute("PRAGMA user_version").fetchone()[0]
            if version > SCHEMA_VERSION:
                raise InvalidInputError(f"{self.path} was written by a newer barkgen (schema {version})")
            self._check_own()  # before anything is written into it
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute(_SCHEMA)
            self._db.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
        except sqlite3.DatabaseError as exc:  # a damaged file, or another program's
            raise InvalidInputError(
                f"{self.path}: not a readable batch manifest ({exc}); move it away to start the "
                "batch afresh (the variants already in the folder are made again)"
            ) from None

    def _check_own(self) -> None:
        """Refuse a database that holds anything but barkgen's manifest (another program's
        ``manifest.sqlite``): it is neither changed nor trusted."""
        from barkgen.errors import InvalidInputError

        tables = {r[0] for r in self._db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if not tables:
            return
        columns = {r[1] for r in self._db.execute("PRAGMA table_info(variants)")}
        if tables != {"variants"} or not _COLUMNS <= columns:
            self._db.close()
            raise InvalidInputError(
                f"{self.path} is not a barkgen batch manifest (it holds "
                f"{', '.join(sorted(tables))[:80]}); give another output folder"
            )

    def close(self) -> None:
        self._db.close()

    def __enter__(self) -> Manifest:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def is_done(self, exemplar: str, seed: int, fingerprint: str, folder: Path) -> bool:
        row = self._db.execute(
            "SELECT state, fingerprint FROM variants WHERE exemplar = ? AND seed = ?", (exemplar, seed)
        ).fetchone()
        return row is not None and row[0] == "done" and row[1] == fingerprint and (folder / "report.json").is_file()

    def mark(
        self,
        exemplar: str,
        seed: int,
        fingerprint: str,
        state: str,
        *,
        error: str | None = None,
        seconds: float | None = None,
        worker: str | None = None,
    ) -> None:
        """Record a variant's new state (``running`` counts an attempt)."""
        if state not in STATES:
            raise ValueError(f"unknown state {state!r}")
        self._db.execute(
            """INSERT INTO variants (exemplar, seed, fingerprint, state, attempts, error, seconds, worker, updated)
               VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)
               ON CONFLICT (exemplar, seed) DO UPDATE SET
                   fingerprint = excluded.fingerprint, state = excluded.state,
                   attempts = variants.attempts + excluded.attempts, error = excluded.error,
                   seconds = excluded.seconds, worker = excluded.worker, updated = excluded.updated""",
            (exemplar, int(seed), fingerprint, state, int(state == "running"), error, seconds, worker, time.time()),
        )

    def rows(self) -> list[dict]:
        """Every variant's row, by exemplar and seed."""
        cur = self._db.execute(
            "SELECT exemplar, seed, fingerprint, state, attempts, error, seconds, worker, "
            "updated FROM variants ORDER BY exemplar, seed"
        )
        names = [d[0] for d in cur.description]
        return [dict(zip(names, row)) for row in cur.fetchall()]

    def counts(self) -> dict[str, int]:
        return {state: n for state, n in self._db.execute("SELECT state, COUNT(*) FROM variants GROUP BY state")}
