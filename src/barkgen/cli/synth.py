"""Texture synthesis commands: ``synth`` (laitoch2018 §3.3), ``tbn`` (texture-by-numbers,
laitoch2018 §3.4) and ``apply-reference`` (a saved reference map re-applied, §3.3.1)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from barkgen.cli._common import (
    BitsOption,
    ExtraOption,
    FlowOption,
    FlowScaleOption,
    OutputOption,
    QuietOption,
    SaveReferenceOption,
    check_bits,
    check_folder,
    check_target,
    parse_extras,
    progress_bar,
    read_fields,
    refuse_input_folder,
    refuse_targets,
    write_outputs,
)
from barkgen.cli._options import option_flags, with_options
from barkgen.errors import InvalidInputError
from barkgen.pipeline import GenerateOptions
from barkgen.synth import TBN_CONFIG, SynthesisConfig


@option_flags(GenerateOptions)  # (the canvas: size, tile, seed, the photo's wrap)
@with_options(SynthesisConfig, after="bits", into="config")
def synth_command(
    exemplar: Annotated[
        Optional[Path],
        typer.Argument(
            help="Bark photo to learn from (PNG, JPEG, TIFF, WebP, TGA, EXR, HDR, PPM, ...; - reads it from a pipe). Default: the bundled sample."
        ),
    ] = None,
    output: OutputOption = Path("barkgen.png"),
    *,
    size: tuple[int, int],
    tile: bool,
    seed: int,
    extra: ExtraOption = None,
    save_reference: SaveReferenceOption = None,
    bits: BitsOption = None,
    exemplar_wrap: str,
    flow: FlowOption = None,
    flow_scale: FlowScaleOption = None,
    quiet: QuietOption = False,
    config: SynthesisConfig,
) -> None:
    """Synthesize a new bark texture of any size from one exemplar photo (along an orientation
    and scale field with --flow / --flow-scale)."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image
    from barkgen.synth import Budget, Canvas, synthesize

    extra_paths = parse_extras(extra)
    _check_outputs(output, save_reference, bits, extra_paths)
    src = exemplar if exemplar is not None else sample_exemplar_path()
    image = read_image(src)
    extras = {name: read_image(p, linear=True) for name, p in extra_paths.items()}  # (a map: kept linear)
    fields = read_fields(flow, flow_scale)
    with progress_bar(not quiet, "synthesizing") as progress:
        result = synthesize(
            image,
            extra=extras,
            config=config,
            canvas=Canvas(size, tile=tile, exemplar_wrap=exemplar_wrap, **fields),
            budget=Budget(seed=seed, progress=progress),
        )
    _write_result(result, output, bits, save_reference, quiet)


@option_flags(GenerateOptions)  # (the canvas, the seed and texture-by-numbers' weights)
@with_options(SynthesisConfig, after="bits", into="config", base=TBN_CONFIG)
def tbn_command(
    exemplar: Annotated[Path, typer.Argument(help="Bark photo to learn from.")],
    labels: Annotated[
        Path,
        typer.Option(
            "--labels",
            help="Label map of the exemplar (lossless image, same size; each grey value or colour is a label).",
        ),
    ],
    target: Annotated[Path, typer.Option("--target", help="Label map of the wanted output; sets the output size.")],
    output: OutputOption = Path("barkgen.png"),
    init: Annotated[str, typer.Option("--init", help="Initialisation: smart or random.")] = "smart",
    thin_label: Annotated[
        Optional[list[str]],
        typer.Option(
            "--thin-label",
            help="A label drawn as thin lines, 1-3 px (a crack network's): matched by its proximity "
            "and direction at every level too. Its grey value or r,g,b; repeat for more.",
        ),
    ] = None,
    *,
    label_weight: float,
    feature_weight: float,
    tile: bool,
    seed: int,
    extra: ExtraOption = None,
    save_reference: SaveReferenceOption = None,
    debug_dir: Annotated[
        Optional[Path],
        typer.Option(
            "--debug-dir",
            help="Write the pyramid levels, label maps, initialisation and each "
            "level's result as PNGs into this folder.",
        ),
    ] = None,
    bits: BitsOption = None,
    exemplar_wrap: str,
    flow: FlowOption = None,
    flow_scale: FlowScaleOption = None,
    edges: int,
    quiet: QuietOption = False,
    config: SynthesisConfig,
) -> None:
    """Texture-by-numbers: synthesize bark that follows a target label map."""

    from barkgen.io import read_image
    from barkgen.synth import Budget, Canvas, texture_by_numbers

    extra_paths = parse_extras(extra)
    thin_labels = [_label_value(v) for v in thin_label or ()]
    _check_outputs(output, save_reference, bits, extra_paths)
    if debug_dir is not None:
        check_folder(debug_dir, "--debug-dir")
        refuse_input_folder(debug_dir, "--debug-dir")
    image = read_image(exemplar)
    label_map = read_image(labels)
    target_map = read_image(target)
    if edges:
        label_map, target_map = _with_edges(image, label_map, target_map, edges, tile, exemplar_wrap)
    extras = {name: read_image(p, linear=True) for name, p in extra_paths.items()}  # (a map: kept linear)
    with progress_bar(not quiet, "texture-by-numbers") as progress:
        result = texture_by_numbers(
            image,
            label_map,
            target_map,
            label_weight=label_weight,
            feature_weight=feature_weight,
            init=init,
            thin_labels=thin_labels,
            extra=extras,
            config=config,
            canvas=Canvas(
                target_map.shape[:2], tile=tile, exemplar_wrap=exemplar_wrap, **read_fields(flow, flow_scale)
            ),
            budget=Budget(seed=seed, progress=progress, debug=_debug_writer(debug_dir)),
        )
    _write_result(result, output, bits, save_reference, quiet)


def _label_value(text: str) -> int | tuple[int, ...]:
    """A label's value as ``--thin-label`` gives it: a grey value (``0``) or a colour
    (``200,10,10``)."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (1, 3) or not all(p.isdigit() for p in parts):
        raise InvalidInputError(f"--thin-label must be a grey value or r,g,b, not {text!r}")
    values = tuple(int(p) for p in parts)
    return values[0] if len(values) == 1 else values


def _with_edges(image, label_map, target_map, width: int, tile: bool, exemplar_wraps: str):
    """Both label maps with the edge label (laitoch2018 §3.5.5), numbered against the
    exemplar's labels (grey values or colours) so they share its grey values; the exemplar's
    map wraps where the exemplar does, the target's where the output tiles."""
    import numpy as np

    from barkgen.labels import add_edge_label
    from barkgen.synth import resolve_exemplar_wrap

    def keys(labels: np.ndarray) -> np.ndarray:  # one integer per grey value or colour
        arr = np.asarray(labels).astype(np.int64)
        if arr.ndim == 2:
            return arr
        if arr.shape[2] == 1:
            return arr[..., 0]
        return (arr[..., 0] << 32) | (arr[..., 1] << 16) | arr[..., 2]

    exemplar_keys = keys(label_map)
    wrap = resolve_exemplar_wrap(exemplar_wraps, image)
    edged = add_edge_label(exemplar_keys, width, wrap=wrap)
    return edged, add_edge_label(keys(target_map), width, wrap=tile, values=np.unique(exemplar_keys))


def apply_reference_command(
    reference: Annotated[Path, typer.Argument(help="Reference map written by --save-reference.")],
    map_path: Annotated[Path, typer.Argument(metavar="MAP", help="Map of the exemplar's size.")],
    output: OutputOption,
    bits: Annotated[Optional[int], typer.Option("--bits", help="8 or 16. Default: the map's.")] = None,
    map_kind: Annotated[
        str,
        typer.Option(
            "--map-kind",
            help="What MAP holds, for a reference map made along a flow field (its copies of the "
            "exemplar are turned): image (resampled), labels (nearest pixel) or normals (turned with "
            "the bark). A plain reference map copies any map exactly.",
        ),
    ] = "image",
) -> None:
    """Re-apply a saved reference map to another map of the exemplar (height, normal, ...)."""
    from barkgen.io import read_image, read_reference, read_reference_orientation, write_png
    from barkgen.synth import OrientedExemplar, apply_references

    check_bits(bits)
    check_target(output, "output")
    if map_kind not in ("image", "labels", "normals"):
        raise InvalidInputError(f"--map-kind must be image, labels or normals, not {map_kind!r}")
    refs, ex_shape = read_reference(reference)
    orientation = read_reference_orientation(reference)
    image = read_image(map_path)
    # apply_references only sees that the references fit inside the map; the file also
    # records the exemplar's size, which a map of another (larger) size must not pass
    if ex_shape is not None and image.shape[:2] != ex_shape:
        raise InvalidInputError(
            f"{map_path} is {image.shape[1]}x{image.shape[0]} px but the reference map was made for "
            f"a {ex_shape[1]}x{ex_shape[0]} exemplar"
        )
    if orientation is not None:  # made along a flow field: the map's turned copies
        image = OrientedExemplar.from_dict(orientation).atlas(image, kind=map_kind)
    write_png(output, apply_references(refs, image), bits=bits)


def _extra_output(output: Path, name: str) -> Path:
    """Where an extra map ``name`` of ``output`` is written: OUT_NAME.png beside it."""
    return output.with_name(f"{output.stem}_{name}{output.suffix}")


def _check_outputs(output: Path, save_reference: Path | None, bits: int | None, extras: dict[str, Path]) -> None:
    """Before any work: every file the run will write, the extras' derived names included,
    is a .png, none is an input and no two are the same file."""
    check_bits(bits)
    check_target(output, "output")
    targets = {"output": output}
    targets.update({f"the --extra {name} map's output": _extra_output(output, name) for name in extras})
    if save_reference is not None:
        check_target(save_reference, "--save-reference")
        targets["--save-reference"] = save_reference
    refuse_targets(targets)


def _debug_writer(debug_dir: Path | None):
    """texture_by_numbers' ``debug(name, image)`` writing DIR/NAME.png (None: no pictures)."""
    if debug_dir is None:
        return None
    from barkgen.io import write_png

    def debug(name: str, img) -> None:
        debug_dir.mkdir(parents=True, exist_ok=True)
        write_png(debug_dir / f"{name}.png", img)

    return debug


def _write_result(result, output: Path, bits: int | None, save_reference: Path | None, quiet: bool) -> None:
    """Write a :class:`SynthesisResult`: the image, each extra map beside it, the reference map,
    all encoded first and written as one step."""
    from barkgen.io import encode_png, encode_reference

    files = {output: encode_png(result.image, bits=bits)}
    files.update({_extra_output(output, name): encode_png(arr) for name, arr in result.extras.items()})
    if save_reference is not None:
        oriented = result.orientation
        files[save_reference] = (
            encode_reference(result.references, result.exemplar_shape)
            if oriented is None
            else encode_reference(result.references, oriented.exemplar_shape, orientation=oriented.to_dict())
        )
    write_outputs(files)
    if not quiet:
        t = result.timings
        h, w = result.image.shape[:2]
        wraps = [axis for axis, on in zip(("rows", "columns"), result.exemplar_wrap) if on]
        flat = [
            name
            for name, axes in result.extra_wraps.items()
            if any(e and not m for e, m in zip(result.exemplar_wrap, axes))
        ]
        typer.echo(
            f"wrote {output} ({w}x{h}, seed {result.seed}"
            f"{', tileable' if result.tile else ''}"
            f"{', exemplar wraps ' + ' and '.join(wraps) if wraps else ''}"
            f"{', not wrapped for ' + ', '.join(flat) + ' (its edges do not meet)' if flat else ''}) in "
            f"{t['analysis'] + t['synthesis']:.2f} s",
            err=True,
        )


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (
    ("synth", synth_command),
    ("tbn", tbn_command),
    ("apply-reference", apply_reference_command),
)
