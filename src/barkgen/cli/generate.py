"""Photo to new bark: ``generate`` (label map, output label map, texture-by-numbers,
laitoch2018 Figure 1.2) and ``batch`` (many seeds of many photos on Dask, the same files)."""

from __future__ import annotations

import dataclasses
import functools
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from barkgen.cli._common import (
    BitsOption,
    EditsOption,
    ExrHeightOption,
    ExtraOption,
    FlowOption,
    FlowScaleOption,
    LayoutOption,
    LibraryOption,
    LicenceOption,
    NameOption,
    NoCacheOption,
    PresetOption,
    QuietOption,
    ResumeOption,
    SaveLevelsOption,
    check_bits,
    check_folder,
    fail,
    level_files,
    parse_extras,
    photo_licence,
    previous_run_files,
    progress_bar,
    read_edits,
    read_fields,
    read_resume,
    refuse_input_folder,
    refuse_inputs,
    set_variant,
    write_run,
)
from barkgen.cli._options import with_options
from barkgen.errors import InvalidInputError
from barkgen.pipeline import GenerateOptions

#: generate's photo argument
PHOTO_HELP = (
    "Bark photo (PNG, JPEG, TIFF, WebP, TGA, EXR, HDR, PPM, ...; - reads it from a pipe), or a folder holding a scanned material set (ambientCG, Poly "
    "Haven, Megascans, Substance or game-pack names: NAME_Color/_diff/_Albedo/_BaseColor/_cc, "
    "_NormalGL/_nor_gl/_nrm/_nm, _Height/_disp/_bump/_hm, _Roughness/_Gloss/_Specular, _AO, _arm; maps of "
    "other sizes are resampled, files it cannot place are named and left out): its own maps are carried "
    "into the new set (--material is then on), named after it. Default: the bundled sample."
)

#: generate's --sizes: one set at several widths
SizesOption = Annotated[
    Optional[str],
    typer.Option(
        "--sizes",
        metavar="1k,2k,4k",
        help="Write the material set at several widths from one run, each as NAME_1K_*, NAME_2K_*, ...: the "
        "same bark resampled, not re-synthesized. The output is as wide as the largest (--size gives the "
        "aspect). Implies --material.",
    ),
]
#: generate's --udim: the set in UDIM tiles (issue 69)
UdimOption = Annotated[
    Optional[str],
    typer.Option(
        "--udim",
        metavar="COLSxROWS",
        help="Write the material set as a grid of UDIM tiles, each --size (NAME_Color.1001.png, 1002, ...; "
        "Mari, Blender and Substance read them as one image): the bark synthesized as one canvas, so every "
        "tile continues into its neighbours (and round the trunk with --tile). Implies --material.",
    ),
]


@with_options(GenerateOptions)
def generate_command(
    photo: Annotated[
        Optional[Path],
        typer.Argument(help=PHOTO_HELP),
    ] = None,
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="Output folder.")] = Path("out"),
    labels: Annotated[
        Optional[Path], typer.Option("--labels", help="Use this label map of the photo instead of making one.")
    ] = None,
    extra: ExtraOption = None,
    save_levels: SaveLevelsOption = None,
    resume: ResumeOption = None,
    bits: BitsOption = None,
    name: NameOption = None,
    licence: LicenceOption = None,
    preset: PresetOption = "ambientcg",
    exr_height: ExrHeightOption = False,
    layout: LayoutOption = "run",
    sizes: SizesOption = None,
    udim: UdimOption = None,
    flow: FlowOption = None,
    flow_scale: FlowScaleOption = None,
    edits: EditsOption = None,
    no_cache: NoCacheOption = False,
    quiet: QuietOption = False,
    *,
    options: GenerateOptions,
) -> None:
    """Photo to new bark in one step: label map, output label map, texture-by-numbers
    (laitoch2018 Figure 1.2). Writes texture.png, labels_in.png, labels_out.png, reference.png,
    report.json and preview.png (+ NAME.png per --extra, + the material set with --material)
    into the output folder."""
    from barkgen import Canvas
    from barkgen.io import read_image, read_scanned_set
    from barkgen.material import EditList
    from barkgen.material.presets import check_preset
    from barkgen.pipeline import (
        adjusted_result,
        check_edit_list,
        encode_generate,
        generate,
        open_store,
        stage_at,
    )
    from barkgen.pipeline.rules import PhotoInputs, check_run

    check_bits(bits)
    check_folder(output_dir, "output")
    set_folder = photo if photo is not None and photo.is_dir() else None
    if set_folder is not None:  # a scanned set in: a set out
        options = dataclasses.replace(options, material=True)
        if output_dir.resolve() == set_folder.resolve():
            raise InvalidInputError(f"{output_dir} is the scanned set's folder; write the new set to another")
    options, widths, grid = _set_sizes(options, sizes, udim)
    check_preset(preset)
    if save_levels is not None:
        check_folder(save_levels, "--save-levels")
        refuse_input_folder(save_levels, "--save-levels")
    extra_paths = _extra_paths(extra)
    src, naming, edit_list = _set_naming(name, licence, photo, set_folder, options.seed, edits)
    stale = _refuse_targets(output_dir, naming, options, widths, extra_paths, preset, layout, grid)
    if edit_list is None:
        edit_list = read_edits(edits) if edits is not None else EditList()
    check_edit_list(edit_list, options.material)
    options = _whole_set_where_needed(options, widths, edit_list)
    scan = read_scanned_set(set_folder) if set_folder is not None else None
    image = scan.color if scan is not None else read_image(src)
    extras = {name: read_image(p, linear=True) for name, p in extra_paths.items()}  # (a map: kept linear)
    label_map = read_image(labels) if labels is not None else None
    edited = read_resume(resume) if resume is not None else None
    fields = read_fields(flow, flow_scale)
    describe = functools.partial(stage_at, material=options.material)
    canvas = Canvas(options.size, tile=options.tile, **fields) if fields else None
    check_run(image, options, canvas, PhotoInputs(extras, label_map, scan), None, edited, edit_list.edits)
    hit: list[float] = []
    with progress_bar(not quiet, "generating", describe) as progress:
        # the photo's analysis from the cache (or made and stored): the same bytes either way;
        # along a flow field the solvers analyse the photo's turned copies, so nothing is kept
        store = open_store(not no_cache) if canvas is None else None
        analysis = _analysis(image, options, extras, label_map, scan, store, progress, hit)
        result = generate(
            image,
            options,
            extra=extras,
            labels_in=label_map if analysis is None else None,
            resume=edited,
            progress=progress,
            scan=scan,
            edits=edit_list.edits,
            canvas=canvas,
            analysis=analysis,
        )
        result = adjusted_result(result, edit_list)  # the edit list's depth and light, after its edits
    set_files = dict(naming, preset=preset, exr_height=exr_height, layout=layout, udim=grid)
    staged: list = []
    try:
        streamed = _write_windowed_set(result, output_dir, str(src), set_files, staged, quiet)
        files = encode_generate(image, result, str(src), **set_files, bits=bits, sizes=widths, streamed=streamed)
    except BaseException:
        from barkgen.io import discard_staged

        discard_staged(staged)
        raise
    levels = {} if save_levels is None else {save_levels / n: d for n, d in level_files(result.label_levels).items()}
    write_run(output_dir, files, stale, levels, staged)
    if store is not None:
        store.flush()  # the analysis, written while the run went on
    if not quiet:
        _say_written(output_dir, options, result, hit)


def _whole_set_where_needed(options, widths, edit_list):
    """``--windowed auto`` makes the set whole where ``--sizes`` resamples it or the edit
    list scales its relief or relights it; ``yes`` is refused there."""
    needs = "--sizes" if widths else ("the edit list's relief and light" if edit_list.adjusts else None)
    if needs is None or options.windowed == "no":
        return options
    if options.windowed == "yes":
        raise InvalidInputError(f"{needs} needs the whole material set: leave out --windowed yes")
    return dataclasses.replace(options, windowed="no")


def _write_windowed_set(result, output_dir: Path, source: str, set_files: dict, staged: list, quiet: bool):
    """A windowed material set's files (``GenerateOptions.windowed``), staged in
    ``output_dir`` window by window with a bar of the windows and the time left; their SHA-256
    (None for a whole set)."""
    from barkgen.pipeline import WindowedMaterial, write_windowed_material

    if not isinstance(result.material, WindowedMaterial):
        return None
    with progress_bar(not quiet, "writing the material set, window by window", counted=True) as progress:
        return write_windowed_material(result, output_dir, source, staged=staged, progress=progress, **set_files)


def _set_sizes(options, sizes: str | None, udim: str | None):
    """The run's options for ``--sizes`` (the output as wide as the largest) or ``--udim`` (the
    output the whole grid of tiles, each ``--size``), the widths and the grid
    (``(columns, rows)`` or None); the two go apart."""
    from barkgen.io import parse_udim
    from barkgen.pipeline import parse_sizes, sized_options, udim_options

    widths = parse_sizes(sizes, "--sizes")
    grid = parse_udim(udim, "--udim")
    if grid is not None and widths:
        raise InvalidInputError("--udim writes the set at the output's size: leave out --sizes")
    return udim_options(sized_options(options, widths), grid), widths, grid


def _say_written(output_dir: Path, options, result, hit: list[float]) -> None:
    """The run's one line on stderr: what it wrote, in how long, and whether the photo's
    analysis came from the cache."""
    h, w = result.texture.shape[:2]
    typer.echo(
        f"wrote {output_dir}/texture.png ({w}x{h}, seed {options.seed}"
        f"{', tileable' if options.tile else ''}) and its maps in "
        f"{result.report['timings_s']['total']:.1f} s"
        f"{f' (the photo analysis from the cache, {hit[0]:.1f} s)' if hit else ''}",
        err=True,
    )


def _analysis(image, options, extras, label_map, scan, store, progress, hit: list[float]):
    """The photo's analysis through ``store`` (:func:`barkgen.pipeline.cached_analysis`; a hit's
    seconds appended to ``hit``), reported as the run's analysis share; None without a store
    (``--no-cache``: generate analyses the photo itself)."""
    from barkgen.pipeline import cached_analysis, stage_span

    if store is None:
        return None
    share = stage_span("analysis", options.material)[1]
    within = (
        None if progress is None else lambda done, total: progress(round(1000 * share * done / max(total, 1)), 1000)
    )
    return cached_analysis(
        image,
        options,
        extra=extras,
        labels_in=label_map,
        scan=scan,
        store=store,
        progress=within,
        on_hit=hit.append,
        wait=False,  # written on a thread while the run goes on
    )


def _run_targets(
    folder: Path, set_names: list[str], extras, stale, preset: str, prefix: str | None, grid=None
) -> list[Path]:
    """The files of ``folder`` a run will write or remove (its own, named after ``prefix`` in
    the library layout; the material set's, in the UDIM tiles of ``grid``, a
    :class:`~barkgen.io.UdimGrid`, if given; each extra's, and the previous run's): none may
    be an input."""
    from barkgen.io.material import material_file_names
    from barkgen.pipeline import run_file_names

    names = set(run_file_names(extras, prefix)) | set(stale)
    for set_name in set_names:
        names |= set(material_file_names(set_name, preset, grid))
        if folder.is_dir():
            names |= {
                p.name for p in folder.iterdir() if p.name.startswith(f"{set_name}_") or p.name == f"{set_name}.json"
            }
    return [folder / n for n in sorted(names)]


def _set_naming(name, licence, photo, set_folder, seed: int, edits):
    """The photo's path (the bundled sample's without one), the set's naming keywords of
    :func:`barkgen.pipeline.encode_generate` (``name``, ``variant``, ``licence``) and the edit
    list when the name needed it (:mod:`barkgen.io.asset_names`). The edit list is read before
    the refusals only then: a named set's files are refused first, whatever the list holds."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import check_material_name
    from barkgen.material import EditList

    if name is not None:
        check_material_name(name)
    edit_list = read_edits(edits) if edits is not None and name is None else None
    src = photo if photo is not None else sample_exemplar_path()
    named_from = _set_stem(set_folder) if set_folder is not None else src
    asset, variant = _set_base_name(name, named_from, seed, edit_list or EditList())
    return src, {"name": asset, "variant": variant, "licence": photo_licence(licence, photo)}, edit_list


def _refuse_targets(
    output_dir: Path, naming: dict, options, widths, extras, preset: str, layout: str, udim=None
) -> list[str]:
    """Refuse a run whose files (its own, named after the output's set in the library layout;
    its sets', in ``udim``'s tiles (``(columns, rows)``) if given; the previous run's) take an
    input, before any work; the previous run's files (:func:`previous_run_files` of its
    record, ``report.json`` or ``SET_report.json``)."""
    from barkgen.io import base_name, material_set_name, material_set_names, udim_grid
    from barkgen.pipeline import LAYOUTS, run_file_names

    if layout not in LAYOUTS:
        raise InvalidInputError(f"--layout must be one of {', '.join(LAYOUTS)}, not {layout!r}")
    base = base_name(naming["name"], naming["variant"])
    grid = None if udim is None else udim_grid(options.size, udim)
    set_shape = options.size if grid is None else grid.tile
    prefix = material_set_name(base, set_shape) if layout == "library" else None
    stale = previous_run_files(output_dir, run_file_names(prefix=prefix)[-1])
    set_names = material_set_names(base, set_shape, widths) if options.material else []
    refuse_inputs(_run_targets(output_dir, set_names, extras, stale, preset, prefix, grid))
    return stale


def _set_stem(folder: Path) -> str:
    """A scanned set's name from its files' names alone (nothing decoded; the files it cannot
    place are named when it is read)."""
    import os
    import warnings

    from barkgen.io import recognise_set

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return recognise_set(os.listdir(folder), folder=str(folder))[0]


def _set_base_name(name: str | None, source, seed: int, edit_list) -> tuple[str, str | None]:
    """The set's asset name and variant (:mod:`barkgen.io.asset_names`): ``--name`` as given
    (no variant), else the photo's or the scanned set's name (``source``: a path or a stem) with
    the seed and the edit list's tag."""
    from barkgen.io import photo_asset_name, set_asset_name

    if name is not None:
        return name, None
    asset = photo_asset_name(source) if isinstance(source, Path) else set_asset_name(str(source))
    return asset, set_variant(seed, edit_list)


def _extra_paths(extra: list[str] | None) -> dict[str, Path]:
    """``--extra NAME=PATH`` maps; each is written as NAME.png beside generate's own files."""
    from barkgen.pipeline import check_generate_names

    extra_paths = parse_extras(extra)
    check_generate_names(extras=extra_paths, words=("--name", "--extra name"))
    return extra_paths


def batch_command(
    spec_path: Annotated[
        Path,
        typer.Argument(
            metavar="SPEC.yaml",
            help="Batch spec: exemplars (path, seeds or count + seed_base) and "
            "generate's options (size, tile, k, method, material, ...).",
        ),
    ],
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="Output folder: OUTDIR/<name>/<seed>/.")],
    scheduler: Annotated[
        Optional[str],
        typer.Option(
            "--scheduler",
            help="Address of a running Dask scheduler (tcp://HOST:PORT). Default: a local cluster on this machine.",
        ),
    ] = None,
    workers: Annotated[
        Optional[int], typer.Option("--workers", help="Worker processes of the local cluster (default: one per core).")
    ] = None,
    threads: Annotated[
        Optional[int],
        typer.Option(
            "--threads",
            help="Threads per variant (default: cores / workers locally, all cores of a worker with --scheduler).",
        ),
    ] = None,
    no_cache: NoCacheOption = False,
    quiet: QuietOption = False,
    library: LibraryOption = None,
) -> None:
    """Generate many unique barks on Dask: every seed of every exemplar in SPEC, each photo
    analysed once and shared with the workers. A re-run makes only what is missing or failed
    (OUTDIR/manifest.sqlite)."""
    from barkgen.batch import load_spec, run_batch

    spec = load_spec(spec_path, threads=threads, library=library)
    check_folder(output_dir, "output")
    say = (lambda message: None) if quiet else (lambda message: typer.echo(message, err=True))
    try:
        with progress_bar(not quiet, "variants") as progress:
            report = run_batch(
                spec,
                output_dir,
                scheduler=scheduler,
                workers=workers,
                threads=threads,
                progress=progress,
                log=say,
                cache=not no_cache,
            )
    except KeyboardInterrupt:
        raise fail(
            f"interrupted; what finished is in {output_dir} (see manifest.sqlite): run the same "
            "command again to make the rest",
            130,
        ) from None
    if report.made or report.failed:
        say(
            f"made {report.made} variant(s) in {report.seconds:.1f} s"
            f"{f', {report.skipped} were already done' if report.skipped else ''} -> {output_dir}"
        )
    if report.failed:
        for name, seed, error in report.failed[:5]:
            print(f"barkgen: error: {name} seed {seed}: {error}", file=sys.stderr)
        raise fail(f"{len(report.failed)} variant(s) failed (run again to retry them)", 1)


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (
    ("generate", generate_command),
    ("batch", batch_command),
)
