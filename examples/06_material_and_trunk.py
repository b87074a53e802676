"""Material maps of new bark and a trunk to look at them on (:mod:`barkgen.material`,
:mod:`barkgen.render`; wang2003 §3.3-3.4).

:func:`barkgen.make_material` estimates the photo's height, normals, ambient occlusion,
roughness and albedo (its shading removed) from the photo alone;
:func:`barkgen.material.transfer_material` carries that set through a synthesis's reference
map, so the new bark gets maps aligned with it pixel for pixel (and tileable when it tiles).
:func:`barkgen.io.encode_material` encodes the set with ambientCG file names,
:func:`barkgen.render_trunk` renders it on a trunk (CPU only) and, when the ``[gltf]`` extra
(trimesh) is installed, :func:`barkgen.trunk_mesh` + :func:`barkgen.io.encode_glb` make a
glTF 2.0 trunk; without it that step is skipped with a message.

Run::

    python examples/06_material_and_trunk.py OUTDIR

Writes ``OUTDIR/bark/`` (the set named asset, variant and size as an artist's library expects,
:mod:`barkgen.io.asset_names`: ``sample_bark_seed7_128x128_Color.png``, ``..._NormalGL.png``,
``..._NormalDX.png``, ``..._Displacement.png``, ``..._Roughness.png``, ``..._AmbientOcclusion.png``,
``sample_bark_seed7_128x128.json``, ``..._blender.py``), ``OUTDIR/trunk_preview.png`` (192x192) and ``OUTDIR/trunk.glb`` (with ``[gltf]``).
"""

import sys
from pathlib import Path

import barkgen
import barkgen.errors
import barkgen.io
import barkgen.material


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    photo = barkgen.read_image(barkgen.sample_exemplar_path())[:128, :128]
    photo_material = barkgen.make_material(photo, barkgen.MaterialOptions(k=3, seed=0))

    synthesis = barkgen.synthesize(photo, 128, tile=True, seed=7)
    material = barkgen.material.transfer_material(
        photo_material,
        synthesis.references,
        barkgen.Canvas(synthesis.references.shape[:2], tile=True, exemplar_wrap=synthesis.exemplar_wrap),
    )
    name = barkgen.io.material_set_name(barkgen.io.base_name("sample_bark", "seed7"), material.shape)
    files = barkgen.io.encode_material(material, name, asset="sample_bark", seed=7, source_photo="sample_bark.jpg")
    barkgen.io.write_folder_atomic(out_dir / "bark", files)

    preview = barkgen.render_trunk(material, (192, 192))
    barkgen.write_png(out_dir / "trunk_preview.png", preview)
    try:
        glb = barkgen.io.encode_glb(barkgen.trunk_mesh(material, segments=32), material)
    except barkgen.errors.MissingExtraError as exc:
        print(f"no glTF trunk: {exc}")
    else:
        (out_dir / "trunk.glb").write_bytes(glb)
    made = "material set, trunk preview" + (" and trunk.glb" if (out_dir / "trunk.glb").exists() else "")
    print(f"{made} in {out_dir}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "examples_out/06_material_and_trunk"))
