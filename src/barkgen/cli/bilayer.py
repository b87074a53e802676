"""``barkgen bilayer``: bi-layer textures (guingo2017), a structure layer plus spatially varying
stationary noise, analysed once and synthesized window by window without bounds."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer

from barkgen._shared.checks import parse_size
from barkgen.bilayer import AnalysisOptions, SynthesisOptions
from barkgen.cli._common import (
    FlowOption,
    FlowScaleOption,
    OutputOption,
    QuietOption,
    check_bits,
    check_file_name,
    check_target,
    parse_pair,
    progress_bar,
    read_fields,
    write_outputs,
)
from barkgen.cli._options import option_flags, with_options

#: help of the ``bilayer`` group
HELP = (
    "Bi-layer textures (guingo2017): structure + spatially varying noise, synthesized window by window without bounds."
)

PhotoArgument = Annotated[Optional[Path], typer.Argument(help="Exemplar photo. Default: the bundled sample.")]


@with_options(AnalysisOptions, after="output")
def analyze_command(
    photo: PhotoArgument = None,
    output: Annotated[Path, typer.Option("-o", "--output", help="Model file (.npz).")] = Path("bark.npz"),
    preview: Annotated[
        Optional[Path],
        typer.Option("--preview", help="Also write a PNG of P, N, the masks, the spectra and a synthesized sample."),
    ] = None,
    quiet: QuietOption = False,
    *,
    options: AnalysisOptions,
) -> None:
    """Analyse a photo into a bi-layer model: structure P, masks M_k, noise spectra S_k."""
    from barkgen.bilayer import analysis_preview, analyze
    from barkgen.data import sample_exemplar_path
    from barkgen.io import encode_bilayer_model, encode_png, read_image

    # K, T_loc, the masks, the border and sigma: AnalysisOptions (the flags)
    check_file_name(output, ".npz", "model file")
    if preview is not None:
        check_target(preview, "preview")
    image = read_image(photo if photo is not None else sample_exemplar_path())
    with progress_bar(not quiet, "analysing") as progress:
        model = analyze(image, options, progress=progress)
    files = {output: encode_bilayer_model(model)}
    if preview is not None:
        h, w = model.exemplar.shape[:2]
        files[preview] = encode_png(analysis_preview(model, model.window(0, 0, 2 * w, h, seed=options.seed)))
    write_outputs(files)
    if not quiet:
        typer.echo(
            f"wrote {output} (K={options.k}, T_loc={options.tloc}, noise std {float(model.noise_layer.std()):.3f})",
            err=True,
        )


@option_flags(AnalysisOptions)
def tune_command(
    photo: PhotoArgument = None,
    output: Annotated[Path, typer.Option("-o", "--output", help="Sheet PNG.")] = Path("tune.png"),
    *,
    k: int,
    seed: int,
    quiet: QuietOption = False,
) -> None:
    """The T_loc choice sheet (guingo2017 Fig. 14): for T_loc = 2, 4, 8, 16 the structure P,
    the noise N and P with new noise synthesized under its masks. Pick the largest T_loc that
    still looks right."""
    from barkgen.bilayer import tune_sheet
    from barkgen.data import sample_exemplar_path
    from barkgen.io import encode_png, read_image

    check_target(output, "output")
    options = AnalysisOptions(k=k, seed=seed)
    image = read_image(photo if photo is not None else sample_exemplar_path())
    with progress_bar(not quiet, "analysing") as progress:
        sheet = tune_sheet(image, options, seed=seed, progress=progress)
    write_outputs({output: encode_png(sheet)})


@option_flags(AnalysisOptions)  # (the window's seed)
@with_options(SynthesisOptions, after="keep_vertical")
def synth_command(
    model_path: Annotated[Path, typer.Argument(metavar="MODEL", help="Model file from `bilayer analyze`.")],
    output: OutputOption = Path("bilayer.png"),
    size: Annotated[str, typer.Option("--size", help="Window size WIDTHxHEIGHT.")] = "1024x1024",
    offset: Annotated[
        str,
        typer.Option(
            "--offset",
            help="Window position X,Y in the unbounded texture (windows of one seed agree where they overlap).",
        ),
    ] = "0,0",
    rotate: Annotated[
        float, typer.Option("--rotate", help="Rotate the structure's pieces by up to DEG_MAX degrees (0-180).")
    ] = 0.0,
    scale: Annotated[str, typer.Option("--scale", help="Zoom the structure's pieces by MIN,MAX.")] = "1,1",
    keep_vertical: Annotated[
        bool,
        typer.Option("--keep-vertical", help="Rotate pieces only about the upright (0 or 180 degrees, plus --rotate)."),
    ] = False,
    flow: FlowOption = None,
    flow_scale: FlowScaleOption = None,
    bits: Annotated[int, typer.Option("--bits", help="Bits per channel (8 or 16).")] = 8,
    *,
    seed: int,
    options: SynthesisOptions,
) -> None:
    """Synthesize a window of the unbounded bi-layer texture of a model. Rotations, zooms and
    the --flow/--flow-scale fields turn each tile's exchanged content as the window is made."""
    from barkgen.bilayer import Deformation
    from barkgen.io import encode_png, read_bilayer_model

    out_shape = parse_size(size)
    x, y = parse_pair(offset, "--offset", int)
    lo, hi = parse_pair(scale, "--scale")
    check_bits(bits)
    check_target(output, "output")
    # the tile size, warp and deformation ranges: SynthesisOptions and Deformation
    options = dataclasses.replace(
        options, deformation=Deformation(rotate=rotate, scale=(lo, hi), keep_vertical=keep_vertical)
    )
    fields = read_fields(flow, flow_scale)
    model = read_bilayer_model(model_path)
    image = model.window(x, y, out_shape[1], out_shape[0], seed=seed, options=options, **fields)
    image16 = (image * 65535.0 + 0.5).astype(np.uint16)
    write_outputs({output: encode_png(image16, bits=bits)})


#: (command name, function) of the group, in the order of ``barkgen bilayer --help``
COMMANDS = (
    ("analyze", analyze_command),
    ("tune", tune_command),
    ("synth", synth_command),
)
