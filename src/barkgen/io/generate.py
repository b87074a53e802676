"""The files of one :func:`barkgen.pipeline.generate` run, encoded (``barkgen generate`` and
``barkgen batch`` write the very same bytes)."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.io.images import _umask, encode_png
from barkgen.io.references import encode_reference

#: the files every run writes (their stems are not free for --extra or the material name)
GENERATE_FILES = ("texture", "labels_in", "labels_out", "reference", "preview", "report")


def encode_generate(photo: np.ndarray, result, source: str, *, name: str = "bark",
                    bits: int | None = None) -> dict[str, bytes]:
    """Every file of a :class:`~barkgen.pipeline.GenerateResult`: ``texture.png`` (``bits``:
    8, 16 or the photo's depth), ``labels_in.png``, ``labels_out.png``, ``reference.png``,
    ``preview.png``, one ``NAME.png`` per extra map, the material set as ``name``
    (:func:`~barkgen.io.encode_material`) when there is one, and ``report.json`` (version, the
    ``source`` photo, the run's report and the list of files)."""
    from barkgen._version import __version__
    from barkgen.io.material import encode_material
    from barkgen.pipeline import preview_sheet

    report = {"barkgen": __version__, "photo": source, **result.report}
    files = {"texture.png": encode_png(result.texture, bits=bits),
             "labels_in.png": encode_png(result.labels_in),
             "labels_out.png": encode_png(result.labels_out),
             "reference.png": encode_reference(result.references, photo.shape[:2]),
             "preview.png": encode_png(preview_sheet(photo, result))}
    files.update({f"{extra}.png": encode_png(arr) for extra, arr in result.extras.items()})
    if result.material is not None:
        material_files = encode_material(result.material, name, seed=result.report["seed"],
                                         source_photo=source)
        clash = sorted(set(material_files) & (set(files) | {"report.json"}))
        if clash:
            raise InvalidInputError(f"--name {name!r} makes {clash[0]}, which is taken; pick another")
        files.update(material_files)
    report["files"] = sorted(files) + ["report.json"]
    files["report.json"] = (json.dumps(report, indent=2) + "\n").encode()
    return files


#: prefixes of the staging folders of :func:`write_folder_atomic` (stale ones may be removed)
STAGING_PREFIXES = (".staging-", ".replaced-")


def write_folder_atomic(folder: str | os.PathLike, files: dict[str, bytes]) -> Path:
    """Make ``folder`` hold exactly ``files``, as one step: they are written in full into a
    staging folder beside it, which is then renamed to ``folder`` (an older ``folder`` is
    moved aside first and removed after). An interrupt or a killed process leaves either the
    old folder or the new one, never a mix or a half-written file; what it may leave is a
    staging folder (``.staging-*`` / ``.replaced-*`` beside ``folder``), which
    :func:`remove_staging` clears."""
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
    """Remove the staging folders that interrupted :func:`write_folder_atomic` calls left in
    ``parent``; returns how many. Call it only when no write into ``parent`` is running."""
    parent = Path(parent)
    removed = 0
    if parent.is_dir():
        for path in parent.iterdir():
            if path.is_dir() and path.name.startswith(STAGING_PREFIXES):
                shutil.rmtree(path, ignore_errors=True)
                removed += 1
    return removed
