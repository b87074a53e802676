"""``barkgen tree``: bark for a whole tree mesh (:func:`barkgen.pipeline.make_tree`)."""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path
from typing import Annotated, Optional

import typer

from barkgen.cli._common import (
    BitsOption,
    LicenceOption,
    NameOption,
    PresetOption,
    QuietOption,
    check_bits,
    check_folder,
    photo_licence,
    previous_run_files,
    progress_bar,
    refuse_inputs,
    write_run,
)
from barkgen.cli._options import with_options
from barkgen.pipeline import GenerateOptions

#: files of a tree run beyond generate's
TREE_FILES = ("tree.glb", "tree_preview.png")


@with_options(GenerateOptions)
def tree_command(
    mesh: Annotated[
        Optional[Path],
        typer.Argument(
            help="Tree mesh with UVs (glTF/GLB or OBJ; a mesh without UVs is unwrapped by xatlas). Default: the "
            "built-in tree (a trunk with two branches and a twig, smooth collars; --seed varies it)."
        ),
    ] = None,
    photo: Annotated[
        Optional[Path],
        typer.Option(
            "--photo", help="Bark photo whose upright fissures follow the branches. Default: the bundled sample."
        ),
    ] = None,
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="Output folder.")] = Path("tree"),
    bark_width: Annotated[
        Optional[float],
        typer.Option(
            "--bark-width",
            min=0.0,
            help="Metres of bark the photo's width shows (default: the bark at the photo's own resolution in "
            "the atlas).",
        ),
    ] = None,
    scale_with_radius: Annotated[
        bool,
        typer.Option("--scale-with-radius", help="Wider plates where the branch is thicker (the built-in tree)."),
    ] = False,
    bits: BitsOption = None,
    name: NameOption = None,
    licence: LicenceOption = None,
    preset: PresetOption = "ambientcg",
    quiet: QuietOption = False,
    *,
    options: GenerateOptions,
) -> None:
    """Bark for a whole tree: the mesh's UV atlas synthesized along its branches (fissures follow
    each branch and turn through its collar), the two sides of every chart border one piece of
    bark on the surface. Writes generate's files for the atlas (--size is the atlas's; never
    tileable), its material set, tree.glb (the mesh with the set's textures) and
    tree_preview.png (four views) into the output folder."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import (
        base_name,
        check_material_name,
        material_set_name,
        photo_asset_name,
        read_image,
        variant_name,
    )
    from barkgen.material.presets import check_preset

    check_bits(bits)
    check_folder(output_dir, "output")
    check_preset(preset)
    options = dataclasses.replace(options, material=True, tile=False)
    if name is not None:
        check_material_name(name)
    src = photo if photo is not None else sample_exemplar_path()
    asset, variant = (name, None) if name is not None else (photo_asset_name(src), variant_name(options.seed))
    set_name = material_set_name(base_name(asset, variant), options.size)
    stale = previous_run_files(output_dir)
    refuse_inputs(_targets(output_dir, set_name, preset, stale))
    image = read_image(src)
    # (the pipeline's and the mesh's imports after the checks: a refusal needs neither)
    from barkgen.pipeline import encode_tree, make_tree, stage_at
    from barkgen.tree import read_tree_mesh

    tree_mesh = read_tree_mesh(mesh, resolution=max(options.size)) if mesh is not None else None
    describe = functools.partial(stage_at, material=True)
    with progress_bar(not quiet, "growing bark", describe) as progress:
        tree = make_tree(
            image,
            options,
            mesh=tree_mesh,
            bark_width_m=bark_width,
            scale_with_radius=scale_with_radius,
            progress=progress,
        )
        licence = photo_licence(licence, photo)
        files = encode_tree(
            image, tree, str(src), name=asset, variant=variant, licence=licence, bits=bits, preset=preset
        )
    write_run(output_dir, files, stale)
    if not quiet:
        h, w = tree.result.texture.shape[:2]
        typer.echo(
            f"wrote {output_dir}/tree.glb ({len(tree.mesh.faces)} triangles, a {w}x{h} atlas, seed {options.seed}) "
            f"and its maps in {tree.result.report['timings_s']['total']:.1f} s",
            err=True,
        )


def _targets(folder: Path, name: str, preset: str, stale) -> list[Path]:
    """The files of ``folder`` a tree run writes or removes: none may be an input."""
    from barkgen.io.material import material_file_names
    from barkgen.pipeline import GENERATE_FILES

    names = {f"{n}.png" for n in GENERATE_FILES} | {"report.json"} | set(TREE_FILES) | set(stale)
    names |= set(material_file_names(name, preset))
    return [folder / n for n in sorted(names)]


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (("tree", tree_command),)
