"""Material sets and their trunk: ``material`` (height, normals, AO, roughness and the colour
with its shading removed, wang2003 §3.3-3.4), ``preview`` (the set rendered on a trunk) and
``export-glb`` (the trunk as glTF 2.0)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated, Optional

import typer

from barkgen._shared.checks import parse_size
from barkgen.cli._common import (
    EditsOption,
    ExrHeightOption,
    LicenceOption,
    NameOption,
    OutputOption,
    PresetOption,
    QuietOption,
    check_file_name,
    check_folder,
    check_target,
    parse_light,
    photo_licence,
    progress_bar,
    read_edits,
    refuse_targets,
    set_variant,
    write_files,
    write_outputs,
)
from barkgen.cli._options import with_options
from barkgen.material import MaterialOptions

ViewRepeat = Annotated[float, typer.Option("--repeat", help="Times the texture goes round the trunk.")]
ViewDisplacement = Annotated[float, typer.Option("--displacement", help="Relief scale (1 = the set's own depth).")]
GlbRepeat = Annotated[
    Optional[float],
    typer.Option(
        "--repeat",
        help="Times the texture goes round the trunk (radius 0.15 m). Default: the set at its real size "
        "(NAME.json's width_m: the circumference over the width, rounded to a whole number), else 2.",
    ),
]


@with_options(MaterialOptions, after="exr_height")
def material_command(
    photo: Annotated[Optional[Path], typer.Argument(help="Bark photo. Default: the bundled sample.")] = None,
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="Output folder.")] = Path("material"),
    name: NameOption = None,
    licence: LicenceOption = None,
    preset: PresetOption = "ambientcg",
    exr_height: ExrHeightOption = False,
    edits: EditsOption = None,
    tile: Annotated[
        bool, typer.Option("--tile", help="The photo is a tileable texture: maps wrap (as --exemplar-wraps yes).")
    ] = False,
    quiet: QuietOption = False,
    *,
    options: MaterialOptions,
) -> None:
    """The material set of a photo: height, normals (OpenGL and DirectX), AO, roughness and the
    colour with its shading removed (wang2003 §3.3-3.4), in ambientCG names."""
    import time

    from barkgen.data import sample_exemplar_path
    from barkgen.io import base_name, check_material_name, encode_material, image_size, material_set_name, read_image
    from barkgen.io.material import material_file_names
    from barkgen.material import EditList, adjust_material, make_material
    from barkgen.material.presets import check_preset

    if name is not None:
        check_material_name(name)
    check_preset(preset)
    check_folder(output_dir, "output")
    # the options: MaterialOptions (the flags); edits outside the photo: the height editor
    if tile:
        options = dataclasses.replace(options, exemplar_wrap="yes")
    # the edit list before the refusals only when the set's name needs its tag (a named set's
    # files are refused first, whatever the list holds)
    edit_list = read_edits(edits) if edits is not None and name is None else None
    src = photo if photo is not None else sample_exemplar_path()
    w, h = image_size(src)
    asset, variant = _asset_and_variant(name, src, edit_list or EditList())
    set_name = material_set_name(base_name(asset, variant), (h, w))
    refuse_targets({f"output {n}": output_dir / n for n in material_file_names(set_name, preset)})
    if edit_list is None:
        edit_list = read_edits(edits) if edits is not None else EditList()
    image = read_image(src)
    h, w = image.shape[:2]
    start = time.perf_counter()
    with progress_bar(not quiet, "material") as progress:
        material = make_material(image, options, edits=edit_list.edits)
        if edit_list.adjusts:  # the edit list's depth and light, after its edits
            material = adjust_material(material, relief=edit_list.relief, equalization=edit_list.light_equalization)
        if progress:
            progress(1, 1)
    files = encode_material(
        material,
        set_name,
        preset,
        exr_height=exr_height,
        asset=asset,
        variant=variant,
        seed=options.seed,
        source_photo=str(src),
        source_licence=photo_licence(licence, photo),
        edits=len(edit_list.edits),
        exemplar_wrap_mode=options.exemplar_wrap,
    )
    write_files(output_dir, files)
    if not quiet:
        lt = material.light
        assert lt is not None  # make_material sets the light it used
        typer.echo(
            f"wrote {output_dir}/{set_name}_*.png ({w}x{h}; light {lt.azimuth:g},{lt.elevation:g}; "
            f"depth {material.depth:.1f} px = {1000 * material.physical_size()['displacement_depth_m']:.1f} mm"
            f"{_wrap_note(material.wraps)}) in {time.perf_counter() - start:.1f} s",
            err=True,
        )


def _asset_and_variant(name: str | None, src: Path, edit_list) -> tuple[str, str | None]:
    """The set's asset name and variant (:mod:`barkgen.io.asset_names`): ``--name`` as given,
    else the photo's name, with the edit list's tag when it has edits (a photo has one set
    of its own; an edited one is another)."""
    from barkgen.io import photo_asset_name

    return (name, None) if name is not None else (photo_asset_name(src), set_variant(None, edit_list))


def _wrap_note(wraps: tuple[bool, bool]) -> str:
    """``; wraps left-right`` and the like: the axes along which the maps tile."""
    names = [name for name, on in zip(("top-bottom", "left-right"), wraps) if on]
    return f"; wraps {' and '.join(names)}" if names else ""


def preview_command(
    folder: Annotated[Path, typer.Argument(help="Material set folder (barkgen material / generate --material).")],
    output: OutputOption = Path("preview.png"),
    size: Annotated[str, typer.Option("--size", help="Image size WIDTHxHEIGHT.")] = "1024x1024",
    light: Annotated[str, typer.Option("--light", help="Light AZ,EL in degrees.")] = "135,35",
    repeat: ViewRepeat = 2.0,
    displacement: ViewDisplacement = 1.0,
) -> None:
    """Render the set on a trunk (displaced cylinder, normal-mapped, lit; CPU only)."""
    from barkgen.io import encode_png, find_material, read_material

    out_shape = parse_size(size)
    check_target(output, "output")
    parsed_light = parse_light(light)
    find_material(folder)  # a wrong folder refused before the renderer's kernels load
    from barkgen.render import TrunkView, render_trunk

    view = TrunkView(repeat=repeat, displacement=displacement, light=parsed_light)
    material, _ = read_material(folder)
    write_outputs({output: encode_png(render_trunk(material, out_shape, view))})


def export_glb_command(
    folder: Annotated[Path, typer.Argument(help="Material set folder.")],
    output: Annotated[
        Optional[Path], typer.Option("-o", "--output", help="Output .glb. Default: SET_trunk.glb (the set's name).")
    ] = None,
    repeat: GlbRepeat = None,
    displacement: ViewDisplacement = 1.0,
    segments: Annotated[int, typer.Option("--segments", help="Vertices around the trunk.")] = 256,
) -> None:
    """Write a glTF 2.0 trunk: the relief in the geometry (in metres at the set's real size),
    colour, normal and occlusion-roughness-metallic textures."""
    from barkgen.io import encode_glb, find_material, library_file_name, read_material

    if output is not None:
        check_file_name(output, ".glb", "output")
    set_name = find_material(folder)[0]  # a wrong folder refused before the renderer's kernels load
    if output is None:  # named as the set is (oak_seed7_2K_trunk.glb), in the current folder
        output = Path(library_file_name(set_name, "trunk.glb"))
        check_file_name(output, ".glb", "output")
    from barkgen.render import TrunkView, trunk_mesh

    view = TrunkView(repeat=repeat, displacement=displacement)
    material, _ = read_material(folder)
    write_outputs({output: encode_glb(trunk_mesh(material, segments=segments, view=view), material)})


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (
    ("material", material_command),
    ("preview", preview_command),
    ("export-glb", export_glb_command),
)
