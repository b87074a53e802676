"""The files of one :func:`barkgen.pipeline.generate` run, encoded (``barkgen generate``,
``barkgen batch`` and the web app write the very same bytes)."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from functools import partial

import numpy as np

from barkgen._version import __version__
from barkgen.errors import InvalidInputError
from barkgen.io.asset_names import base_name, library_file_name, material_set_name, sized_shapes
from barkgen.io.folders import RECORD_HASHES, file_record
from barkgen.io.images import encode_concurrently, encode_png
from barkgen.io.material import check_material_name, encode_material, utf8_text
from barkgen.io.references import encode_reference
from barkgen.io.udim import udim_grid
from barkgen.material.illumination import encode_illumination
from barkgen.material.materialset import MaterialSet
from barkgen.pipeline.materials import WindowedMaterial
from barkgen.pipeline.report import preview_sheet

#: the files every run writes (their stems are not free for --extra or the material name)
GENERATE_FILES = ("texture", "labels_in", "labels_out", "reference", "preview", "report", "illumination")
#: how a run's own files are named (:func:`encode_generate`): ``run``, as they are
#: (``texture.png``, ``report.json``: a folder per run); ``library``, each carrying the set's
#: name (``oak_seed7_1K_texture.png``, ``oak_seed7_1K_report.json``: runs side by side in one
#: folder, as an artist's library keeps its sets)
LAYOUTS = ("run", "library")
#: the photo's broad light as carried to the output (:func:`barkgen.material.encode_illumination`):
#: what the web app's light slider puts back
ILLUMINATION_FILE = "illumination.png"


def check_generate_names(
    material_name: str | None = None,
    extras=(),
    *,
    words: tuple[str, str] = ("the material set's name", "the extra map name"),
) -> None:
    """Check, before any work, the names a run of :func:`~barkgen.pipeline.generate` will write
    beside its own files (:data:`GENERATE_FILES`): the material set's (a valid set name,
    :func:`barkgen.io.check_material_name`, that takes none of them) and each extra map's.
    ``words`` name the two in the errors as the front end calls them (e.g. ``--name``).
    Raises :class:`~barkgen.errors.InvalidInputError`; the CLI and batch call it."""
    if material_name is not None:
        check_material_name(material_name)
        if material_name in GENERATE_FILES:
            raise InvalidInputError(
                f"{words[0]} {material_name!r} would overwrite one of generate's own files; pick another"
            )
    clash = sorted(set(extras) & set(GENERATE_FILES))
    if clash:
        raise InvalidInputError(f"{words[1]} {clash[0]!r} is taken by one of generate's own files; pick another")


def encode_generate(
    photo: np.ndarray,
    result,
    source: str,
    *,
    name: str = "bark",
    variant: str | None = None,
    licence: str | None = None,
    bits: int | None = None,
    preset: str = "ambientcg",
    sizes: Sequence[int] = (),
    exr_height: bool = False,
    also: Mapping[str, bytes] | None = None,
    layout: str = "run",
    udim: tuple[int, int] | None = None,
    streamed: Mapping[str, str] | None = None,
) -> dict[str, bytes]:
    """Every file of a :class:`~barkgen.pipeline.GenerateResult`, encoded.

    ``texture.png``, ``labels_in.png``, ``labels_out.png``, ``reference.png``, ``preview.png``,
    one ``NAME.png`` per extra map, the material set when there is one, named as an artist's
    library expects (``ASSET_VARIANT_2K_Color.png``, :mod:`barkgen.io.asset_names`;
    :func:`~barkgen.io.encode_material`), and ``report.json`` (version, the
    ``source`` photo, the run's report, the list of files and each one's SHA-256, by which a
    later run proves which files of the folder are barkgen's, :func:`barkgen.io.owned_files`):
    the bytes ``barkgen generate``, ``barkgen batch`` and the web app write.

    Parameters
    ----------
    photo : ndarray
        The photo of the run.
    result : GenerateResult
        What :func:`~barkgen.pipeline.generate` made of it.
    source : str
        The photo's name or path, as recorded in ``report.json``.
    name : str, default "bark"
        The set's asset name (:func:`barkgen.io.photo_asset_name` of the photo, or the user's).
    variant : str, optional
        What tells this set apart from the photo's others (:func:`barkgen.io.variant_name`:
        ``seed7``, ``seed7-edit3f9a1c``); every file of the set is named
        ``ASSET_VARIANT_SIZE_*`` (``ASSET_SIZE_*`` without one).
    licence : str, optional
        The source photo's licence, recorded in the set's JSON (``source_licence``).
    bits : {8, 16}, optional
        Bit depth of ``texture.png`` (default: the photo's).
    preset : {"ambientcg", "blender", "unreal", "unity", "gltf"}, default "ambientcg"
        The material set's layout (:mod:`barkgen.material.presets`).
    sizes : sequence of int, optional
        Widths of the material set to write, each tagged with its size (``oak_seed7_2K_Color.png``,
        :func:`barkgen.io.size_tag`): the same bark resampled
        (:meth:`~barkgen.material.MaterialSet.resampled`), not re-synthesized. Default: one set,
        the output's size.
    exr_height : bool, default False
        Also each set's displacement as 32-bit float EXR (:func:`~barkgen.io.encode_material`).
    also : mapping of str to bytes, optional
        More files of the run (a tree's ``tree.glb``), recorded with generate's own.
    layout : {"run", "library"}, default "run"
        The run's own files as they are, or each named after the output's set (:data:`LAYOUTS`,
        :func:`run_file_names`).
    udim : (int, int), optional
        ``(columns, rows)``: the material set's maps written as that grid of UDIM tiles
        (``ASSET_VARIANT_4K_Color.1001.png`` ..., :mod:`barkgen.io.udim`), the set named after
        a tile's size; the run's own files stay whole. Not with ``sizes``.
    streamed : mapping of str to str, optional
        The files of the run's :class:`~barkgen.pipeline.WindowedMaterial` already written
        (:func:`write_windowed_material`, with the same naming keywords) -> their SHA-256:
        recorded in ``report.json``, not encoded again. Without it, such a set is made whole here
        (:meth:`~barkgen.pipeline.WindowedMaterial.whole`).

    Returns
    -------
    dict of str to bytes
        File name -> content; write it with :func:`barkgen.io.write_folder_atomic`.

    Raises
    ------
    InvalidInputError
        A material name whose files clash with the run's own; ``udim`` with ``sizes``, or a grid
        that does not cut the output into equal tiles.
    """
    if udim is not None and sizes:
        raise InvalidInputError("--udim writes the set at the output's size: leave out --sizes")
    material = result.material
    if streamed is not None and (not isinstance(material, WindowedMaterial) or sizes):
        raise InvalidInputError("streamed files are those of a windowed material set, at the output's size")
    if isinstance(material, WindowedMaterial) and streamed is None:
        material = material.whole()
    grid = None if udim is None else udim_grid(result.texture.shape[:2], udim)
    source = utf8_text(source)
    report = {"barkgen": __version__, "photo": source, **result.report}
    jobs: dict[str, Callable[[], bytes]] = {
        "texture.png": partial(encode_png, result.texture, bits=bits),
        "labels_in.png": partial(encode_png, result.labels_in),
        "labels_out.png": partial(encode_png, result.labels_out),
        "reference.png": partial(
            encode_reference,
            result.references,
            photo.shape[:2],
            orientation=None if result.orientation is None else result.orientation.to_dict(),
        ),
        "preview.png": lambda: encode_png(preview_sheet(photo, result)),
    }
    jobs.update({f"{extra}.png": partial(encode_png, arr) for extra, arr in result.extras.items()})
    if isinstance(material, MaterialSet) and material.illumination is not None:
        jobs[ILLUMINATION_FILE] = partial(encode_png, encode_illumination(material.illumination))
    files = encode_concurrently(jobs)
    material_files: dict[str, bytes] = {}
    if isinstance(material, MaterialSet):
        base = base_name(name, variant)
        sets = _sized_sets(material, base, sizes) if grid is None else [(material_set_name(base, grid.tile), material)]
        for set_name, one_set in sets:
            material_files.update(
                encode_material(
                    one_set,
                    set_name,
                    preset,
                    exr_height=exr_height,
                    udim=udim,
                    **_set_record(result, source, name, variant, licence),
                )
            )
    clash = sorted((set(material_files) | set(streamed or {})) & (set(files) | {"report.json"}))
    if clash:
        raise InvalidInputError(f"--name {name!r} makes {clash[0]}, which is taken; pick another")
    files.update(material_files)
    files.update(also or {})
    record = "report.json"
    if layout == "library":  # the run's own files named after the output's set (its maps are)
        prefix = _set_name(result.texture.shape[:2], name, variant, grid)
        files = {(n if n in material_files else library_file_name(prefix, n)): data for n, data in files.items()}
        record = library_file_name(prefix, record)
    report["files"] = sorted([*files, *(streamed or {})]) + [record]
    # what barkgen may later replace or remove of this folder: only these files, unchanged
    report[RECORD_HASHES] = dict(sorted({**file_record(files), **(streamed or {})}.items()))
    files[record] = (json.dumps(report, indent=2) + "\n").encode()
    return files


def write_windowed_material(
    result,
    folder,
    source: str,
    *,
    staged: list,
    name: str = "bark",
    variant: str | None = None,
    licence: str | None = None,
    preset: str = "ambientcg",
    exr_height: bool = False,
    layout: str = "run",
    udim: tuple[int, int] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, str]:
    """The files of a run's :class:`~barkgen.pipeline.WindowedMaterial`, written into
    ``folder`` as its windows are finished (:func:`~barkgen.pipeline.write_material_streamed`;
    issue 69): the set under the name :func:`encode_generate` gives it, and the run's
    ``illumination.png``. They are added to ``staged`` (:mod:`barkgen.io.staging`), for the
    caller to commit with the files :func:`encode_generate` makes with ``streamed=`` what this
    returns: every file -> its SHA-256. The keywords are :func:`encode_generate`'s
    (``progress(windows_done, windows)`` after each window)."""
    material = result.material
    if not isinstance(material, WindowedMaterial):
        raise InvalidInputError("the run's material set is not a windowed one (GenerateOptions.windowed)")
    grid = None if udim is None else udim_grid(material.shape, udim)
    set_name = _set_name(material.shape, name, variant, grid)
    illumination = ILLUMINATION_FILE if layout == "run" else library_file_name(set_name, ILLUMINATION_FILE)
    return material.write(
        folder,
        set_name,
        preset,
        exr_height=exr_height,
        udim=udim,
        illumination=illumination,
        staged=staged,
        progress=progress,
        **_set_record(result, utf8_text(source), name, variant, licence),
    )


def _set_name(shape: tuple[int, int], name: str, variant: str | None, grid) -> str:
    """The output's set name (``ASSET_VARIANT_4K``): a UDIM tile's size with a grid."""
    return material_set_name(base_name(name, variant), shape if grid is None else grid.tile)


def _set_record(result, source: str, name: str, variant: str | None, licence: str | None) -> dict:
    """What the set's ``NAME.json`` says of the run (:func:`barkgen.io.encode_material`'s metadata)."""
    return {
        "asset": name,
        "variant": variant,
        "seed": result.report["seed"],
        "source_photo": source,
        "source_licence": licence,
    }


def run_file_names(extras=(), prefix: str | None = None) -> list[str]:
    """The names of a run's own files (its set's aside), the record ``report.json`` last: as
    they are, or in the library layout (:data:`LAYOUTS`) each after ``prefix``, the output's
    set name (``oak_seed7_1K_texture.png``, ... ``oak_seed7_1K_report.json``)."""
    names = [f"{n}.png" for n in GENERATE_FILES] + [f"{n}.png" for n in extras] + ["report.json"]
    return names if prefix is None else [library_file_name(prefix, n) for n in names]


def parse_sizes(value, where: str = "sizes") -> list[int]:
    """Widths of a set of sizes, sorted: ``"1k,2k,4k"`` or ``"512,1024"`` (the CLI's
    ``--sizes``), or a list of such items (a batch spec's ``sizes``); ``None`` -> ``[]``."""
    if value is None:
        return []
    items = value.split(",") if isinstance(value, str) else value
    if not isinstance(items, (list, tuple)):
        raise InvalidInputError(f"{where}: {value!r} is no list of widths (e.g. 1k,2k,4k or 512,1024)")
    widths = set()
    for item in items:
        word = str(item).strip().lower()
        number = word[:-1] if word.endswith("k") else word
        if isinstance(item, bool) or not number.isdigit() or len(number) > 6 or int(number) == 0:
            raise InvalidInputError(f"{where}: {str(item).strip()!r} is no width (e.g. 1k,2k,4k or 512,1024)")
        widths.add(int(number) * (1024 if word.endswith("k") else 1))
    return sorted(widths)


def sized_options(options, widths: Sequence[int]):
    """The options of a run that writes its set at ``widths``: the output as wide as the
    largest, in ``options.size``'s aspect, with the material set on."""
    if not widths:
        return options
    import dataclasses

    h, w = options.size
    return dataclasses.replace(options, material=True, size=(max(1, round(h * widths[-1] / w)), widths[-1]))


def udim_options(options, udim: tuple[int, int] | None):
    """The options of a run that writes its set as ``udim`` (``(columns, rows)``) tiles, each
    of ``options.size``: the output the whole grid, one canvas (so every tile continues into
    its neighbours, and round the torus with ``tile``), with the material set on."""
    if udim is None:
        return options
    import dataclasses

    h, w = options.size
    return dataclasses.replace(options, material=True, size=(h * udim[1], w * udim[0]))


def _sized_sets(material, base: str, sizes: Sequence[int]):
    """``(set name, set)`` for each requested width (or the set's own), the height in proportion."""
    for shape in sized_shapes(material.shape, sizes):
        yield material_set_name(base, shape), material.resampled(shape)
