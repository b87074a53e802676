"""What the command groups share that is not an option of a run: the one-line error, the progress
bar, the reading of inputs (CLI-only strings, edit lists, flow fields), the checks of output
paths, the writing of encoded files, and the flags of the files several commands read and write.
A run's options are the options classes' fields (:mod:`barkgen.cli._options`)."""

from __future__ import annotations

import os
import re
import sys
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Optional

import typer

from barkgen.errors import InvalidInputError

if TYPE_CHECKING:
    from barkgen.material import EditList

_LEVEL_NAME = re.compile(r"level_(\d+)\.png$", re.IGNORECASE)


def fail(message: str, status: int = 2) -> typer.Exit:
    """Print ``barkgen: error: MESSAGE`` on stderr; the exit to raise with ``status``."""
    print(f"barkgen: error: {message}", file=sys.stderr)
    return typer.Exit(status)


@contextmanager
def progress_bar(
    enabled: bool, description: str, describe: Callable[[float], str] | None = None, counted: bool = False
) -> Iterator:
    """A rich progress bar on stderr when it is a terminal, else a no-op callback. With
    ``describe``, the bar's text follows the run: ``describe(done / total)`` names what is
    running (e.g. :func:`barkgen.pipeline.stage_at`). ``counted``: the steps are alike (a large
    set's windows): the bar shows ``done/total`` and the time left."""
    if not enabled or not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    columns = [
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(),
    ]
    if counted:
        columns[2:2] = [MofNCompleteColumn()]
        columns.append(TimeRemainingColumn())
    with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(describe(0.0) if describe else description, total=None)

        def update(done: int, total: int) -> None:
            text = describe(done / max(total, 1)) if describe else description
            bar.update(task, completed=done, total=total, description=text)

        yield update


# ------------------------------------------------------------------------ CLI-only strings


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


def parse_pair(text: str, what: str, kind=float) -> tuple:
    """``"A,B"`` -> ``(A, B)``; raises :class:`InvalidInputError` with a clear message."""
    parts = (text or "").split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return kind(parts[0]), kind(parts[1])
    except ValueError:
        raise InvalidInputError(f"invalid {what} {text!r}: expected two numbers A,B") from None


def parse_light(text: str | None):
    """``"AZ,EL"`` -> :class:`barkgen.material.Light`; None (estimated) stays None."""
    from barkgen.material import parse_light as parse

    return None if text is None else parse(text)


def read_resume(path: Path):
    """An edited level for ``--resume``: ``(level, map)`` when the file name says the level
    (``level_N.png``), else the map alone (its size tells the level)."""
    from barkgen.io import read_image

    image = read_image(path)
    m = _LEVEL_NAME.search(path.name)
    return (int(m.group(1)), image) if m else image


#: the largest --edits file read (10,000 edits of JSON are under 1 MiB)
MAX_EDITS_BYTES = 4 * 2**20


def read_edits(path: Path) -> EditList:
    """The edit list of an ``--edits`` JSON file: its height edits, and the depth and light it
    chose (:func:`barkgen.material.parse_edit_list`)."""
    import json

    from barkgen.material import parse_edit_list

    try:
        if path.stat().st_size > MAX_EDITS_BYTES:
            raise InvalidInputError(f"{path}: over {MAX_EDITS_BYTES // 2**20} MiB; an edit list is never that long")
        document = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InvalidInputError(f"{path}: cannot read the edit list ({exc.strerror})") from None
    except RecursionError:
        raise InvalidInputError(f"{path}: nested too deeply to be an edit list") from None
    except ValueError as exc:  # (a UnicodeDecodeError too)
        raise InvalidInputError(f"{path}: not JSON ({str(exc)[:80]})") from None
    return parse_edit_list(document)


# ------------------------------------------------------------------------ output paths


def check_target(path: Path, what: str, suffix: str = ".png") -> None:
    """An output file named by the user: ``suffix`` (.png, .json) and not a folder."""
    if path.suffix.lower() != suffix:
        raise InvalidInputError(f"{what} {str(path)!r} must be a {suffix} file")
    if path.exists() and path.is_dir():
        raise InvalidInputError(f"{what} {str(path)!r} is a directory")


def check_file_name(path: Path, suffix: str, what: str) -> None:
    """A binary output (.glb model, .npz bi-layer model): ``suffix`` and not a folder."""
    if path.suffix.lower() != suffix:
        raise InvalidInputError(f"{path}: the {what} must end in {suffix}")
    if path.is_dir():
        raise InvalidInputError(f"{path} is a folder; give a {suffix} file name")


def check_folder(path: Path, what: str) -> None:
    if path.exists() and not path.is_dir():
        raise InvalidInputError(f"{what} {str(path)!r} exists and is not a folder")


def check_bits(bits: int | None) -> None:
    """``--bits``, checked before the run (the encoder checks it too, but only once the image
    is made)."""
    if bits not in (None, 8, 16):
        raise InvalidInputError(f"--bits must be 8 or 16, not {bits}")


# ------------------------------------------------------------------------ inputs are never outputs

#: the keyword arguments of the commands that name a file they write, and a folder they write into
OUTPUT_FILE_ARGS = ("output", "save_reference", "preview", "labels_out", "plot")
OUTPUT_FOLDER_ARGS = ("output_dir", "save_levels", "debug_dir")
#: the files the running command reads (set by :func:`guard_paths`, checked by :func:`write_files`)
_INPUTS: ContextVar[tuple[Path, ...]] = ContextVar("barkgen_cli_inputs", default=())
#: the largest input image a command reads, in pixels (``barkgen --max-pixels``)
MAX_INPUT_PIXELS: ContextVar[int | None] = ContextVar("barkgen_cli_max_pixels", default=None)
#: the file types whose size in pixels is checked before they are read
_IMAGE_SUFFIXES = (
    *(".png", ".jpg", ".jpeg", ".tif", ".tiff", ".webp", ".gif", ".bmp"),
    *(".ppm", ".pgm", ".tga", ".exr", ".hdr"),
)


def _check_pixels(path: Path) -> None:
    """An input image's declared size against the limit, from its header: a 117 KB PNG that
    declares 121 megapixels is refused in milliseconds, not after minutes of work. Every input
    file is looked at, whatever its name: an image is known by its content."""
    from barkgen._shared.checks import MAX_PHOTO_PIXELS
    from barkgen.errors import ImageReadError, ImageTooLargeError
    from barkgen.io import image_size

    limit = MAX_INPUT_PIXELS.get() or MAX_PHOTO_PIXELS
    try:
        width, height = image_size(path)
    except ImageReadError:
        if path.suffix.lower() in _IMAGE_SUFFIXES:
            raise
        return  # not an image by its content (a spec, an edit list): its own reader judges it
    if width * height > limit:
        raise ImageTooLargeError(
            f"{path}: {width}x{height} px is {width * height / 1e6:.3g} megapixels, more than the "
            f"limit of {limit / 1e6:g}; scale it down (or raise the limit: barkgen --max-pixels N "
            "COMMAND ...)"
        )


def _is_pipe(path: Path) -> bool:
    """``-`` (the standard input), a pipe or a character device: read as a stream."""
    from barkgen.io.image_formats import is_stream

    return is_stream(path)


def _named_paths(kwargs: Mapping[str, object]) -> Iterator[tuple[str, Path]]:
    """``(argument, path)`` of every path among a command's arguments (``--extra NAME=PATH``
    items included)."""
    for key, value in kwargs.items():
        items = value if isinstance(value, (list, tuple)) else [value]
        for item in items:
            if isinstance(item, Path):
                yield key, item
            elif isinstance(item, str) and "=" in item and key == "extra":
                yield key, Path(item.partition("=")[2])


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _writable_folder(folder: Path, what: str, path: Path) -> None:
    """The nearest existing folder at or above ``folder`` takes new files, or one line now
    (not after the whole computation, naming a temporary)."""
    probe = folder if str(folder) else Path(".")
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if probe.exists() and (not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK)):
        raise InvalidInputError(f"{what} {str(path)!r}: cannot write into {str(probe)!r} (not a writable folder)")
    if probe.is_dir():  # the permission bits say yes; ask the file system (root, /proc, a full disk)
        import tempfile

        try:
            handle, name = tempfile.mkstemp(prefix=f".barkgen-probe.{os.getpid()}.", suffix=".tmp", dir=probe)
        except OSError as exc:
            raise InvalidInputError(
                f"{what} {str(path)!r}: cannot write into {str(probe)!r} ({exc.strerror or exc})"
            ) from None
        os.close(handle)
        os.unlink(name)


def _set_files(folder: Path) -> list[Path]:
    """The files of the material set a command reads from ``folder`` (``preview``,
    ``export-glb``); none when it holds no set (the command says so itself)."""
    from barkgen.errors import BarkgenError
    from barkgen.io import find_material

    try:
        name, meta = find_material(folder)
    except BarkgenError:
        return []
    files = meta.get("files")
    listed = files if isinstance(files, list) else []
    return [folder / f"{name}.json"] + [folder / n for n in listed if isinstance(n, str)]


def guard_paths(kwargs: Mapping[str, object]) -> Callable[[], None]:
    """Before a command works: record the files it reads (every existing file among its path
    arguments, and the material set of a folder it reads, ``preview``'s), refuse an
    output that is one of them, and refuse an output whose folder cannot be written. Returns
    the function that forgets the inputs once the command has ended."""
    inputs: list[Path] = []
    for key, path in _named_paths(kwargs):
        if key in OUTPUT_FILE_ARGS or key in OUTPUT_FOLDER_ARGS:
            continue
        if path.is_file():
            inputs.append(path)
            _check_pixels(path)  # by its content, whatever its name (.dat, .raw, no suffix)
        elif _is_pipe(path):  # (``-``, /dev/stdin) read once, up to the reader's byte limit
            _check_pixels(path)
        elif path.is_dir():
            inputs.extend(_set_files(path))
    token = _INPUTS.set(tuple(inputs))
    try:
        for key, path in _named_paths(kwargs):
            what = "--" + key.replace("_dir", "").replace("_", "-")
            if key in OUTPUT_FILE_ARGS:
                refuse_inputs([path], what)
                _writable_folder(path.parent, what, path)
            elif key in OUTPUT_FOLDER_ARGS:
                _writable_folder(path, what, path)
    except BaseException:
        _INPUTS.reset(token)
        raise
    return lambda: _INPUTS.reset(token)


def refuse_inputs(targets: Iterable[Path], what: str = "output") -> None:
    """Refuse (one line) to write any of ``targets`` that is a file the command reads: the
    photo, a label map, an extra map, a set being previewed. Write elsewhere, then move the
    result if replacing the input is meant."""
    for target in targets:
        for source in _INPUTS.get():
            if _same_file(target, source):
                raise InvalidInputError(
                    f"{what} {str(target)!r} is also an input of this command; "
                    "it would be overwritten: write it elsewhere"
                )


# ------------------------------------------------------------------------ writing


def write_files(folder: Path, files: dict[str, bytes]) -> None:
    """Write encoded files into ``folder`` as one step (:func:`write_outputs`)."""
    write_outputs({folder / name: data for name, data in files.items()})


def set_variant(seed: int | None, edit_list) -> str | None:
    """A set's variant (:func:`barkgen.io.variant_name`): the seed, and the tag of an edit list
    that changes anything (its JSON document, :func:`barkgen.material.edits_document`, as the
    web app's relief editor saves it: a replay is named as the web's result)."""
    from barkgen.io import variant_name
    from barkgen.material import edits_document

    changes = edit_list.edits or edit_list.adjusts
    relief, light = edit_list.relief, edit_list.light_equalization
    return variant_name(
        seed, edits_document(edit_list.edits, relief=relief, light_equalization=light) if changes else None
    )


def photo_licence(licence: str | None, photo: Path | None) -> str | None:
    """The licence a set records (``--licence``): the user's, else the bundled sample's when
    the run is of it (no photo given), else none."""
    from barkgen.io.asset_names import SAMPLE_LICENCE

    return licence if licence is not None or photo is not None else SAMPLE_LICENCE


def previous_run_files(folder: Path, record: str = "report.json") -> list[str]:
    """The files of ``folder`` that the run which last wrote it provably made: those its
    ``record`` (generate's ``report.json``) lists whose content still has the recorded SHA-256
    (:func:`barkgen.io.owned_files`); none when there is no barkgen record. Another program's
    ``report.json``, or a file edited since, never makes barkgen remove a file."""
    from barkgen.io import owned_files

    return [n for n in owned_files(folder, record) or [] if n != record]


def write_run(
    folder: Path,
    files: dict[str, bytes],
    stale: Iterable[str],
    also: dict[Path, bytes] | None = None,
    staged: list | None = None,
) -> None:
    """Write a run's files into ``folder``, and ``also`` (e.g. its pyramid levels elsewhere), as
    one step with the files already ``staged`` in it (a windowed material set's,
    :func:`barkgen.pipeline.write_windowed_material`; :func:`write_outputs`), then remove the
    files of the run before it (``stale``, from :func:`previous_run_files` read before the run)
    that this run did not write: a folder never holds a mix of two runs' sets (a new texture
    beside an old run's material maps that ``preview`` would then pick up)."""
    staged = staged or []
    write_outputs({folder / name: data for name, data in files.items()} | dict(also or {}), staged)
    written = set(files) | {Path(target).name for _, target in staged if Path(target).parent == folder}
    for name in set(stale) - written:
        path = folder / name
        if path.is_file() and not any(_same_file(path, p) for p in _INPUTS.get()):
            path.unlink(missing_ok=True)


def write_outputs(files: dict[Path, bytes], staged: list | None = None) -> None:
    """Write every encoded output as one step, whatever folders they go to: nothing is written
    before all are encoded, and nothing renamed into place before all are staged in full (a
    full disk leaves none of them, :func:`barkgen.io.stage_files`); ``staged``: files staged
    already (:mod:`barkgen.io.staging`), committed with them (or discarded)."""
    from barkgen.io import commit_staged, discard_staged, stage_files

    staged = staged if staged is not None else []
    try:
        refuse_inputs(list(files))
    except BaseException:
        discard_staged(staged)
        raise
    by_folder: dict[Path, dict[str, bytes]] = {}
    for path, data in files.items():
        by_folder.setdefault(path.parent, {})[path.name] = data
    try:
        for folder, group in by_folder.items():
            stage_files(folder, group, staged)
        commit_staged(staged)
    except BaseException:
        discard_staged(staged)
        raise


def refuse_targets(targets: Mapping[str, Path]) -> None:
    """Before any work: none of a command's outputs (``{what: path}``, derived names
    included) is one of its inputs, and no two are the same file; one line otherwise."""
    seen: dict[str, str] = {}
    for what, path in targets.items():
        refuse_inputs([path], what)
        key = os.path.normcase(os.path.abspath(path))
        if key in seen:
            raise InvalidInputError(f"{what} and {seen[key]} would both write {str(path)!r}; name them apart")
        seen[key] = what


def refuse_input_folder(folder: Path, what: str) -> None:
    """Before any work: a folder the command fills with files of its own naming (debug
    pictures, pyramid levels) holds none of its inputs, which a file of that naming could
    overwrite; one line otherwise."""
    for source in _INPUTS.get():
        if folder.is_dir() and _same_file(source.parent, folder):
            raise InvalidInputError(
                f"{what} {str(folder)!r} holds {source.name!r}, an input of "
                "this command, which its files could overwrite: give "
                "another folder"
            )


def level_files(levels: list) -> dict[str, bytes]:
    """``level_N.png`` of every computed level of an output label map."""
    from barkgen.io import encode_png

    return {f"level_{i}.png": encode_png(lvl) for i, lvl in enumerate(levels) if lvl is not None}


# ------------------------------------------------------------------------ inputs and outputs several commands name
# (what a run is made with: the options classes' fields, barkgen.cli._options)

OutputOption = Annotated[Path, typer.Option("-o", "--output", help="Output PNG.")]
ExtraOption = Annotated[
    Optional[list[str]],
    typer.Option(
        "--extra",
        metavar="NAME=PATH",
        help="Map aligned with the exemplar (height, normal, ...), synthesized along; written as OUTPUT_NAME.png.",
    ),
]
SaveReferenceOption = Annotated[
    Optional[Path], typer.Option("--save-reference", help="Also write the reference map (16-bit PNG of exemplar x, y).")
]
BitsOption = Annotated[
    Optional[int], typer.Option("--bits", help="Bits per channel of the output (8 or 16). Default: the exemplar's.")
]
QuietOption = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")]
NoCacheOption = Annotated[
    bool,
    typer.Option(
        "--no-cache",
        help="Neither read nor write the photo analysis cache (by default another run on the same photo and "
        "analysis options reuses the analysis: the same bytes, seconds sooner; barkgen cache show / clear).",
    ),
]
LibraryOption = Annotated[
    Optional[Path],
    typer.Option(
        "--library", help="Library folder (default: $BARKGEN_LIBRARY, else barkgen/library in your user data folder)."
    ),
]
PresetOption = Annotated[
    str,
    typer.Option(
        "--preset",
        metavar="{ambientcg,blender,unreal,unity,gltf}",
        help="The material set's layout, as each engine reads it: ambientcg (NAME_Color, NormalGL and "
        "NormalDX, Displacement, Roughness, AmbientOcclusion), blender (NormalGL only, so Node Wrangler wires "
        "it, and NAME.mtlx with the displacement's scale and midlevel), unreal (BaseColor, NormalDX, ORM), "
        "unity (BaseMap, NormalGL, HDRP MaskMap) or gltf (BaseColor, NormalGL, ORM).",
    ),
]
ExrHeightOption = Annotated[
    bool,
    typer.Option(
        "--exr-height",
        help="Also write the displacement as 32-bit float OpenEXR (NAME_Displacement.exr, 0 = deepest, 1 = "
        "highest: the 16-bit PNG without its rounding; the [exr] extra).",
    ),
]
NameOption = Annotated[
    Optional[str],
    typer.Option(
        "--name",
        help="The set's asset name: files NAME_2K_Color.png, NAME_2K_NormalGL.png, ..., NAME_2K.json (the size tag "
        "in every file). Default: the photo's (or the scanned set's) file name and the variant, as "
        "oak_seed7_2K_Color.png (the seed; an edit list's tag with --edits).",
    ),
]
LayoutOption = Annotated[
    str,
    typer.Option(
        "--layout",
        metavar="{run,library}",
        help="run: the run's own files as texture.png, report.json, ... (a folder per run); library: each named "
        "after the set (oak_seed7_1K_texture.png, ..._report.json), so that runs of several photos, seeds and "
        "sizes share one folder, as an artist's library keeps its sets.",
    ),
]
LicenceOption = Annotated[
    Optional[str],
    typer.Option(
        "--licence",
        help="The photo's licence (e.g. CC0-1.0, CC-BY-4.0), recorded in the set's JSON as source_licence (the "
        "new bark is made of the photo's pixels). Default: the bundled sample's, else not recorded.",
    ),
]
SaveLevelsOption = Annotated[
    Optional[Path],
    typer.Option(
        "--save-levels",
        help="Write every pyramid level of the output label map as "
        "DIR/level_N.png (0 = full size) to edit and --resume from.",
    ),
]
ResumeOption = Annotated[
    Optional[Path],
    typer.Option(
        "--resume",
        help="Continue the output label map from an edited level (DIR/level_N.png of "
        "--save-levels, painted with the same grey values).",
    ),
]
EditsOption = Annotated[
    Optional[Path],
    typer.Option(
        "--edits",
        help="JSON list of height edits to replay on the relief (HeightEditor, wang2003 §3.3; the web app's "
        'relief editor saves one): {"version": 1, "edits": [{"x": 10, "y": 20, "delta": 1.5, "radius": 4}]}, '
        'in pixels of the image edited; "relief": 1.5 and "light_equalization": 0.5 beside "edits" then scale '
        "the depth and relight the colour (the web app's depth and photo light sliders).",
    ),
]
FlowOption = Annotated[
    Optional[Path],
    typer.Option(
        "--flow",
        metavar="FIELD",
        help="Orientation field of the output's size: .npy of angles in degrees, counter-clockwise on screen, "
        "by which the photo is turned at each pixel (0 = as in the photo; an upright fissure then runs at 90 + "
        "angle), or a grey image (mid-grey 0, black -180, white about +180).",
    ),
]
FlowScaleOption = Annotated[
    Optional[Path],
    typer.Option(
        "--flow-scale",
        metavar="FIELD",
        help="Scale field of the output's size: .npy of scales (1 = the photo's; 2 = features twice as large; "
        "0.25 to 4), or a grey image (black 0.25, mid-grey 1, white 4).",
    ),
]


def read_fields(flow: Path | None, flow_scale: Path | None) -> dict:
    """``--flow`` and ``--flow-scale`` read (:func:`barkgen.io.read_field`), as keyword arguments of
    the engine (empty when neither is given)."""
    from barkgen.io import read_field

    fields = {}
    if flow is not None:
        fields["flow"] = read_field(flow, "flow")
    if flow_scale is not None:
        fields["flow_scale"] = read_field(flow_scale, "flow scale")
    return fields
