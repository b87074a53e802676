"""Files written as one step: every file in full to a temporary beside its target, renamed
into place only when all are on disk, so a failure or an interrupt (or a full disk) leaves the
old files and no half-written one; and the only temporaries barkgen ever removes are its own,
named :data:`TEMPORARY_NAME`, whose writer is gone."""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path


def current_umask() -> int:
    """The process's umask (the mode a new file gets is ``0o666 & ~umask``)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file renamed into place.

    Parameters
    ----------
    path : str or PathLike
        The file; its folder is made if missing.
    data : bytes
        The content.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    return write_files_atomic(path.parent, {path.name: data})[0]


#: the name of every temporary barkgen writes: ``.barkgen.PID.RANDOM.tmp`` (short whatever the
#: target's name, so a target of the longest name the file system allows still has one), and
#: the only names :func:`remove_stale_temporaries` ever removes
TEMPORARY_NAME = re.compile(r"^\.barkgen\.(\d+)\.[A-Za-z0-9_]+\.tmp$")


def process_alive(pid: int) -> bool:
    """Whether process ``pid`` runs (another user's counts as running)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # someone else's process: alive
        return True
    return True


def remove_stale_temporaries(folder: str | os.PathLike) -> int:
    """Remove the temporaries of :func:`write_files_atomic` that a killed writer left in
    ``folder``: only files named as barkgen names its own (:data:`TEMPORARY_NAME`) whose
    process is gone. A running writer's are kept, and so is every other file, whatever it is
    called (a user's ``.thesis.32000.bak.tmp`` or ``.backup.tmp`` is not barkgen's to remove).
    Returns how many were removed."""
    removed = 0
    try:
        candidates = [p for p in Path(folder).iterdir() if TEMPORARY_NAME.match(p.name)]
    except OSError:
        return 0
    for path in candidates:
        match = TEMPORARY_NAME.match(path.name)
        assert match is not None  # the candidates are the names it matches
        try:
            if path.is_file() and not path.is_symlink() and not process_alive(int(match.group(1))):
                path.unlink()
                removed += 1
        except OSError:
            continue
    return removed


def write_files_atomic(folder: str | os.PathLike, files: dict[str, bytes]) -> list[Path]:
    """Write several files into ``folder`` as one step.

    Every file is first written in full to a temporary file beside its target, and only when all
    are on disk are they renamed into place, so a failure or an interrupt while writing leaves
    the old set of files untouched (and no temporary file).

    Parameters
    ----------
    folder : str or PathLike
        The folder (made if missing).
    files : dict of str to bytes
        File name -> content.

    Returns
    -------
    list of Path
        The files written, in the order given.
    """
    staged: list[tuple[str, Path]] = []
    try:
        stage_files(folder, files, staged)
        commit_staged(staged)
    except BaseException:
        discard_staged(staged)
        raise
    return [target for tmp, target in staged if tmp]


def stage_files(folder: str | os.PathLike, files: dict[str, bytes], staged: list[tuple[str, Path]]) -> None:
    """Write each of ``files`` in full to a temporary beside its target in ``folder`` (made if
    missing), appending ``(temporary, target)`` to ``staged`` as it goes, so that a failure
    part-way leaves the caller every temporary to discard (:func:`discard_staged`); nothing is
    renamed into place (:func:`commit_staged`). Several folders staged first and committed
    after are written as one step (a full disk on the last file leaves none of them, nor a
    folder made for them: ``staged`` lists those too, as ``("", folder)``)."""
    folder = Path(folder)
    missing = [f for f in (folder, *folder.parents) if not f.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    staged.extend(("", f) for f in reversed(missing))  # made here: removed again on a failure
    remove_stale_temporaries(folder)
    for name, data in files.items():
        try:
            fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".barkgen.{os.getpid()}.", suffix=".tmp")
            staged.append((tmp, folder / name))
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
            os.chmod(tmp, 0o666 & ~current_umask())
        except OSError as exc:  # name the file the user asked for, not our temporary
            raise OSError(exc.errno, exc.strerror, str(folder / name)) from None


def commit_staged(staged: list[tuple[str, Path]]) -> None:
    """Rename every staged temporary (:func:`stage_files`) onto its target."""
    for tmp, target in staged:
        if tmp:
            os.replace(tmp, target)


def discard_staged(staged: list[tuple[str, Path]]) -> None:
    """Remove the staged temporaries not yet renamed into place."""
    for tmp, _ in staged:
        try:
            if tmp:
                os.unlink(tmp)
        except OSError:
            pass
    for tmp, folder in reversed(staged):  # the folders staging made, innermost first, if empty
        if not tmp:
            try:
                os.rmdir(folder)
            except OSError:
                pass
