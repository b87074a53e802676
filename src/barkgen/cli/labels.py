"""Label map commands: ``labels`` (colour regions, laitoch2018 §3.5, or merged texton channels,
wang2003 §3.2), ``textons`` (the raw texton channels) and ``merge`` (channels -> label map)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer

from barkgen.cli._common import (
    OutputOption,
    QuietOption,
    check_folder,
    check_target,
    progress_bar,
    refuse_targets,
    write_files,
    write_outputs,
)
from barkgen.cli._options import option_flags
from barkgen.errors import InvalidInputError
from barkgen.pipeline import GenerateOptions


@option_flags(GenerateOptions)  # (the photo's label map as generate makes it)
def labels_command(
    photo: Annotated[Path, typer.Argument(help="Bark photo (PNG, JPEG, TIFF, WebP, TGA, EXR, HDR, PPM, ...).")],
    output: OutputOption,
    *,
    k: int,
    method: str,
    merge_by: Annotated[
        str,
        typer.Option(
            "--merge-by",
            help="With --method texton: group the texton channels by texture (their mean filter "
            "responses, wang2003 §3.2) or colour.",
        ),
    ] = "texture",
    edges: Annotated[bool, typer.Option("--edges", help="Add a label for the region edges (k + 1 labels).")] = False,
    edge_width: Annotated[int, typer.Option("--edge-width", help="Width of the edge band, px.")] = 3,
    exemplar_wrap: str,
    equalize_light: float,
    seed: int,
    preview: Annotated[
        Optional[Path],
        typer.Option("--preview", help="Also write the photo with the label regions tinted and outlined."),
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Make the label map of a bark photo (input of texture-by-numbers)."""
    from barkgen.io import encode_png, image_size, read_image
    from barkgen.labels import add_edge_label, label_preview
    from barkgen.pipeline.labelmaps import photo_label_map
    from barkgen.synth import resolve_exemplar_wrap

    # --method picks the function to call, so it is checked here (k, seed and the edge width
    # by the functions)
    if method not in ("color", "texton"):
        raise InvalidInputError(f"--method must be color or texton, not {method!r}")
    check_target(output, "output")
    if preview is not None:
        check_target(preview, "--preview")
        refuse_targets({"output": output, "--preview": preview})
    if edges:  # a band as wide as the photo covers it whole: refused before the label map is made
        width, height = image_size(photo)
        if edge_width // 2 >= max(width, height):
            raise InvalidInputError(
                f"an edge band {edge_width} px wide covers the whole {width}x{height} photo; give a narrower edge width"
            )
    image = read_image(photo)
    wrap = resolve_exemplar_wrap(exemplar_wrap, image)
    with progress_bar(not quiet, "labelling"):
        extra = {} if method == "color" else {"merge_by": merge_by}
        label_map = photo_label_map(image, k, method, wrap=wrap, equalize_light=equalize_light, seed=seed, **extra)
        if edges:
            label_map = add_edge_label(label_map, edge_width)
        sheet = label_preview(image, label_map) if preview is not None else None
    files = {output: encode_png(label_map)}
    if sheet is not None:
        assert preview is not None  # the sheet is made for a preview
        files[preview] = encode_png(sheet)
    write_outputs(files)  # both or neither (a full disk)
    if not quiet:
        n = len(np.unique(label_map))
        typer.echo(f"wrote {output} ({label_map.shape[1]}x{label_map.shape[0]}, {n} labels)", err=True)


@option_flags(GenerateOptions)
def textons_command(
    photo: Annotated[Path, typer.Argument(help="Bark photo (PNG, JPEG, TIFF, WebP, TGA, EXR, HDR, PPM, ...).")],
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="Output folder.")],
    n_textons: Annotated[int, typer.Option("--textons", help="Number of textons (2-64).")] = 25,
    *,
    exemplar_wrap: str,
    seed: int,
    preview: Annotated[
        Optional[Path],
        typer.Option(
            "--preview", help="Also write every channel over the photo, as one sheet (wang2003 Fig. 4 (c)-(d))."
        ),
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Texton channels of a photo (wang2003 §3.2): OUT/textons.png (texton number per pixel),
    one mask per texton (OUT/texton_NN.png) and a contact sheet (OUT/sheet.png)."""
    from barkgen.io import encode_png, read_image
    from barkgen.labels import channel_previews, contact_sheet, texton_channels
    from barkgen.labels.textons import MAX_TEXTONS
    from barkgen.synth import resolve_exemplar_wrap

    check_folder(output_dir, "output")
    n_files = min(max(n_textons, 0), MAX_TEXTONS)  # (the count itself is checked with the photo)
    names = ["textons.png", "sheet.png"] + [f"texton_{t:02d}.png" for t in range(n_files)]
    targets = {f"output {n}": output_dir / n for n in names}
    if preview is not None:
        check_target(preview, "--preview")
        targets["--preview"] = preview
    refuse_targets(targets)
    image = read_image(photo)
    wrap = resolve_exemplar_wrap(exemplar_wrap, image)
    with progress_bar(not quiet, "textons"):
        textons, _ = texton_channels(image, n_textons, seed=seed, wrap=wrap)
        masks = [np.where(textons == t, 255, 0).astype(np.uint8) for t in range(n_textons)]
        sheet = contact_sheet(masks, [f"texton {t}" for t in range(n_textons)])
        over = None
        if preview is not None:
            shown = [int(t) for t in np.unique(textons)]
            over = contact_sheet(channel_previews(image, textons), [f"texton {t}" for t in shown], tile_size=240)
    files = {"textons.png": encode_png(textons), "sheet.png": encode_png(sheet)}
    files.update({f"texton_{t:02d}.png": encode_png(mask) for t, mask in enumerate(masks)})
    write_files(output_dir, files)
    if over is not None:
        assert preview is not None  # the sheet is made for a preview
        write_outputs({preview: encode_png(over)})
    if not quiet:
        typer.echo(f"wrote {n_textons} texton channels to {output_dir}", err=True)


def merge_command(
    texton_map: Annotated[Path, typer.Argument(help="textons.png written by 'barkgen textons'.")],
    output: OutputOption,
    groups: Annotated[str, typer.Option("--groups", help='Texton numbers of each label, e.g. "0,3,7;1,2;4,5,6".')],
) -> None:
    """Merge raw texton channels into a label map (wang2003 §3.2)."""
    from barkgen.io import read_image, write_png
    from barkgen.labels import merge_channels, parse_groups

    parsed = parse_groups(groups)
    check_target(output, "output")
    write_png(output, merge_channels(read_image(texton_map), parsed))


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (
    ("labels", labels_command),
    ("textons", textons_command),
    ("merge", merge_command),
)
