"""``barkgen branches``: branching structures (cracks, fissures, dried mud; sibbing2010):
extract (§3), grow (§4), render from fragments (§5) and compare statistics (Fig. 7)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer

from barkgen.branching import GrowOptions
from barkgen.cli._common import (
    OutputOption,
    QuietOption,
    check_target,
    progress_bar,
    write_outputs,
)
from barkgen.cli._options import option_flags, with_options
from barkgen.pipeline import GenerateOptions

#: help of the ``branches`` group
HELP = (
    "Branching structures (cracks, fissures, dried mud; sibbing2010): extract a network "
    "from an image, grow new ones, render them from fragments of the image, compare statistics."
)

SourceArgument = Annotated[Path, typer.Argument(metavar="SRC.json", help="Source structure.")]


def extract_command(
    image_path: Annotated[Path, typer.Argument(metavar="IMAGE", help="Image with cracks or fissures.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Structure JSON.")] = Path("source.json"),
    labels: Annotated[
        Optional[Path],
        typer.Option(
            "--labels",
            help="A label map of the image (e.g. from `barkgen labels`); its darkest label "
            "in the image is taken as the fissures.",
        ),
    ] = None,
    step: Annotated[
        Optional[float], typer.Option("--step", help="Resampling step h in pixels (default: from the crack width).")
    ] = None,
    preview: Annotated[
        Optional[Path], typer.Option("--preview", help="Also write a PNG of the structure drawn over the image.")
    ] = None,
    labels_out: Annotated[
        Optional[Path],
        typer.Option(
            "--labels-out",
            help="Also write the image's fissure label map (white cracks on black), "
            "the exemplar labels for texture-by-numbers with a rendered --labels-out as target.",
        ),
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Extract the crack network of an image as a structure (skeleton graph with thickness)."""
    from barkgen.branching import extract_structure, overlay_structure, rasterize
    from barkgen.io import encode_png, read_image
    from barkgen.io.branches import encode_structure

    check_target(output, "output", ".json")
    if preview is not None:
        check_target(preview, "preview")
    if labels_out is not None:
        check_target(labels_out, "--labels-out")
    image = read_image(image_path)
    label_map = read_image(labels) if labels is not None else None
    # the step's range and the label map's size: extract_structure
    structure = extract_structure(image, label_map, step=step)
    files = {output: encode_structure(structure)}
    if preview is not None:
        files[preview] = encode_png(overlay_structure(image, structure))
    if labels_out is not None:
        files[labels_out] = encode_png(rasterize(structure).astype(np.uint8) * 255)
    write_outputs(files)
    if not quiet:
        typer.echo(
            f"wrote {output}: {len(structure.branches)} branches, "
            f"{structure.total_length():.0f} px, {structure.junctions()} junctions, "
            f"step {structure.step:g} px",
            err=True,
        )


@option_flags(GenerateOptions)  # (the output's size and seed)
@with_options(GrowOptions, after="guide")
def grow_command(
    source_path: SourceArgument,
    output: Annotated[Path, typer.Option("-o", "--output", help="Grown structure JSON.")] = Path("grown.json"),
    *,
    size: tuple[int, int],
    guide: Annotated[
        Optional[Path],
        typer.Option(
            "--guide",
            help="Guide map of the output size: branches are drawn to dark values "
            "(a dark valley along a path), roots start where it is dark.",
        ),
    ] = None,
    seed: int,
    quiet: QuietOption = False,
    options: GrowOptions,
) -> None:
    """Grow a new structure with the source's bending, furcation and merge statistics."""
    from barkgen.branching import check_grow_size, fit_model, grow_structure
    from barkgen.io import read_image
    from barkgen.io.branches import encode_structure, read_structure

    check_target(output, "output", ".json")
    h, w = size
    # the options: GrowOptions (the flags); the size's range and the guide map's size: grow_structure
    check_grow_size((w, h), options, guide is not None)  # before the model is fitted
    source = read_structure(source_path)
    guide_map = _grey_unit(read_image(guide)) if guide is not None else None
    model = fit_model(source)
    with progress_bar(not quiet, "growing") as progress:
        grown = grow_structure(model, (w, h), seed=seed, guide=guide_map, options=options, progress=progress)
    write_outputs({output: encode_structure(grown)})
    if not quiet:
        typer.echo(
            f"wrote {output}: {len(grown.branches)} branches, {grown.total_length():.0f} px, "
            f"{grown.junctions()} junctions",
            err=True,
        )


def _grey_unit(image: np.ndarray) -> np.ndarray:
    """An image as a float32 ``(H, W)`` map in [0, 1] (colour averaged)."""
    scale = 65535.0 if image.dtype == np.uint16 else 255.0
    grey = image.astype(np.float32) / scale
    return grey.mean(axis=2) if grey.ndim == 3 else grey


@option_flags(GenerateOptions)  # (the seed)
def render_command(
    image_path: Annotated[Path, typer.Argument(metavar="IMAGE", help="The source image.")],
    source_path: Annotated[Path, typer.Argument(metavar="SRC.json", help="Its structure.")],
    target_path: Annotated[Path, typer.Argument(metavar="DST.json", help="The structure to render.")],
    output: OutputOption = Path("branches.png"),
    labels_out: Annotated[
        Optional[Path],
        typer.Option(
            "--labels-out",
            help="Also write the fissure label map of the output (white cracks on black) for texture-by-numbers.",
        ),
    ] = None,
    *,
    seed: int,
    quiet: QuietOption = False,
) -> None:
    """Render a structure from fragments of the source image; the core engine fills the gaps."""
    from barkgen.branching import render_branches
    from barkgen.io import encode_png, read_image
    from barkgen.io.branches import read_structure

    check_target(output, "output")
    if labels_out is not None:
        check_target(labels_out, "--labels-out")
    image = read_image(image_path)
    source = read_structure(source_path)
    target = read_structure(target_path)
    # the source structure's size against the image's: render_branches
    with progress_bar(not quiet, "rendering") as progress:
        result = render_branches(image, source, target, seed=seed, progress=progress)
    files = {output: encode_png(result.image)}
    if labels_out is not None:
        files[labels_out] = encode_png(result.labels)
    write_outputs(files)


def stats_command(
    source_path: SourceArgument,
    target_path: Annotated[Path, typer.Argument(metavar="DST.json", help="Grown structure.")],
    plot: Annotated[
        Optional[Path], typer.Option("--plot", help="Histogram plot PNG (default: DST_stats.png beside DST.json).")
    ] = None,
) -> None:
    """Angle and thickness histograms of two structures side by side (sibbing2010 Fig. 7)."""
    from rich.console import Console

    from barkgen.branching import compare_structures, comparison_plot
    from barkgen.io import encode_png
    from barkgen.io.branches import read_structure

    plot = plot if plot is not None else target_path.with_name(f"{target_path.stem}_stats.png")
    check_target(plot, "--plot")
    cmp = compare_structures(read_structure(source_path), read_structure(target_path))
    console = Console()
    for table in _histogram_tables(cmp):
        console.print(table)
    console.print(
        f"L1 angle {cmp.angle_l1:.3f}   L1 thickness {cmp.thickness_l1:.3f}   "
        f"L1 direction {cmp.heading_l1:.3f}   "
        f"junctions per Mpx {cmp.source_junction_density:.0f} -> {cmp.target_junction_density:.0f}   "
        f"free ends per Mpx {cmp.source_free_end_density:.0f} -> {cmp.target_free_end_density:.0f}   "
        f"length per px {cmp.source_length_density:.4f} -> {cmp.target_length_density:.4f}   "
        f"intersections {cmp.target_intersections}",
        highlight=False,
    )
    write_outputs({plot: encode_png(comparison_plot(cmp))})


def _histogram_tables(cmp) -> list:
    """The turning-angle and thickness histograms of a :class:`StructureComparison` as rich
    tables: bin, source, target and two bars."""
    from rich.table import Table

    tables = []
    for title, edges, src, dst, fmt in (
        ("turning angle (degrees)", np.degrees(cmp.angle_edges), cmp.source_angles, cmp.target_angles, "{:+.1f}"),
        ("thickness (px)", cmp.thickness_edges, cmp.source_thickness, cmp.target_thickness, "{:.2f}"),
    ):
        table = Table(title=title, title_justify="left")
        table.add_column("bin")
        table.add_column("source", justify="right")
        table.add_column("target", justify="right")
        table.add_column("source | target", no_wrap=True)
        for i in range(len(src)):
            bar = "#" * int(round(src[i] * 60))
            bar2 = "#" * int(round(dst[i] * 60))
            table.add_row(
                f"{fmt.format(edges[i])} .. {fmt.format(edges[i + 1])}",
                f"{src[i]:.3f}",
                f"{dst[i]:.3f}",
                f"{bar:<20.20}|{bar2:<20.20}",
            )
        tables.append(table)
    return tables


#: (command name, function) of the group, in the order of ``barkgen branches --help``
COMMANDS = (
    ("extract", extract_command),
    ("grow", grow_command),
    ("render", render_command),
    ("stats", stats_command),
)
