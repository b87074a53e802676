"""Folders written as one step: a run's files appear together or not at all; and what barkgen
may replace or remove of a folder it wrote before: only what it can prove it wrote.

A run's record (generate's ``report.json``) lists its files with the SHA-256 of each
(:func:`file_record`). A file is barkgen's to remove or replace only while its content still
has the recorded hash (:func:`owned_files`): another program's ``report.json`` listing a user's
``holiday.jpg`` proves nothing, and a file the user has since edited is the user's.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
from pathlib import Path

from barkgen.errors import InvalidInputError
from barkgen.io.staging import current_umask, process_alive

#: prefixes of the staging folders of :func:`write_folder_atomic`, followed by the writer's
#: process id (stale ones, whose writer is gone, may be removed: :func:`remove_staging`)
STAGING_PREFIXES = (".barkgen-staging.", ".barkgen-replaced.")
_STAGING_NAME = re.compile(r"^\.barkgen-(?:staging|replaced)\.(\d+)\.[A-Za-z0-9_]+$")
#: the record of a run: the key under which it lists its files' hashes
RECORD_HASHES = "file_sha256"


def file_record(files: dict[str, bytes]) -> dict[str, str]:
    """The SHA-256 (hex) of each file a run writes, for its record (:data:`RECORD_HASHES`)."""
    return {name: hashlib.sha256(data).hexdigest() for name, data in sorted(files.items())}


def _sha256(path: Path) -> str | None:
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return None
    return digest.hexdigest()


def owned_files(folder: str | os.PathLike, record: str = "report.json") -> list[str] | None:
    """The files of ``folder`` that barkgen provably wrote: those its ``record`` lists whose
    content still has the recorded SHA-256. None when ``record`` is not a barkgen record (no
    such file, not JSON, no hashes: another program's, or an older barkgen's)."""
    folder = Path(folder)
    try:
        meta = json.loads((folder / record).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    hashes = meta.get(RECORD_HASHES) if isinstance(meta, dict) and "barkgen" in meta else None
    if not isinstance(hashes, dict):
        return None
    owned = []
    for name, digest in sorted(hashes.items()):
        if (
            isinstance(name, str)
            and name
            and Path(name).name == name
            and name not in (".", "..")
            and (folder / name).is_file()
            and not (folder / name).is_symlink()
            and _sha256(folder / name) == digest
        ):
            owned.append(name)
    return owned


def check_replaceable(folder: str | os.PathLike, record: str = "report.json") -> None:
    """Refuse (:class:`~barkgen.errors.InvalidInputError`, one line) to replace ``folder`` as a
    whole unless it is missing, empty, or holds nothing but a run barkgen wrote (its
    ``record`` and the files it proves, :func:`owned_files`)."""
    folder = Path(folder)
    if not folder.exists():
        return
    if not folder.is_dir() or folder.is_symlink():
        raise InvalidInputError(f"{str(folder)!r} exists and is not a folder barkgen wrote; give another output")
    entries = sorted(p.name for p in folder.iterdir())
    if not entries:
        return
    owned = owned_files(folder, record)
    foreign = [n for n in entries if owned is None or (n not in owned and n != record)]
    if foreign:
        raise InvalidInputError(
            f"{str(folder)!r} holds {foreign[0]!r}, which barkgen did not "
            "write; it would be removed: give another output folder"
        )


def write_folder_atomic(folder: str | os.PathLike, files: dict[str, bytes]) -> Path:
    """Make ``folder`` hold exactly ``files``, as one step.

    The files are written in full into a staging folder beside it, which is then renamed to
    ``folder`` (an older ``folder`` is moved aside first and removed after). An interrupt or a
    killed process leaves either the old folder or the new one, never a mix or a half-written
    file; what it may leave is a staging folder (``.barkgen-staging.PID.*`` /
    ``.barkgen-replaced.PID.*`` beside ``folder``), which :func:`remove_staging` clears. An
    existing ``folder`` is replaced only if it holds nothing but a run barkgen wrote
    (:func:`check_replaceable`; :class:`~barkgen.errors.InvalidInputError` otherwise).

    Parameters
    ----------
    folder : str or PathLike
        The folder to make (its parent is made if missing).
    files : dict of str to bytes
        File name -> content.

    Returns
    -------
    Path
        ``folder``.
    """
    folder = Path(folder)
    check_replaceable(folder)
    folder.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f"{STAGING_PREFIXES[0]}{os.getpid()}."))
    try:
        for name, data in files.items():
            path = staging / name
            with open(path, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
            os.chmod(path, 0o666 & ~current_umask())
        os.chmod(staging, 0o777 & ~current_umask())
        old = None
        if folder.exists():
            old = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f"{STAGING_PREFIXES[1]}{os.getpid()}."))
            os.replace(folder, old / folder.name)
        os.replace(staging, folder)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return folder


def remove_staging(parent: str | os.PathLike) -> int:
    """Remove the staging folders that interrupted :func:`write_folder_atomic` calls left:
    only folders named as barkgen names its own whose writing process is gone (a running
    writer's are kept, and so is every other folder).

    Parameters
    ----------
    parent : str or PathLike
        The folder holding the targets.

    Returns
    -------
    int
        How many staging folders were removed.
    """
    parent = Path(parent)
    removed = 0
    if parent.is_dir():
        for path in parent.iterdir():
            match = _STAGING_NAME.match(path.name)
            if match and path.is_dir() and not path.is_symlink() and not process_alive(int(match.group(1))):
                shutil.rmtree(path, ignore_errors=True)
                removed += 1
    return removed
