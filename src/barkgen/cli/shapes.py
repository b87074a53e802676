"""Label map synthesis: ``shapes``, a new label map of any size from an exemplar's
(laitoch2018 §3.6; the layered strategy of rosenberger2009)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from barkgen.cli._common import (
    OutputOption,
    QuietOption,
    ResumeOption,
    SaveLevelsOption,
    check_folder,
    check_target,
    level_files,
    progress_bar,
    read_resume,
    refuse_input_folder,
    write_outputs,
)
from barkgen.cli._options import option_flags
from barkgen.errors import InvalidInputError
from barkgen.pipeline import GenerateOptions


@option_flags(GenerateOptions)  # (the canvas, the strategy, the seed and the memory)
def shapes_command(
    labels: Annotated[Path, typer.Argument(help="Label map of the exemplar (lossless, grey).")],
    output: OutputOption,
    *,
    size: tuple[int, int],
    strategy: str = "engine",
    photo: Annotated[
        Optional[Path],
        typer.Option(
            "--photo", help="The photo the label map belongs to (the joint strategy matches its colours too)."
        ),
    ] = None,
    rotations: str,
    layer_order: Annotated[
        Optional[str],
        typer.Option(
            "--layer-order",
            help='Layered strategy: grey values bottom layer first, e.g. "255,0,128" (default: automatic).',
        ),
    ] = None,
    tile: bool,
    seed: int,
    save_levels: SaveLevelsOption = None,
    resume: ResumeOption = None,
    exemplar_wrap: str,
    max_memory: int | None,
    quiet: QuietOption = False,
) -> None:
    """Synthesize a new label map of any size from an exemplar's label map (laitoch2018 §3.6)."""
    from barkgen.io import encode_png, read_image
    from barkgen.shapes import Budget, Canvas, synthesize_label_map
    from barkgen.synth import resolve_exemplar_wrap

    out_shape, memory = size, max_memory
    check_target(output, "output")
    if save_levels is not None:
        check_folder(save_levels, "--save-levels")
        refuse_input_folder(save_levels, "--save-levels")
    order = _parse_layer_order(layer_order)
    # synthesize_label_map ignores a photo the strategy does not use: say so instead
    if photo is not None and strategy != "joint":
        raise InvalidInputError("--photo is for --strategy joint")
    label_map = read_image(labels)
    photo_image = read_image(photo) if photo is not None else None
    edited = read_resume(resume) if resume is not None else None
    # "auto" is decided on the photo (or the label map) by synthesize_label_map
    wrap = None if exemplar_wrap == "auto" else resolve_exemplar_wrap(exemplar_wrap, label_map)
    with progress_bar(not quiet, "label map") as progress:
        result = synthesize_label_map(
            label_map,
            out_shape,
            strategy=strategy,
            photo=photo_image,
            canvas=Canvas(out_shape, tile=tile, exemplar_wrap=wrap),
            budget=Budget(seed=seed, max_memory=memory, progress=progress),
            rotations=rotations,
            layer_order=order,
            resume=edited,
        )
    levels: dict[Path, bytes] = {}
    if save_levels is not None:
        levels = {save_levels / n: d for n, d in level_files(result.levels).items()}
    write_outputs({output: encode_png(result.label_map)} | levels)
    if not quiet:
        typer.echo(
            f"wrote {output} ({out_shape[1]}x{out_shape[0]}, {strategy}) in {result.timings['label_map']:.2f} s",
            err=True,
        )


def _parse_layer_order(text: str | None) -> list[int] | None:
    """``"255,0,128"`` -> ``[255, 0, 128]`` (whether they are the map's labels is the API's
    check)."""
    if text is None:
        return None
    try:
        return [int(v) for v in text.split(",")]
    except ValueError:
        raise InvalidInputError(f"invalid --layer-order {text!r}: expected grey values such as 255,0,128") from None


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (("shapes", shapes_command),)
