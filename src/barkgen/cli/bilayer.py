"""``barkgen bilayer``: bi-layer textures (guingo2017), a structure layer plus spatially varying
stationary noise, analysed once and synthesized window by window without bounds."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer

from barkgen._shared.checks import parse_size
from barkgen._shared.memory import parse_memory
from barkgen.cli._common import (
    FlowOption,
    FlowScaleOption,
    MaxMemoryOption,
    OutputOption,
    QuietOption,
    SeedOption,
    check_bits,
    check_file_name,
    check_target,
    parse_pair,
    progress_bar,
    read_fields,
    write_outputs,
)

#: help of the ``bilayer`` group
HELP = (
    "Bi-layer textures (guingo2017): structure + spatially varying noise, synthesized window by window without bounds."
)

TlocOption = Annotated[
    int,
    typer.Option(
        "--tloc",
        help="Local spectrum window: 2, 4, 8 or 16 px (larger: more goes into the noise; see `barkgen bilayer tune`).",
    ),
]
NoisesOption = Annotated[int, typer.Option("--k", help="Number of stationary noises (clusters), 1-8.")]
PhotoArgument = Annotated[Optional[Path], typer.Argument(help="Exemplar photo. Default: the bundled sample.")]


def analyze_command(
    photo: PhotoArgument = None,
    output: Annotated[Path, typer.Option("-o", "--output", help="Model file (.npz).")] = Path("bark.npz"),
    k: NoisesOption = 2,
    tloc: TlocOption = 4,
    masks: Annotated[str, typer.Option("--masks", help="binary or barycentric.")] = "binary",
    equalize: Annotated[
        bool, typer.Option("--equalize", help="Equalise the noise's histogram per cluster (non-Gaussian noise, §6).")
    ] = False,
    border: Annotated[
        int, typer.Option("--border", help="Band (px) along mask borders kept sharp in the structure (§6); 0: none.")
    ] = 0,
    sigma: Annotated[
        float,
        typer.Option(
            "--sigma", help="Range sigma of the structure filter (larger: more of the grain goes into the noise)."
        ),
    ] = 0.001,
    seed: SeedOption = 0,
    max_memory: MaxMemoryOption = None,
    preview: Annotated[
        Optional[Path],
        typer.Option("--preview", help="Also write a PNG of P, N, the masks, the spectra and a synthesized sample."),
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Analyse a photo into a bi-layer model: structure P, masks M_k, noise spectra S_k."""
    from barkgen.bilayer import AnalysisOptions, analysis_preview, analyze
    from barkgen.data import sample_exemplar_path
    from barkgen.io import encode_bilayer_model, encode_png, read_image

    # K, T_loc, the masks, the border and sigma: AnalysisOptions
    options = AnalysisOptions(
        k=k,
        tloc=tloc,
        masks=masks,
        equalize=equalize,
        border=border,
        sigma_range=sigma,
        seed=seed,
        max_memory=parse_memory(max_memory),
    )
    check_file_name(output, ".npz", "model file")
    if preview is not None:
        check_target(preview, "preview")
    image = read_image(photo if photo is not None else sample_exemplar_path())
    with progress_bar(not quiet, "analysing") as progress:
        model = analyze(image, options, progress=progress)
    files = {output: encode_bilayer_model(model)}
    if preview is not None:
        h, w = model.exemplar.shape[:2]
        files[preview] = encode_png(analysis_preview(model, model.window(0, 0, 2 * w, h, seed=seed)))
    write_outputs(files)
    if not quiet:
        typer.echo(f"wrote {output} (K={k}, T_loc={tloc}, noise std {float(model.noise_layer.std()):.3f})", err=True)


def tune_command(
    photo: PhotoArgument = None,
    output: Annotated[Path, typer.Option("-o", "--output", help="Sheet PNG.")] = Path("tune.png"),
    k: NoisesOption = 2,
    seed: SeedOption = 0,
    quiet: QuietOption = False,
) -> None:
    """The T_loc choice sheet (guingo2017 Fig. 14): for T_loc = 2, 4, 8, 16 the structure P,
    the noise N and P with new noise synthesized under its masks. Pick the largest T_loc that
    still looks right."""
    from barkgen.bilayer import AnalysisOptions, tune_sheet
    from barkgen.data import sample_exemplar_path
    from barkgen.io import encode_png, read_image

    check_target(output, "output")
    options = AnalysisOptions(k=k, seed=seed)
    image = read_image(photo if photo is not None else sample_exemplar_path())
    with progress_bar(not quiet, "analysing") as progress:
        sheet = tune_sheet(image, options, seed=seed, progress=progress)
    write_outputs({output: encode_png(sheet)})


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
    tile_size: Annotated[
        Optional[int], typer.Option("--tile-size", help="Wang tile size in px (default: a quarter of the exemplar).")
    ] = None,
    warp: Annotated[
        float, typer.Option("--warp", help="Turbulence bending the tile grid, in tile sizes (0-1; 0: none).")
    ] = 0.1,
    compensate: Annotated[
        bool,
        typer.Option(
            "--compensate/--no-compensate",
            help="With --rotate or "
            "--scale, give the noise the fine detail the deformed "
            "structure lost (--no-compensate: the paper's noise).",
        ),
    ] = True,
    blend: Annotated[
        bool,
        typer.Option(
            "--blend/--no-blend", help="Blend the tiles' seams in the gradient domain (--no-blend: graph cuts only)."
        ),
    ] = True,
    flow: FlowOption = None,
    flow_scale: FlowScaleOption = None,
    seed: SeedOption = 0,
    bits: Annotated[int, typer.Option("--bits", help="Bits per channel (8 or 16).")] = 8,
    max_memory: MaxMemoryOption = None,
) -> None:
    """Synthesize a window of the unbounded bi-layer texture of a model. Rotations, zooms and
    the --flow/--flow-scale fields turn each tile's exchanged content as the window is made."""
    from barkgen.bilayer import Deformation, SynthesisOptions
    from barkgen.io import encode_png, read_bilayer_model

    out_shape = parse_size(size)
    x, y = parse_pair(offset, "--offset", int)
    lo, hi = parse_pair(scale, "--scale")
    check_bits(bits)
    check_target(output, "output")
    # the tile size, warp and deformation ranges: SynthesisOptions and Deformation
    options = SynthesisOptions(
        tile_size=tile_size,
        warp=warp,
        compensate=compensate,
        blend=blend,
        deformation=Deformation(rotate=rotate, scale=(lo, hi), keep_vertical=keep_vertical),
        max_memory=parse_memory(max_memory),
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
