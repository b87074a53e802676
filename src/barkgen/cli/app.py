"""The ``barkgen`` command line: a thin front end over the public API."""

from __future__ import annotations

import functools
import re
import sys
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional, TypeVar

import numpy as np
import typer

from barkgen.errors import BarkgenError, InvalidInputError
from barkgen._shared.checks import parse_size

F = TypeVar("F", bound=Callable[..., None])

app = typer.Typer(
    name="barkgen",
    help="Turn one photograph of tree bark into unlimited new, seamless, varied bark.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)

_MEM_RE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([kKmMgGtT]?)i?[bB]?\s*$")


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"barkgen: warning: {message}", file=sys.stderr)


def _fail(message: str, status: int = 2) -> typer.Exit:
    print(f"barkgen: error: {message}", file=sys.stderr)
    return typer.Exit(status)


def user_errors(func: F) -> F:
    """Run a command so that every failure is one line on stderr, never a traceback:
    user errors exit with status 2, interruptions with 130, anything unexpected with 1."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        warnings.showwarning = _one_line_warning
        try:
            return func(*args, **kwargs)
        except (typer.Exit, typer.Abort):
            raise
        except BarkgenError as exc:
            raise _fail(str(exc)) from None
        except MemoryError:
            raise _fail("out of memory (try a smaller --size or fewer --extra maps)") from None
        except OSError as exc:
            where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
            raise _fail(f"{exc.strerror or exc}{where}") from None
        except KeyboardInterrupt:
            raise _fail("interrupted", 130) from None
        except Exception as exc:  # noqa: BLE001 - last resort: still one line, no traceback
            raise _fail(f"internal error: {type(exc).__name__}: {exc}", 1) from None

    return wrapper  # type: ignore[return-value]


def parse_memory(text: str) -> int:
    """``"8G"``, ``"512M"``, ``"1.5GB"`` or a byte count -> bytes."""
    m = _MEM_RE.match(text or "")
    if not m:
        raise InvalidInputError(f"invalid memory amount {text!r}: use e.g. 8G or 512M")
    value = float(m.group(1)) * 1024 ** " KMGT".index((m.group(2) or " ").upper())
    if value <= 0:
        raise InvalidInputError(f"invalid memory amount {text!r}: must be positive")
    return int(value)


def parse_extras(items: list[str] | None) -> dict[str, Path]:
    """``["height=h.png", ...]`` -> ``{"height": Path("h.png")}``."""
    out: dict[str, Path] = {}
    for item in items or []:
        name, sep, path = item.partition("=")
        name = name.strip()
        if not sep or not name or not path or not re.fullmatch(r"[A-Za-z0-9_\-]+", name):
            raise InvalidInputError(f"invalid --extra {item!r}: expected NAME=PATH, e.g. height=h.png")
        if name in out:
            raise InvalidInputError(f"--extra {name!r} given twice")
        out[name] = Path(path)
    return out


def _check_png_target(path: Path, what: str) -> None:
    if path.suffix.lower() != ".png":
        raise InvalidInputError(f"{what} {str(path)!r} must be a .png file")
    if path.exists() and path.is_dir():
        raise InvalidInputError(f"{what} {str(path)!r} is a directory")


def _check_folder(path: Path, what: str) -> None:
    if path.exists() and not path.is_dir():
        raise InvalidInputError(f"{what} {str(path)!r} exists and is not a folder")


@contextmanager
def _progress(enabled: bool, description: str) -> Iterator:
    """A rich progress bar on stderr when it is a terminal, else a no-op callback."""
    if not enabled or not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                  TimeElapsedColumn(), console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(description, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield update


# options shared by the synthesis commands
OutputOption = Annotated[Path, typer.Option("-o", "--output", help="Output PNG.")]
TileOption = Annotated[bool, typer.Option("--tile", help="Make the output tile seamlessly.")]
SeedOption = Annotated[int, typer.Option("--seed", min=0, help="Random seed (same seed, same bytes).")]
ExemplarWrapsOption = Annotated[str, typer.Option(
    "--exemplar-wraps", help="auto: the photo is used as a torus along each axis along which it "
    "tiles itself (its last row continues into its first), so pieces run on across its edge; "
    "yes / no: force it.")]
ExtraOption = Annotated[Optional[list[str]], typer.Option(
    "--extra", metavar="NAME=PATH", help="Map aligned with the exemplar (height, normal, ...), "
    "synthesized along; written as OUTPUT_NAME.png.")]
SaveReferenceOption = Annotated[Optional[Path], typer.Option(
    "--save-reference", help="Also write the reference map (16-bit PNG of exemplar x, y).")]
BitsOption = Annotated[Optional[int], typer.Option(
    "--bits", help="Bits per channel of the output (8 or 16). Default: the exemplar's.")]
MaxMemoryOption = Annotated[str, typer.Option(
    "--max-memory", help="Refuse jobs estimated to need more memory than this.")]
ThreadsOption = Annotated[Optional[int], typer.Option("--threads", min=1, help="Worker threads.")]
QuietOption = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")]
LibraryOption = Annotated[Optional[Path], typer.Option(
    "--library", help="Library folder (default: $BARKGEN_LIBRARY, else barkgen/library in your "
    "user data folder).")]
NameOption = Annotated[str, typer.Option(
    "--name", help="Material set name: files NAME_Color.png, NAME_NormalGL.png, ..., NAME.json.")]
ReliefOption = Annotated[float, typer.Option(
    "--relief", help="Relief strength of the estimated height (1 = as fitted on scanned bark; "
    "2 doubles its depth and its slopes; normals and AO follow).")]
LightOption = Annotated[Optional[str], typer.Option(
    "--light", help="The photo's light AZ,EL in degrees (azimuth counter-clockwise from the "
    "right, elevation above the surface) for shading removal. Default: estimated.")]


def _extra_output_path(output: Path, name: str) -> Path:
    return output.with_name(f"{output.stem}_{name}{output.suffix}")


@app.command("synth")
@user_errors
def synth_command(
    exemplar: Annotated[Optional[Path], typer.Argument(
        help="Bark photo to learn from (PNG/JPEG/TIFF/WebP). Default: the bundled sample.")] = None,
    output: OutputOption = Path("barkgen.png"),
    size: Annotated[str, typer.Option("--size", help="Output size WIDTHxHEIGHT.")] = "1024x1024",
    tile: TileOption = False,
    seed: SeedOption = 0,
    extra: ExtraOption = None,
    save_reference: SaveReferenceOption = None,
    bits: BitsOption = None,
    max_memory: MaxMemoryOption = "8G",
    threads: ThreadsOption = None,
    exemplar_wraps: ExemplarWrapsOption = "auto",
    quiet: QuietOption = False,
) -> None:
    """Synthesize a new bark texture of any size from one exemplar photo."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image
    from barkgen.synth import SynthesisConfig, synthesize

    out_shape = parse_size(size)
    budget = parse_memory(max_memory)
    extra_paths = parse_extras(extra)
    _check_outputs(output, save_reference, bits)
    src = exemplar if exemplar is not None else sample_exemplar_path()
    image = read_image(src)
    extras = {name: read_image(p) for name, p in extra_paths.items()}
    config = SynthesisConfig(threads=threads, max_memory=budget)
    with _progress(not quiet, "synthesizing") as progress:
        result = synthesize(image, out_shape, tile=tile, seed=seed, extra=extras, config=config,
                            progress=progress, exemplar_wrap=exemplar_wraps)
    _write_result(result, output, bits, save_reference, quiet)


def _write_result(result, output: Path, bits: int | None, save_reference: Path | None,
                  quiet: bool) -> None:
    """Write a :class:`SynthesisResult`: the image, each extra map beside it, the reference map."""
    from barkgen.io import write_png, write_reference

    write_png(output, result.image, bits=bits)
    for name, arr in result.extras.items():
        write_png(_extra_output_path(output, name), arr)
    if save_reference is not None:
        write_reference(save_reference, result.references, result.exemplar_shape)
    if not quiet:
        t = result.timings
        h, w = result.image.shape[:2]
        wraps = [axis for axis, on in zip(("rows", "columns"), result.exemplar_wrap) if on]
        typer.echo(f"wrote {output} ({w}x{h}, seed {result.seed}"
                   f"{', tileable' if result.tile else ''}"
                   f"{', exemplar wraps ' + ' and '.join(wraps) if wraps else ''}) in "
                   f"{t['analysis'] + t['synthesis']:.2f} s", err=True)


def _check_outputs(output: Path, save_reference: Path | None, bits: int | None) -> None:
    if bits not in (None, 8, 16):
        raise InvalidInputError(f"--bits must be 8 or 16, not {bits}")
    _check_png_target(output, "output")
    if save_reference is not None:
        _check_png_target(save_reference, "--save-reference")


@app.command("tbn")
@user_errors
def tbn_command(
    exemplar: Annotated[Path, typer.Argument(help="Bark photo to learn from.")],
    labels: Annotated[Path, typer.Option(
        "--labels", help="Label map of the exemplar (lossless image, same size; each grey value "
        "or colour is a label).")],
    target: Annotated[Path, typer.Option(
        "--target", help="Label map of the wanted output; sets the output size.")],
    output: OutputOption = Path("barkgen.png"),
    init: Annotated[str, typer.Option("--init", help="Initialisation: smart or random.")] = "smart",
    label_weight: Annotated[float, typer.Option(
        "--label-weight", help="Weight w of the label term (laitoch2018 eq. 3.1), in units of "
        "the exemplar's colour variance.")] = 20.0,
    feature_weight: Annotated[float, typer.Option(
        "--feature-weight", help="Weight z of the feature-distance channel (eq. 3.3), same "
        "units.")] = 8.0,
    tile: TileOption = False,
    seed: SeedOption = 0,
    extra: ExtraOption = None,
    save_reference: SaveReferenceOption = None,
    debug_dir: Annotated[Optional[Path], typer.Option(
        "--debug-dir", help="Write the pyramid levels, label maps, initialisation and each "
        "level's result as PNGs into this folder.")] = None,
    bits: BitsOption = None,
    max_memory: MaxMemoryOption = "8G",
    threads: ThreadsOption = None,
    exemplar_wraps: ExemplarWrapsOption = "auto",
    quiet: QuietOption = False,
) -> None:
    """Texture-by-numbers: synthesize bark that follows a target label map."""
    import dataclasses

    from barkgen.io import read_image, write_png
    from barkgen.synth import texture_by_numbers
    from barkgen.synth.tbn import TBN_CONFIG

    budget = parse_memory(max_memory)
    extra_paths = parse_extras(extra)
    _check_outputs(output, save_reference, bits)
    if debug_dir is not None:
        _check_folder(debug_dir, "--debug-dir")
    image = read_image(exemplar)
    label_map = read_image(labels)
    target_map = read_image(target)
    extras = {name: read_image(p) for name, p in extra_paths.items()}
    config = dataclasses.replace(TBN_CONFIG, threads=threads, max_memory=budget)

    debug = None
    if debug_dir is not None:
        def debug(name: str, img) -> None:
            debug_dir.mkdir(parents=True, exist_ok=True)
            write_png(debug_dir / f"{name}.png", img)

    with _progress(not quiet, "texture-by-numbers") as progress:
        result = texture_by_numbers(image, label_map, target_map, label_weight=label_weight,
                                    feature_weight=feature_weight, init=init, tile=tile,
                                    seed=seed, extra=extras, config=config, progress=progress,
                                    debug=debug, exemplar_wrap=exemplar_wraps)
    _write_result(result, output, bits, save_reference, quiet)


@app.command("labels")
@user_errors
def labels_command(
    photo: Annotated[Path, typer.Argument(help="Bark photo (PNG/JPEG/TIFF/WebP).")],
    output: OutputOption,
    k: Annotated[int, typer.Option("--k", help="Number of labels (1-16).")] = 3,
    method: Annotated[str, typer.Option(
        "--method", help="color: colour regions (laitoch2018 §3.5); texton: texton channels "
        "merged automatically (wang2003 §3.2).")] = "color",
    edges: Annotated[bool, typer.Option(
        "--edges", help="Add a label for the region edges (k + 1 labels).")] = False,
    edge_width: Annotated[int, typer.Option("--edge-width", help="Width of the edge band, px.")] = 3,
    seed: SeedOption = 0,
    preview: Annotated[Optional[Path], typer.Option(
        "--preview", help="Also write the photo with the label regions tinted and outlined.")] = None,
    quiet: QuietOption = False,
) -> None:
    """Make the label map of a bark photo (input of texture-by-numbers)."""
    from barkgen.io import read_image, write_png
    from barkgen.labels import add_edge_label, color_regions, label_preview, texton_regions

    if method not in ("color", "texton"):
        raise InvalidInputError(f"--method must be color or texton, not {method!r}")
    _check_png_target(output, "output")
    if preview is not None:
        _check_png_target(preview, "--preview")
    image = read_image(photo)
    with _progress(not quiet, "labelling"):
        regions = color_regions if method == "color" else texton_regions
        label_map = regions(image, k, seed=seed)
        if edges:
            label_map = add_edge_label(label_map, edge_width)
        sheet = label_preview(image, label_map) if preview is not None else None
    write_png(output, label_map)
    if sheet is not None:
        write_png(preview, sheet)
    if not quiet:
        n = len(np.unique(label_map))
        typer.echo(f"wrote {output} ({label_map.shape[1]}x{label_map.shape[0]}, {n} labels)", err=True)


@app.command("textons")
@user_errors
def textons_command(
    photo: Annotated[Path, typer.Argument(help="Bark photo (PNG/JPEG/TIFF/WebP).")],
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="Output folder.")],
    n_textons: Annotated[int, typer.Option("--textons", help="Number of textons (2-64).")] = 25,
    seed: SeedOption = 0,
    quiet: QuietOption = False,
) -> None:
    """Texton channels of a photo (wang2003 §3.2): OUT/textons.png (texton number per pixel),
    one mask per texton (OUT/texton_NN.png) and a contact sheet (OUT/sheet.png)."""
    from barkgen.io import read_image, write_png
    from barkgen.labels import contact_sheet, texton_channels

    _check_folder(output_dir, "output")
    image = read_image(photo)
    with _progress(not quiet, "textons"):
        textons, _ = texton_channels(image, n_textons, seed=seed)
        masks = [np.where(textons == t, 255, 0).astype(np.uint8) for t in range(n_textons)]
        sheet = contact_sheet(masks, [f"texton {t}" for t in range(n_textons)])
    output_dir.mkdir(parents=True, exist_ok=True)
    write_png(output_dir / "textons.png", textons)
    for t, mask in enumerate(masks):
        write_png(output_dir / f"texton_{t:02d}.png", mask)
    write_png(output_dir / "sheet.png", sheet)
    if not quiet:
        typer.echo(f"wrote {n_textons} texton channels to {output_dir}", err=True)


@app.command("merge")
@user_errors
def merge_command(
    texton_map: Annotated[Path, typer.Argument(help="textons.png written by 'barkgen textons'.")],
    output: OutputOption,
    groups: Annotated[str, typer.Option(
        "--groups", help="Texton numbers of each label, e.g. \"0,3,7;1,2;4,5,6\".")],
) -> None:
    """Merge raw texton channels into a label map (wang2003 §3.2)."""
    from barkgen.io import read_image, write_png
    from barkgen.labels import merge_channels, parse_groups

    parsed = parse_groups(groups)
    _check_png_target(output, "output")
    write_png(output, merge_channels(read_image(texton_map), parsed))


_LEVEL_NAME = re.compile(r"level_(\d+)\.png$", re.IGNORECASE)


def _read_resume(path: Path):
    """An edited level for ``--resume``: ``(level, map)`` when the file name says the level
    (``level_N.png``), else the map alone (its size tells the level)."""
    from barkgen.io import read_image

    image = read_image(path)
    m = _LEVEL_NAME.search(path.name)
    return (int(m.group(1)), image) if m else image


def _level_files(levels: list) -> dict[str, bytes]:
    """``level_N.png`` of every computed level of an output label map."""
    from barkgen.io import encode_png

    return {f"level_{i}.png": encode_png(lvl) for i, lvl in enumerate(levels) if lvl is not None}


def _write_files(folder: Path, files: dict[str, bytes]) -> None:
    """Write encoded files into ``folder`` as one step (:func:`barkgen.io.write_files_atomic`:
    all are encoded before any is written, all staged before any is renamed into place)."""
    from barkgen.io import write_files_atomic

    write_files_atomic(folder, files)


StrategyOption = Annotated[str, typer.Option(
    "--strategy", help="Output label maps: joint (the core engine on one-hot label channels and "
    "the photo's colours; generate's default, shapes needs --photo), engine (label channels alone; "
    "shapes' default) or layered (Rosenberger et al.'s layered shape synthesis, laitoch2018 §3.6).")]
RotationsOption = Annotated[str, typer.Option(
    "--rotations", help="Layered strategy: boundary patches may turn none, vertical (180°) or "
    "all (90° steps).")]
SaveLevelsOption = Annotated[Optional[Path], typer.Option(
    "--save-levels", help="Write every pyramid level of the output label map as "
    "DIR/level_N.png (0 = full size) to edit and --resume from.")]
ResumeOption = Annotated[Optional[Path], typer.Option(
    "--resume", help="Continue the output label map from an edited level (DIR/level_N.png of "
    "--save-levels, painted with the same grey values).")]


@app.command("shapes")
@user_errors
def shapes_command(
    labels: Annotated[Path, typer.Argument(help="Label map of the exemplar (lossless, grey).")],
    output: OutputOption,
    size: Annotated[str, typer.Option("--size", help="Output size WIDTHxHEIGHT.")] = "1024x1024",
    strategy: StrategyOption = "engine",
    photo: Annotated[Optional[Path], typer.Option(
        "--photo", help="The photo the label map belongs to (the joint strategy matches its "
        "colours too).")] = None,
    rotations: RotationsOption = "vertical",
    layer_order: Annotated[Optional[str], typer.Option(
        "--layer-order", help="Layered strategy: grey values bottom layer first, e.g. "
        "\"255,0,128\" (default: automatic).")] = None,
    tile: TileOption = False,
    seed: SeedOption = 0,
    save_levels: SaveLevelsOption = None,
    resume: ResumeOption = None,
    exemplar_wraps: ExemplarWrapsOption = "auto",
    quiet: QuietOption = False,
) -> None:
    """Synthesize a new label map of any size from an exemplar's label map (laitoch2018 §3.6)."""
    from barkgen.io import encode_png, read_image
    from barkgen.shapes import synthesize_label_map

    out_shape = parse_size(size)
    _check_png_target(output, "output")
    if save_levels is not None:
        _check_folder(save_levels, "--save-levels")
    order = None
    if layer_order is not None:
        try:
            order = [int(v) for v in layer_order.split(",")]
        except ValueError:
            raise InvalidInputError(
                f"invalid --layer-order {layer_order!r}: expected grey values such as 255,0,128") from None
    if photo is not None and strategy != "joint":
        raise InvalidInputError("--photo is for --strategy joint")
    label_map = read_image(labels)
    photo_image = read_image(photo) if photo is not None else None
    edited = _read_resume(resume) if resume is not None else None
    with _progress(not quiet, "label map") as progress:
        result = synthesize_label_map(label_map, out_shape, strategy=strategy, tile=tile,
                                      seed=seed, rotations=rotations, layer_order=order,
                                      resume=edited, progress=progress, photo=photo_image,
                                      exemplar_wrap=exemplar_wraps)
    files = {output.name: encode_png(result.label_map)}
    _write_files(output.parent, files)
    if save_levels is not None:
        _write_files(save_levels, _level_files(result.levels))
    if not quiet:
        typer.echo(f"wrote {output} ({out_shape[1]}x{out_shape[0]}, {strategy}) in "
                   f"{result.timings['label_map']:.2f} s", err=True)


@app.command("generate")
@user_errors
def generate_command(
    photo: Annotated[Optional[Path], typer.Argument(
        help="Bark photo (PNG/JPEG/TIFF/WebP). Default: the bundled sample.")] = None,
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="Output folder.")] = Path("out"),
    size: Annotated[str, typer.Option("--size", help="Output size WIDTHxHEIGHT.")] = "1024x1024",
    k: Annotated[int, typer.Option("--k", help="Number of labels (1-16).")] = 3,
    method: Annotated[str, typer.Option(
        "--method", help="Input label map: color (laitoch2018 §3.5) or texton (wang2003 §3.2).")] = "color",
    labels: Annotated[Optional[Path], typer.Option(
        "--labels", help="Use this label map of the photo instead of making one.")] = None,
    strategy: StrategyOption = "joint",
    rotations: RotationsOption = "vertical",
    tile: TileOption = False,
    seed: SeedOption = 0,
    extra: ExtraOption = None,
    save_levels: SaveLevelsOption = None,
    resume: ResumeOption = None,
    bits: BitsOption = None,
    max_memory: MaxMemoryOption = "8G",
    threads: ThreadsOption = None,
    material: Annotated[bool, typer.Option(
        "--material", help="Also write the material set of the new bark (NAME_Color, NormalGL/DX, "
        "Displacement 16-bit, Roughness, AmbientOcclusion, NAME.json).")] = False,
    name: NameOption = "bark",
    light: LightOption = None,
    relief: ReliefOption = 1.0,
    exemplar_wraps: ExemplarWrapsOption = "auto",
    quiet: QuietOption = False,
) -> None:
    """Photo to new bark in one step: label map, output label map, texture-by-numbers
    (laitoch2018 Figure 1.2). Writes texture.png, labels_in.png, labels_out.png, reference.png,
    report.json and preview.png (+ NAME.png per --extra, + the material set with --material)
    into the output folder."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image
    from barkgen.pipeline import GENERATE_FILES, encode_generate
    from barkgen.pipeline import GenerateOptions, generate

    if bits not in (None, 8, 16):
        raise InvalidInputError(f"--bits must be 8 or 16, not {bits}")
    _check_folder(output_dir, "output")
    _check_material_name(name)
    if not material and (light is not None or relief != 1.0):
        raise InvalidInputError("--light and --relief apply to the material set: add --material")
    if material and name in GENERATE_FILES:
        raise InvalidInputError(f"--name {name!r} would overwrite one of generate's own files; pick another")
    if save_levels is not None:
        _check_folder(save_levels, "--save-levels")
    options = GenerateOptions(size=parse_size(size), k=k, method=method, strategy=strategy,
                              rotations=rotations, tile=tile, seed=seed, threads=threads,
                              max_memory=parse_memory(max_memory), material=material,
                              light=_light(light), relief=relief, exemplar_wrap=exemplar_wraps)
    extra_paths = parse_extras(extra)
    clash = sorted(set(extra_paths) & set(GENERATE_FILES))
    if clash:
        raise InvalidInputError(f"--extra name {clash[0]!r} is taken by an output file; pick another")
    src = photo if photo is not None else sample_exemplar_path()
    image = read_image(src)
    extras = {name: read_image(p) for name, p in extra_paths.items()}
    label_map = read_image(labels) if labels is not None else None
    edited = _read_resume(resume) if resume is not None else None
    with _progress(not quiet, "generating") as progress:
        result = generate(image, options, extra=extras, labels_in=label_map, resume=edited,
                          progress=progress)
        files = encode_generate(image, result, str(src), name=name, bits=bits)
    _write_files(output_dir, files)
    if save_levels is not None:
        _write_files(save_levels, _level_files(result.label_levels))
    if not quiet:
        h, w = result.texture.shape[:2]
        typer.echo(f"wrote {output_dir}/texture.png ({w}x{h}, seed {seed}"
                   f"{', tileable' if tile else ''}) and its maps in "
                   f"{result.report['timings_s']['total']:.1f} s", err=True)


def _light(text: str | None):
    from barkgen.material import parse_light

    return None if text is None else parse_light(text)


def _check_material_name(name: str) -> None:
    from barkgen.io import check_material_name

    check_material_name(name)


@app.command("material")
@user_errors
def material_command(
    photo: Annotated[Optional[Path], typer.Argument(
        help="Bark photo. Default: the bundled sample.")] = None,
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="Output folder.")] = Path("material"),
    name: NameOption = "bark",
    k: Annotated[int, typer.Option("--k", help="Labels of the structure cue (1-16).")] = 3,
    light: LightOption = None,
    relief: ReliefOption = 1.0,
    edits: Annotated[Optional[Path], typer.Option(
        "--edits", help="JSON list of height edits to replay (HeightEditor, wang2003 §3.3): "
        '{"version": 1, "edits": [{"x": 10, "y": 20, "delta": 1.5, "radius": 4}]}.')] = None,
    tile: Annotated[bool, typer.Option("--tile", help="The photo is a tileable texture: maps wrap.")] = False,
    seed: SeedOption = 0,
    quiet: QuietOption = False,
) -> None:
    """The material set of a photo: height, normals (OpenGL and DirectX), AO, roughness and the
    colour with its shading removed (wang2003 §3.3-3.4), in ambientCG names."""
    import json
    import time

    from barkgen.data import sample_exemplar_path
    from barkgen.io import encode_material, read_image
    from barkgen.material import MaterialOptions, make_material, parse_edits

    _check_material_name(name)
    _check_folder(output_dir, "output")
    options = MaterialOptions(k=k, light=_light(light), tile=tile, seed=seed, relief=relief)
    edit_list = []
    if edits is not None:
        try:
            document = json.loads(edits.read_text())
        except OSError as exc:
            raise InvalidInputError(f"{edits}: cannot read the edit list ({exc.strerror})") from None
        except ValueError as exc:
            raise InvalidInputError(f"{edits}: not JSON ({exc})") from None
        edit_list = parse_edits(document)
    src = photo if photo is not None else sample_exemplar_path()
    image = read_image(src)
    h, w = image.shape[:2]
    outside = [e for e in edit_list if not (0 <= e.x < w and 0 <= e.y < h)]
    if outside:
        raise InvalidInputError(f"edit at ({outside[0].x}, {outside[0].y}) is outside the {w}x{h} photo")
    start = time.perf_counter()
    with _progress(not quiet, "material") as progress:
        material = make_material(image, options, edits=edit_list)
        if progress:
            progress(1, 1)
    files = encode_material(material, name, seed=seed, source_photo=str(src),
                            edits=len(edit_list))
    _write_files(output_dir, files)
    if not quiet:
        lt = material.light
        typer.echo(f"wrote {output_dir}/{name}_*.png ({w}x{h}; light {lt.azimuth:g},{lt.elevation:g}; "
                   f"depth {material.depth:.1f} px) in {time.perf_counter() - start:.1f} s", err=True)


ViewRepeat = Annotated[float, typer.Option("--repeat", help="Times the texture goes round the trunk.")]
ViewDisplacement = Annotated[float, typer.Option(
    "--displacement", help="Relief scale (1 = the set's own depth).")]


@app.command("preview")
@user_errors
def preview_command(
    folder: Annotated[Path, typer.Argument(help="Material set folder (barkgen material / generate --material).")],
    output: OutputOption = Path("preview.png"),
    size: Annotated[str, typer.Option("--size", help="Image size WIDTHxHEIGHT.")] = "1024x1024",
    light: Annotated[str, typer.Option("--light", help="Light AZ,EL in degrees.")] = "135,35",
    repeat: ViewRepeat = 2.0,
    displacement: ViewDisplacement = 1.0,
) -> None:
    """Render the set on a trunk (displaced cylinder, normal-mapped, lit; CPU only)."""
    from barkgen.io import encode_png, read_material
    from barkgen.render import TrunkView, render_trunk

    out_shape = parse_size(size)
    _check_png_target(output, "output")
    view = TrunkView(repeat=repeat, displacement=displacement, light=_light(light))
    material, _ = read_material(folder)
    _write_files(output.parent, {output.name: encode_png(render_trunk(material, out_shape, view))})


@app.command("export-glb")
@user_errors
def export_glb_command(
    folder: Annotated[Path, typer.Argument(help="Material set folder.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Output .glb.")] = Path("trunk.glb"),
    repeat: ViewRepeat = 2.0,
    displacement: ViewDisplacement = 1.0,
    segments: Annotated[int, typer.Option("--segments", help="Vertices around the trunk.")] = 256,
) -> None:
    """Write a glTF 2.0 trunk: the relief in the geometry, colour, normal and
    occlusion-roughness-metallic textures."""
    from barkgen.io import encode_glb, read_material
    from barkgen.render import TrunkView, trunk_mesh

    if output.suffix.lower() != ".glb":
        raise InvalidInputError(f"{output}: the output must end in .glb")
    if output.is_dir():
        raise InvalidInputError(f"{output} is a folder; give a .glb file name")
    view = TrunkView(repeat=repeat, displacement=displacement)
    material, _ = read_material(folder)
    _write_files(output.parent, {output.name: encode_glb(trunk_mesh(material, segments=segments, view=view),
                                                         material)})


@app.command("apply-reference")
@user_errors
def apply_reference_command(
    reference: Annotated[Path, typer.Argument(help="Reference map written by --save-reference.")],
    map_path: Annotated[Path, typer.Argument(metavar="MAP", help="Map of the exemplar's size.")],
    output: OutputOption,
    bits: Annotated[Optional[int], typer.Option("--bits", help="8 or 16. Default: the map's.")] = None,
) -> None:
    """Re-apply a saved reference map to another map of the exemplar (height, normal, ...)."""
    from barkgen.io import read_image, read_reference, write_png
    from barkgen.synth import apply_references

    if bits not in (None, 8, 16):
        raise InvalidInputError(f"--bits must be 8 or 16, not {bits}")
    _check_png_target(output, "output")
    refs, ex_shape = read_reference(reference)
    image = read_image(map_path)
    if ex_shape is not None and image.shape[:2] != ex_shape:
        raise InvalidInputError(
            f"{map_path} is {image.shape[1]}x{image.shape[0]} px but the reference map was made for "
            f"a {ex_shape[1]}x{ex_shape[0]} exemplar")
    write_png(output, apply_references(refs, image), bits=bits)


@app.command("batch")
@user_errors
def batch_command(
    spec_path: Annotated[Path, typer.Argument(
        metavar="SPEC.yaml", help="Batch spec: exemplars (path, seeds or count + seed_base) and "
        "generate's options (size, tile, k, method, material, ...).")],
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="Output folder: OUTDIR/<name>/<seed>/.")],
    scheduler: Annotated[Optional[str], typer.Option(
        "--scheduler", help="Address of a running Dask scheduler (tcp://HOST:PORT). "
        "Default: a local cluster on this machine.")] = None,
    workers: Annotated[Optional[int], typer.Option(
        "--workers", help="Worker processes of the local cluster (default: one per core).")] = None,
    threads: Annotated[Optional[int], typer.Option(
        "--threads", help="Threads per variant (default: cores / workers locally, all cores of a "
        "worker with --scheduler).")] = None,
    quiet: QuietOption = False,
    library: LibraryOption = None,
) -> None:
    """Generate many unique barks on Dask: every seed of every exemplar in SPEC, each photo
    analysed once and shared with the workers. A re-run makes only what is missing or failed
    (OUTDIR/manifest.sqlite)."""
    from barkgen.batch import load_spec, run_batch

    spec = load_spec(spec_path, threads=threads, library=library)
    _check_folder(output_dir, "output")
    say = (lambda message: None) if quiet else (lambda message: typer.echo(message, err=True))
    try:
        with _progress(not quiet, "variants") as progress:
            report = run_batch(spec, output_dir, scheduler=scheduler, workers=workers, threads=threads,
                               progress=progress, log=say)
    except KeyboardInterrupt:
        raise _fail(f"interrupted; what finished is in {output_dir} (see manifest.sqlite): run the same "
                    "command again to make the rest", 130) from None
    if report.made or report.failed:
        say(f"made {report.made} variant(s) in {report.seconds:.1f} s"
            f"{f', {report.skipped} were already done' if report.skipped else ''} -> {output_dir}")
    if report.failed:
        for name, seed, error in report.failed[:5]:
            print(f"barkgen: error: {name} seed {seed}: {error}", file=sys.stderr)
        raise _fail(f"{len(report.failed)} variant(s) failed (run again to retry them)", 1)


bilayer_app = typer.Typer(
    name="bilayer", no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
    rich_markup_mode=None,
    help="Bi-layer textures (guingo2017): structure + spatially varying noise, synthesized "
    "window by window without bounds.")
app.add_typer(bilayer_app, name="bilayer")

TlocOption = Annotated[int, typer.Option(
    "--tloc", help="Local spectrum window: 2, 4, 8 or 16 px (larger: more goes into the noise; "
    "see `barkgen bilayer tune`).")]
NoisesOption = Annotated[int, typer.Option("--k", help="Number of stationary noises (clusters), 1-8.")]


def parse_pair(text: str, what: str, kind=float) -> tuple:
    """``"A,B"`` -> ``(A, B)``; raises :class:`InvalidInputError` with a clear message."""
    parts = (text or "").split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return kind(parts[0]), kind(parts[1])
    except ValueError:
        raise InvalidInputError(f"invalid {what} {text!r}: expected two numbers A,B") from None


def _analysis_options(k: int, tloc: int, masks: str, equalize: bool, border: int, sigma: float, seed: int):
    from barkgen.bilayer import AnalysisOptions

    return AnalysisOptions(k=k, tloc=tloc, masks=masks, equalize=equalize, border=border,
                           sigma_range=sigma, seed=seed)


@bilayer_app.command("analyze")
@user_errors
def bilayer_analyze_command(
    photo: Annotated[Optional[Path], typer.Argument(help="Exemplar photo. Default: the bundled sample.")] = None,
    output: Annotated[Path, typer.Option("-o", "--output", help="Model file (.npz).")] = Path("bark.npz"),
    k: NoisesOption = 2,
    tloc: TlocOption = 4,
    masks: Annotated[str, typer.Option("--masks", help="binary or barycentric.")] = "binary",
    equalize: Annotated[bool, typer.Option("--equalize", help="Equalise the noise's histogram per "
                                           "cluster (non-Gaussian noise, §6).")] = False,
    border: Annotated[int, typer.Option("--border", help="Band (px) along mask borders kept sharp in "
                                        "the structure (§6); 0: none.")] = 0,
    sigma: Annotated[float, typer.Option("--sigma", help="Range sigma of the structure filter "
                                         "(larger: more of the grain goes into the noise).")] = 0.001,
    seed: SeedOption = 0,
    preview: Annotated[Optional[Path], typer.Option(
        "--preview", help="Also write a PNG of P, N, the masks, the spectra and a synthesized sample.")] = None,
    quiet: QuietOption = False,
) -> None:
    """Analyse a photo into a bi-layer model: structure P, masks M_k, noise spectra S_k."""
    from barkgen.bilayer import analysis_preview, analyze
    from barkgen.data import sample_exemplar_path
    from barkgen.io import encode_png, read_image
    from barkgen.io.bilayer import encode_bilayer_model

    options = _analysis_options(k, tloc, masks, equalize, border, sigma, seed)
    if output.suffix.lower() != ".npz":
        raise InvalidInputError(f"{output}: the model file must end in .npz")
    if output.is_dir():
        raise InvalidInputError(f"{output} is a folder; give a .npz file name")
    if preview is not None:
        _check_png_target(preview, "preview")
    image = read_image(photo if photo is not None else sample_exemplar_path())
    with _progress(not quiet, "analysing") as progress:
        model = analyze(image, options, progress=progress)
    files = {output: encode_bilayer_model(model)}
    if preview is not None:
        h, w = model.exemplar.shape[:2]
        files[preview] = encode_png(analysis_preview(model, model.window(0, 0, 2 * w, h, seed=seed)))
    for path, data in files.items():  # everything is encoded before anything is written
        _write_files(path.parent, {path.name: data})
    if not quiet:
        typer.echo(f"wrote {output} (K={k}, T_loc={tloc}, noise std "
                   f"{float(model.noise_layer.std()):.3f})", err=True)


@bilayer_app.command("tune")
@user_errors
def bilayer_tune_command(
    photo: Annotated[Optional[Path], typer.Argument(help="Exemplar photo. Default: the bundled sample.")] = None,
    output: Annotated[Path, typer.Option("-o", "--output", help="Sheet PNG.")] = Path("tune.png"),
    k: NoisesOption = 2,
    seed: SeedOption = 0,
    quiet: QuietOption = False,
) -> None:
    """The T_loc choice sheet (guingo2017 Fig. 14): for T_loc = 2, 4, 8, 16 the structure P,
    the noise N and a synthesized sample. Pick the largest T_loc that still looks right."""
    from barkgen.bilayer import AnalysisOptions, tune_sheet
    from barkgen.data import sample_exemplar_path
    from barkgen.io import encode_png, read_image

    _check_png_target(output, "output")
    options = AnalysisOptions(k=k, seed=seed)
    image = read_image(photo if photo is not None else sample_exemplar_path())
    with _progress(not quiet, "analysing") as progress:
        sheet = tune_sheet(image, options, seed=seed, progress=progress)
    _write_files(output.parent, {output.name: encode_png(sheet)})


@bilayer_app.command("synth")
@user_errors
def bilayer_synth_command(
    model_path: Annotated[Path, typer.Argument(metavar="MODEL", help="Model file from `bilayer analyze`.")],
    output: OutputOption = Path("bilayer.png"),
    size: Annotated[str, typer.Option("--size", help="Window size WIDTHxHEIGHT.")] = "1024x1024",
    offset: Annotated[str, typer.Option("--offset", help="Window position X,Y in the unbounded "
                                        "texture (windows of one seed agree where they overlap).")] = "0,0",
    rotate: Annotated[float, typer.Option("--rotate", help="Rotate the structure's pieces by up to "
                                          "DEG_MAX degrees (0-180).")] = 0.0,
    scale: Annotated[str, typer.Option("--scale", help="Zoom the structure's pieces by MIN,MAX.")] = "1,1",
    keep_vertical: Annotated[bool, typer.Option("--keep-vertical", help="Rotate pieces only about the "
                                                "upright (0 or 180 degrees, plus --rotate).")] = False,
    tile_size: Annotated[Optional[int], typer.Option("--tile-size", help="Wang tile size in px "
                                                     "(default: a quarter of the exemplar).")] = None,
    warp: Annotated[float, typer.Option("--warp", help="Turbulence bending the tile grid, in tile "
                                        "sizes (0-1; 0: none).")] = 0.1,
    compensate: Annotated[bool, typer.Option("--compensate/--no-compensate", help="With --rotate or "
                                             "--scale, give the noise the fine detail the deformed "
                                             "structure lost (--no-compensate: the paper's noise).")] = True,
    blend: Annotated[bool, typer.Option("--blend/--no-blend", help="Blend the tiles' seams in the "
                                        "gradient domain (--no-blend: graph cuts only).")] = True,
    seed: SeedOption = 0,
    bits: Annotated[int, typer.Option("--bits", help="Bits per channel (8 or 16).")] = 8,
) -> None:
    """Synthesize a window of the unbounded bi-layer texture of a model."""
    from barkgen.bilayer import Deformation, SynthesisOptions
    from barkgen.io import encode_png
    from barkgen.io.bilayer import read_bilayer_model

    out_shape = parse_size(size)
    x, y = parse_pair(offset, "--offset", int)
    lo, hi = parse_pair(scale, "--scale")
    if bits not in (8, 16):
        raise InvalidInputError(f"--bits must be 8 or 16, not {bits}")
    _check_png_target(output, "output")
    options = SynthesisOptions(tile_size=tile_size, warp=warp, compensate=compensate, blend=blend,
                               deformation=Deformation(rotate=rotate, scale=(lo, hi), keep_vertical=keep_vertical))
    model = read_bilayer_model(model_path)
    image = model.window(x, y, out_shape[1], out_shape[0], seed=seed, options=options)
    image16 = (image * 65535.0 + 0.5).astype(np.uint16)
    _write_files(output.parent, {output.name: encode_png(image16, bits=bits)})


@app.callback(invoke_without_command=True)
def _root(
    version: Annotated[bool, typer.Option("--version", help="Print the version and exit.")] = False,
) -> None:
    if version:
        from barkgen._version import __version__

        typer.echo(f"barkgen {__version__}")
        raise typer.Exit()


library_app = typer.Typer(
    name="library", no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
    rich_markup_mode=None,
    help="The exemplar library: bark photos by species, their analyses and generated results "
    "(SQLite + files; --library PATH or $BARKGEN_LIBRARY, default in your data folder).")
app.add_typer(library_app, name="library")


def _open_library(path: Path | None):
    from barkgen.library import Library

    return Library(path)


@library_app.command("add")
@user_errors
def library_add_command(
    photo: Annotated[Path, typer.Argument(help="Bark photo (PNG, JPEG, TIFF, WebP).")],
    name: Annotated[Optional[str], typer.Option("--name", help="Display name (default: the file name).")] = None,
    species: Annotated[Optional[str], typer.Option("--species", help="Tree species, e.g. oak.")] = None,
    bark_type: Annotated[Optional[str], typer.Option("--bark-type", help="e.g. furrowed, plated, scaly.")] = None,
    licence: Annotated[Optional[str], typer.Option("--licence", help="Licence of the photo, e.g. CC0.")] = None,
    source: Annotated[Optional[str], typer.Option("--source", help="Where the photo comes from.")] = None,
    library: LibraryOption = None,
) -> None:
    """Add a bark photo to the library and print its id (the same photo twice gives one entry)."""
    from barkgen.io import read_image_bytes

    lib = _open_library(library)
    data = read_image_bytes(photo)
    existing = lib.find_exemplar(data)
    exemplar = existing or lib.add_exemplar(data, name or photo.stem, species=species, bark_type=bark_type,
                                            licence=licence, source=source or str(photo))
    note = "" if existing is None else " (already in the library)"
    typer.echo(f"{exemplar.id}\t{exemplar.name}{note}")


@library_app.command("list")
@user_errors
def library_list_command(library: LibraryOption = None) -> None:
    """List the exemplars: id, name, species, bark type, size, results, licence."""
    lib = _open_library(library)
    counts: dict[int, int] = {}
    for result in lib.results():
        counts[result.exemplar_id] = counts.get(result.exemplar_id, 0) + 1
    rows = [("id", "name", "species", "type", "size", "results", "licence")]
    rows += [(str(e.id), e.name, e.species or "-", e.bark_type or "-", f"{e.width}x{e.height}",
              str(counts.get(e.id, 0)), e.licence or "-") for e in lib.exemplars()]
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        typer.echo("  ".join(cell.ljust(width) for cell, width in zip(row, widths)).rstrip())
    typer.echo(f"library: {lib.path}", err=True)


@library_app.command("show")
@user_errors
def library_show_command(
    exemplar_id: Annotated[int, typer.Argument(metavar="ID", help="Exemplar id (see `barkgen library list`).")],
    library: LibraryOption = None,
) -> None:
    """Show one exemplar and its results."""
    import json

    lib = _open_library(library)
    exemplar = lib.exemplar(exemplar_id)
    results = [{"id": r.id, "created": r.created, "params": r.params, "files": sorted(r.files),
                "timings_s": r.timings} for r in lib.results(exemplar_id)]
    typer.echo(json.dumps({**exemplar.to_dict(), "results": results}, indent=2))


@library_app.command("rm")
@user_errors
def library_rm_command(
    exemplar_id: Annotated[int, typer.Argument(metavar="ID", help="Exemplar id to remove.")],
    library: LibraryOption = None,
) -> None:
    """Remove an exemplar with its analyses and results."""
    lib = _open_library(library)
    name = lib.exemplar(exemplar_id).name
    lib.remove_exemplar(exemplar_id)
    typer.echo(f"removed {exemplar_id}\t{name}")


@app.command("serve")
@user_errors
def serve_command(
    host: Annotated[str, typer.Option("--host", help="Address to listen on (127.0.0.1: this "
                                      "machine only; 0.0.0.0 opens it to your network).")] = "127.0.0.1",
    port: Annotated[int, typer.Option("--port", help="Port to listen on.")] = 8000,
    library: LibraryOption = None,
    max_upload_mb: Annotated[int, typer.Option("--max-upload-mb", help="Largest upload in MB.")] = 25,
    max_upload_mp: Annotated[float, typer.Option("--max-upload-mp", help="Largest upload in megapixels.")] = 50,
) -> None:
    """Run the web app: pick or upload bark, generate with one click, paint labels, see it on a
    trunk, download the material set."""
    import socket

    from barkgen.web import WebLimits, serve

    if not 0 < port < 65536:
        raise InvalidInputError(f"--port must be 1-65535, not {port}")
    if max_upload_mb <= 0 or max_upload_mp <= 0:
        raise InvalidInputError("upload limits must be > 0")
    lib = _open_library(library)
    try:  # a clear line instead of uvicorn's traceback when the port is taken
        with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind((host, port))
    except OSError as exc:
        raise InvalidInputError(f"cannot listen on {host}:{port} ({exc.strerror or exc}); "
                                "try another --port") from None
    limits = WebLimits(max_upload_bytes=max_upload_mb * 1024**2,
                       max_upload_pixels=int(max_upload_mp * 1e6))

    from barkgen.web.app import is_loopback

    def ready(url: str) -> None:
        typer.echo(f"barkgen is running at {url}  (library: {lib.path}; Ctrl-C stops it)", err=True)
        if not is_loopback(host):
            typer.echo(f"barkgen: warning: listening on {host}: anyone who can reach this machine "
                       "can use this server and its library (there is no login)", err=True)

    try:
        serve(lib, host=host, port=port, limits=limits, on_ready=ready)
    except KeyboardInterrupt:  # Ctrl-C is how a server is stopped: not an error
        pass
    typer.echo("barkgen: server stopped", err=True)


branches_app = typer.Typer(
    name="branches", no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
    rich_markup_mode=None,
    help="Branching structures (cracks, fissures, dried mud; sibbing2010): extract a network "
    "from an image, grow new ones, render them from fragments of the image, compare statistics.")
app.add_typer(branches_app, name="branches")


def _check_json_target(path: Path, what: str) -> None:
    if path.suffix.lower() != ".json":
        raise InvalidInputError(f"{what} {str(path)!r} must be a .json file")
    if path.exists() and path.is_dir():
        raise InvalidInputError(f"{what} {str(path)!r} is a directory")


def _write_outputs(files: dict[Path, bytes]) -> None:
    """Write every encoded output, each folder as one step (nothing is written before all are
    encoded)."""
    by_folder: dict[Path, dict[str, bytes]] = {}
    for path, data in files.items():
        by_folder.setdefault(path.parent, {})[path.name] = data
    for folder, group in by_folder.items():
        _write_files(folder, group)


def _grey_unit(image: np.ndarray) -> np.ndarray:
    """An image as a float32 ``(H, W)`` map in [0, 1] (colour averaged)."""
    scale = 65535.0 if image.dtype == np.uint16 else 255.0
    grey = image.astype(np.float32) / scale
    return grey.mean(axis=2) if grey.ndim == 3 else grey


@branches_app.command("extract")
@user_errors
def branches_extract_command(
    image_path: Annotated[Path, typer.Argument(metavar="IMAGE", help="Image with cracks or fissures.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Structure JSON.")] = Path("source.json"),
    labels: Annotated[Optional[Path], typer.Option(
        "--labels", help="A label map of the image (e.g. from `barkgen labels`); its darkest label "
        "in the image is taken as the fissures.")] = None,
    step: Annotated[Optional[float], typer.Option(
        "--step", help="Resampling step h in pixels (default: from the crack width).")] = None,
    preview: Annotated[Optional[Path], typer.Option(
        "--preview", help="Also write a PNG of the structure drawn over the image.")] = None,
    labels_out: Annotated[Optional[Path], typer.Option(
        "--labels-out", help="Also write the image's fissure label map (white cracks on black), "
        "the exemplar labels for texture-by-numbers with a rendered --labels-out as target.")] = None,
    quiet: QuietOption = False,
) -> None:
    """Extract the crack network of an image as a structure (skeleton graph with thickness)."""
    from barkgen.branching.extract import extract_structure, overlay_structure
    from barkgen.io import encode_png, read_image
    from barkgen.io.branches import encode_structure

    _check_json_target(output, "output")
    if preview is not None:
        _check_png_target(preview, "preview")
    if labels_out is not None:
        _check_png_target(labels_out, "--labels-out")
    if step is not None and not 0.25 <= step <= 64:
        raise InvalidInputError(f"--step must be in [0.25, 64] pixels, got {step}")
    image = read_image(image_path)
    label_map = read_image(labels) if labels is not None else None
    if label_map is not None and label_map.shape[:2] != image.shape[:2]:
        raise InvalidInputError(f"{labels}: the label map is {label_map.shape[1]}x{label_map.shape[0]} "
                                f"but the image is {image.shape[1]}x{image.shape[0]}")
    structure = extract_structure(image, label_map, step=step)
    files = {output: encode_structure(structure)}
    if preview is not None:
        files[preview] = encode_png(overlay_structure(image, structure))
    if labels_out is not None:
        from barkgen.branching import rasterize

        files[labels_out] = encode_png(rasterize(structure).astype(np.uint8) * 255)
    _write_outputs(files)
    if not quiet:
        typer.echo(f"wrote {output}: {len(structure.branches)} branches, "
                   f"{structure.total_length():.0f} px, {structure.junctions()} junctions, "
                   f"step {structure.step:g} px", err=True)


@branches_app.command("grow")
@user_errors
def branches_grow_command(
    source_path: Annotated[Path, typer.Argument(metavar="SRC.json", help="Source structure.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Grown structure JSON.")] = Path("grown.json"),
    size: Annotated[str, typer.Option("--size", help="Output size WIDTHxHEIGHT.")] = "1024x1024",
    guide: Annotated[Optional[Path], typer.Option(
        "--guide", help="Guide map of the output size: branches are drawn to dark values "
        "(a dark valley along a path), roots start where it is dark.")] = None,
    length: Annotated[Optional[float], typer.Option(
        "--length", help="Total branch length to grow in px (default: the source's length per "
        "pixel times the output area).")] = None,
    levels: Annotated[int, typer.Option("--levels", help="Maximum branch generations.")] = 64,
    seed: SeedOption = 0,
    quiet: QuietOption = False,
) -> None:
    """Grow a new structure with the source's bending, furcation and merge statistics."""
    from barkgen.branching.grow import GrowOptions, grow_structure
    from barkgen.branching.model import fit_model
    from barkgen.io import read_image
    from barkgen.io.branches import encode_structure, read_structure

    _check_json_target(output, "output")
    h, w = parse_size(size)
    options = GrowOptions(total_length=length, max_levels=levels).validate()
    source = read_structure(source_path)
    guide_map = None
    if guide is not None:
        guide_map = _grey_unit(read_image(guide))
        if guide_map.shape != (h, w):
            raise InvalidInputError(f"{guide}: the guide map is {guide_map.shape[1]}x{guide_map.shape[0]} "
                                    f"but --size is {w}x{h}; they must be the same size")
    model = fit_model(source)
    with _progress(not quiet, "growing") as progress:
        grown = grow_structure(model, (w, h), seed=seed, guide=guide_map, options=options, progress=progress)
    _write_outputs({output: encode_structure(grown)})
    if not quiet:
        typer.echo(f"wrote {output}: {len(grown.branches)} branches, {grown.total_length():.0f} px, "
                   f"{grown.junctions()} junctions", err=True)


@branches_app.command("render")
@user_errors
def branches_render_command(
    image_path: Annotated[Path, typer.Argument(metavar="IMAGE", help="The source image.")],
    source_path: Annotated[Path, typer.Argument(metavar="SRC.json", help="Its structure.")],
    target_path: Annotated[Path, typer.Argument(metavar="DST.json", help="The structure to render.")],
    output: OutputOption = Path("branches.png"),
    labels_out: Annotated[Optional[Path], typer.Option(
        "--labels-out", help="Also write the fissure label map of the output (white cracks on "
        "black) for texture-by-numbers.")] = None,
    seed: SeedOption = 0,
    quiet: QuietOption = False,
) -> None:
    """Render a structure from fragments of the source image; the core engine fills the gaps."""
    from barkgen.branching.render import render_branches
    from barkgen.io import encode_png, read_image
    from barkgen.io.branches import read_structure

    _check_png_target(output, "output")
    if labels_out is not None:
        _check_png_target(labels_out, "--labels-out")
    image = read_image(image_path)
    source = read_structure(source_path)
    target = read_structure(target_path)
    if (source.width, source.height) != (image.shape[1], image.shape[0]):
        raise InvalidInputError(f"{source_path} belongs to a {source.width}x{source.height} image but "
                                f"{image_path} is {image.shape[1]}x{image.shape[0]}")
    with _progress(not quiet, "rendering") as progress:
        result = render_branches(image, source, target, seed=seed, progress=progress)
    files = {output: encode_png(result.image)}
    if labels_out is not None:
        files[labels_out] = encode_png(result.labels)
    _write_outputs(files)


@branches_app.command("stats")
@user_errors
def branches_stats_command(
    source_path: Annotated[Path, typer.Argument(metavar="SRC.json", help="Source structure.")],
    target_path: Annotated[Path, typer.Argument(metavar="DST.json", help="Grown structure.")],
    plot: Annotated[Optional[Path], typer.Option(
        "--plot", help="Histogram plot PNG (default: DST_stats.png beside DST.json).")] = None,
) -> None:
    """Angle and thickness histograms of two structures side by side (sibbing2010 Fig. 7)."""
    from rich.console import Console
    from rich.table import Table

    from barkgen.branching.stats import compare_structures, comparison_plot
    from barkgen.io import encode_png
    from barkgen.io.branches import read_structure

    plot = plot if plot is not None else target_path.with_name(f"{target_path.stem}_stats.png")
    _check_png_target(plot, "--plot")
    cmp = compare_structures(read_structure(source_path), read_structure(target_path))
    console = Console()
    for title, edges, src, dst, fmt in (
            ("turning angle (degrees)", np.degrees(cmp.angle_edges), cmp.source_angles, cmp.target_angles, "{:+.1f}"),
            ("thickness (px)", cmp.thickness_edges, cmp.source_thickness, cmp.target_thickness, "{:.2f}")):
        table = Table(title=title, title_justify="left")
        table.add_column("bin")
        table.add_column("source", justify="right")
        table.add_column("target", justify="right")
        table.add_column("source | target", no_wrap=True)
        for i in range(len(src)):
            bar = "#" * int(round(src[i] * 60))
            bar2 = "#" * int(round(dst[i] * 60))
            table.add_row(f"{fmt.format(edges[i])} .. {fmt.format(edges[i + 1])}", f"{src[i]:.3f}",
                          f"{dst[i]:.3f}", f"{bar:<20.20}|{bar2:<20.20}")
        console.print(table)
    console.print(f"L1 angle {cmp.angle_l1:.3f}   L1 thickness {cmp.thickness_l1:.3f}   "
                  f"L1 direction {cmp.heading_l1:.3f}   "
                  f"junctions per Mpx {cmp.source_junction_density:.0f} -> {cmp.target_junction_density:.0f}   "
                  f"free ends per Mpx {cmp.source_free_end_density:.0f} -> {cmp.target_free_end_density:.0f}   "
                  f"length per px {cmp.source_length_density:.4f} -> {cmp.target_length_density:.4f}   "
                  f"intersections {cmp.target_intersections}", highlight=False)
    _write_outputs({plot: encode_png(comparison_plot(cmp))})
