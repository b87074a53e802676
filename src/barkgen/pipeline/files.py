"""The files of one :func:`barkgen.pipeline.generate` run, encoded (``barkgen generate``,
``barkgen batch`` and the web app write the very same bytes)."""

from __future__ import annotations

import json

import numpy as np

from barkgen._version import __version__
from barkgen.errors import InvalidInputError
from barkgen.io.images import encode_png
from barkgen.io.material import encode_material
from barkgen.io.references import encode_reference
from barkgen.pipeline.core import preview_sheet

#: the files every run writes (their stems are not free for --extra or the material name)
GENERATE_FILES = ("texture", "labels_in", "labels_out", "reference", "preview", "report")


def encode_generate(photo: np.ndarray, result, source: str, *, name: str = "bark",
                    bits: int | None = None) -> dict[str, bytes]:
    """Every file of a :class:`~barkgen.pipeline.GenerateResult`, encoded.

    ``texture.png``, ``labels_in.png``, ``labels_out.png``, ``reference.png``, ``preview.png``,
    one ``NAME.png`` per extra map, the material set as ``name``
    (:func:`~barkgen.io.encode_material`) when there is one, and ``report.json`` (version, the
    ``source`` photo, the run's report and the list of files): the bytes ``barkgen generate``,
    ``barkgen batch`` and the web app write.

    Parameters
    ----------
    photo : ndarray
        The photo of the run.
    result : GenerateResult
        What :func:`~barkgen.pipeline.generate` made of it.
    source : str
        The photo's name or path, as recorded in ``report.json``.
    name : str, default "bark"
        The material set's ``NAME``.
    bits : {8, 16}, optional
        Bit depth of ``texture.png`` (default: the photo's).

    Returns
    -------
    dict of str to bytes
        File name -> content; write it with :func:`barkgen.io.write_folder_atomic`.

    Raises
    ------
    InvalidInputError
        A material name whose files clash with the run's own.
    """
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
