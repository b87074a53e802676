"""A textured tree from one bark photo: the mesh (the user's or the built-in tree), the flow and
scale fields of its UV atlas, the bark atlas synthesized along them with its material set, the
two sides of every chart border made one piece of bark, and the files an artist takes away
(mazzolini2012 §3.1.3, §3.1.4, §4.2).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from barkgen._shared.arrays import ProgressCallback
from barkgen._shared.canvas import Canvas
from barkgen.pipeline.core import GenerateResult, generate
from barkgen.pipeline.materials import WindowedMaterial
from barkgen.pipeline.options import GenerateOptions
from barkgen.tree import TexelMap, TreeMesh, default_tree_mesh, level_charts, texel_map


@dataclass
class TreeResult:
    """What :func:`make_tree` makes: the ``mesh``, its ``texels`` (the surface behind each
    texel, the fields and the chart-border links) and ``result``, the bark atlas as
    :func:`barkgen.pipeline.generate` makes it (texture, label maps, references, material)."""

    mesh: TreeMesh
    texels: TexelMap
    result: GenerateResult


def make_tree(
    photo: np.ndarray,
    options: GenerateOptions | None = None,
    *,
    mesh: TreeMesh | None = None,
    bark_width_m: float | None = None,
    scale_with_radius: bool = False,
    progress: ProgressCallback | None = None,
) -> TreeResult:
    """Bark for a whole tree.

    Parameters
    ----------
    photo : ndarray
        The bark photo (upright fissures run along the branches).
    options : GenerateOptions, optional
        As :func:`barkgen.pipeline.generate`'s; ``size`` is the atlas's, the seed also varies
        the built-in tree; an atlas never tiles.
    mesh : TreeMesh, optional
        The tree (:func:`barkgen.tree.read_tree_mesh`); default: the built-in tree
        (:func:`barkgen.tree.default_tree_mesh`).
    bark_width_m : float, optional
        How many metres of bark the photo's width shows (default: the bark at the photo's own
        resolution in the atlas).
    scale_with_radius : bool
        Wider plates where the branch is thicker (meshes with known radii).
    progress : callable, optional
        ``progress(done, total)``.

    Returns
    -------
    TreeResult

    References
    ----------
    .. [1] mazzolini2012, §3.1.3 (features that follow the trunk and branches), §3.1.4 (no seams
       at branch joins), §4.2 (synthesis on the surface).
    """
    options = dataclasses.replace(options or GenerateOptions(), tile=False)
    h, w = options.size
    if mesh is None:
        mesh = default_tree_mesh(options.seed, resolution=max(h, w))
    texels = texel_map(
        mesh,
        (h, w),
        photo_width_px=int(np.shape(photo)[1]),
        bark_width_m=bark_width_m,
        scale_with_radius=scale_with_radius,
    )
    fields = Canvas(options.size, tile=options.tile, flow=texels.flow, flow_scale=texels.scale, links=texels.links)
    result = generate(photo, options, canvas=fields, progress=progress)
    assert not isinstance(result.material, WindowedMaterial)  # (along a flow field the set is whole)
    if result.material is not None:  # the charts' heights brought to one level on the surface
        result.material = dataclasses.replace(result.material, height=level_charts(result.material.height, texels))
    return TreeResult(mesh, texels, result)


def encode_tree(photo: np.ndarray, tree: TreeResult, source: str, **encode) -> dict[str, bytes]:
    """Every file of a tree: ``barkgen generate``'s of its atlas
    (:func:`barkgen.pipeline.encode_generate` with ``encode``'s keywords), ``tree.glb`` (the
    mesh with the atlas's material set, when it has one) and ``tree_preview.png`` (four views)."""
    from barkgen.io import encode_glb, encode_png
    from barkgen.pipeline.files import encode_generate
    from barkgen.render.mesh import four_views

    material = tree.result.material
    assert not isinstance(material, WindowedMaterial)  # (made whole by make_tree)
    also = {}
    if material is not None:
        also = {
            "tree.glb": encode_glb(tree.mesh, material),
            "tree_preview.png": encode_png(four_views(tree.mesh, material)),
        }
    return encode_generate(photo, tree.result, source, also=also, **encode)
