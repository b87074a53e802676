"""The web app's job queue, kept in the library's ``jobs`` table (:mod:`.schema`) so that queued
and running jobs outlive a server restart. The web app (:mod:`barkgen.web.jobs`) owns the jobs;
this table only keeps their records."""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Callable, Iterable, Mapping
from contextlib import AbstractContextManager

#: the ``jobs`` table's columns, in order
JOB_COLUMNS = (
    "id",
    "number",
    "kind",
    "exemplar_id",
    "params",
    "state",
    "spec",
    "parent_id",
    "labels_key",
    "result_id",
    "error",
    "created",
    "started",
    "finished",
)
#: the columns kept as JSON values
JOB_JSON = ("params", "spec", "labels_key")


class JobTable:
    """The kept web jobs of a library, through its ``transaction`` (a write under its lock and
    read-only rules) and ``read`` (a query's rows)."""

    def __init__(
        self,
        transaction: Callable[[], AbstractContextManager[sqlite3.Connection]],
        read: Callable[[str], list[sqlite3.Row]],
    ) -> None:
        self._transaction = transaction
        self._read = read

    def save(self, record: Mapping) -> None:
        """Keep (or update) one web job: a mapping of the ``jobs`` columns; ``params``, ``spec``
        and ``labels_key`` are JSON values."""
        values = [json.dumps(record.get(c)) if c in JOB_JSON else record.get(c) for c in JOB_COLUMNS]
        with self._transaction() as conn:
            conn.execute(
                f"INSERT OR REPLACE INTO jobs ({', '.join(JOB_COLUMNS)}) VALUES ({', '.join('?' * len(JOB_COLUMNS))})",
                values,
            )

    def saved(self) -> list[dict]:
        """Every kept web job, in submission order (:meth:`save`'s mappings)."""
        rows = self._read("SELECT * FROM jobs ORDER BY number")
        return [{c: json.loads(row[c]) if c in JOB_JSON else row[c] for c in JOB_COLUMNS} for row in rows]

    def forget(self, job_ids: Iterable[str]) -> None:
        """Drop web jobs from the kept queue (old finished ones)."""
        with self._transaction() as conn:
            conn.executemany("DELETE FROM jobs WHERE id = ?", [(str(i),) for i in job_ids])
