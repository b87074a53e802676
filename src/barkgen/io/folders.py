"""Folders written as one step: a run's files appear together or not at all."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from barkgen.io.images import _umask

#: prefixes of the staging folders of :func:`write_folder_atomic` (stale ones may be removed)
STAGING_PREFIXES = (".staging-", ".replaced-")


def write_folder_atomic(folder: str | os.PathLike, files: dict[str, bytes]) -> Path:
    """Make ``folder`` hold exactly ``files``, as one step.

    The files are written in full into a staging folder beside it, which is then renamed to
    ``folder`` (an older ``folder`` is moved aside first and removed after). An interrupt or a
    killed process leaves either the old folder or the new one, never a mix or a half-written
    file; what it may leave is a staging folder (``.staging-*`` / ``.replaced-*`` beside
    ``folder``), which :func:`remove_staging` clears.

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
    folder.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f"{STAGING_PREFIXES[0]}{folder.name}-"))
    try:
        for name, data in files.items():
            path = staging / name
            with open(path, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
            os.chmod(path, 0o666 & ~_umask())
        os.chmod(staging, 0o777 & ~_umask())
        old = None
        if folder.exists():
            old = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f"{STAGING_PREFIXES[1]}{folder.name}-"))
            os.replace(folder, old / folder.name)
        os.replace(staging, folder)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return folder


def remove_staging(parent: str | os.PathLike) -> int:
    """Remove the staging folders that interrupted :func:`write_folder_atomic` calls left.

    Call it only when no write into ``parent`` is running.

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
            if path.is_dir() and path.name.startswith(STAGING_PREFIXES):
                shutil.rmtree(path, ignore_errors=True)
                removed += 1
    return removed
