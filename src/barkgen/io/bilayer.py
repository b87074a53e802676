"""Bi-layer model files: a ``.npz`` of arrays plus a JSON header with a format name and a
version, written atomically and checked on reading."""

from __future__ import annotations

import dataclasses
import io
import json
import os
import zipfile
from pathlib import Path

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.io.staging import write_bytes_atomic

FORMAT = "barkgen-bilayer"
VERSION = 1
_ARRAYS = ("exemplar", "structure", "masks", "labels", "spectra", "bases", "means", "sigmas", "quantiles")


def encode_bilayer_model(model) -> bytes:
    """The bytes of a bi-layer model file: a compressed ``.npz``.

    A JSON header (format name, version, barkgen version, the analysis options) and the model's
    arrays (exemplar, structure, masks, labels and the noise statistics); no pickles.

    Parameters
    ----------
    model : BilayerModel
        The model (:func:`barkgen.bilayer.analyze`).

    Returns
    -------
    bytes
    """
    from barkgen._version import __version__

    header = {
        "format": FORMAT,
        "version": VERSION,
        "barkgen": __version__,
        "options": dataclasses.asdict(model.options),
    }
    stats = model.noise
    arrays = {
        "exemplar": model.exemplar.astype(np.float32),
        "structure": model.structure.astype(np.float32),
        "masks": model.masks.astype(np.float32),
        "labels": model.labels.astype(np.uint8),
        "spectra": stats.spectra,
        "bases": stats.bases,
        "means": stats.means,
        "sigmas": stats.sigmas,
        "quantiles": stats.quantiles,
    }
    buffer = io.BytesIO()
    np.savez_compressed(buffer, header=np.array(json.dumps(header)), **arrays)
    return buffer.getvalue()


def write_bilayer_model(path: str | os.PathLike, model) -> Path:
    """Write ``model`` (:class:`~barkgen.bilayer.BilayerModel`) to ``path``, atomically.

    Parameters
    ----------
    path : str or PathLike
        The file (``.npz``).
    model : BilayerModel
        The model.

    Returns
    -------
    Path
        ``path``.
    """
    return write_bytes_atomic(path, encode_bilayer_model(model))


def _bad(path, why: str) -> InvalidInputError:
    return InvalidInputError(f"{path}: not a barkgen bi-layer model ({why})")


def read_bilayer_model(path: str | os.PathLike):
    """Read and validate a bi-layer model file.

    Parameters
    ----------
    path : str or PathLike
        A file written by :func:`write_bilayer_model`.

    Returns
    -------
    BilayerModel

    Raises
    ------
    InvalidInputError
        A missing file, a file that is not a model, of another version, or with missing or
        inconsistent arrays (one clear line).

    References
    ----------
    .. [1] guingo2017 (the model's layers and statistics).
    """
    from barkgen.bilayer.model import BilayerModel, NoiseStatistics
    from barkgen.bilayer.options import AnalysisOptions

    path = Path(path)
    if not path.is_file():
        raise InvalidInputError(f"{path}: no such model file")
    if not zipfile.is_zipfile(path):
        raise _bad(path, "not an .npz archive")
    try:
        with np.load(path, allow_pickle=False) as data:
            header = json.loads(str(data["header"]))
            arrays = {name: np.array(data[name]) for name in _ARRAYS}
    except (zipfile.BadZipFile, ValueError, KeyError, EOFError, OSError) as exc:
        raise _bad(path, f"unreadable: {exc}") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise _bad(path, "wrong format name")
    if header.get("version") != VERSION:
        raise InvalidInputError(
            f"{path}: bi-layer model version {header.get('version')!r} is not "
            f"supported (this barkgen reads version {VERSION}); re-run the analysis"
        )
    try:
        options = AnalysisOptions(**header["options"])
    except (TypeError, KeyError) as exc:
        raise _bad(path, f"bad options: {exc}") from None
    ex, st, masks = arrays["exemplar"], arrays["structure"], arrays["masks"]
    spectra = arrays["spectra"]
    k = masks.shape[2] if masks.ndim == 3 else -1
    ok = (
        ex.ndim == 3
        and ex.shape[2] == 3
        and st.shape == ex.shape
        and masks.ndim == 3
        and masks.shape[:2] == ex.shape[:2]
        and arrays["labels"].shape == ex.shape[:2]
        and spectra.ndim == 4
        and spectra.shape[:2] == (k, 3)
        and spectra.shape[2] == spectra.shape[3]
        and arrays["bases"].shape == (k, 3, 3)
        and arrays["means"].shape == (k, 3)
        and arrays["sigmas"].shape == (k, 3)
        and arrays["quantiles"].ndim == 3
        and arrays["quantiles"].shape[:2] == (k, 3)
    )
    if not ok:
        raise _bad(path, "inconsistent array shapes")
    finite = all(np.isfinite(arrays[n]).all() for n in _ARRAYS if arrays[n].dtype.kind == "f")
    if not finite:
        raise _bad(path, "non-finite values")
    stats = NoiseStatistics(
        spectra=spectra.astype(np.float32),
        bases=arrays["bases"].astype(np.float32),
        means=arrays["means"].astype(np.float32),
        sigmas=arrays["sigmas"].astype(np.float32),
        quantiles=arrays["quantiles"].astype(np.float32),
    )
    return BilayerModel(
        exemplar=ex.astype(np.float32),
        structure=st.astype(np.float32),
        masks=masks.astype(np.float32),
        labels=arrays["labels"].astype(np.uint8),
        noise=stats,
        options=options,
    )
