"""Bark for a whole tree (mazzolini2012 §3.1.3, §3.1.4, §4.2): a tree mesh in (a user's glTF/OBJ
with UVs, or the built-in trunk with branches and smooth collars), its UV atlas's flow and scale
fields (the branch axis carried into the atlas), the bark atlas synthesized along them with its
material set, chart borders made continuous on the surface, ``tree.glb`` and a four-view
preview out.

Modules: :mod:`.skeleton` (the built-in tree's limbs and implicit surface), :mod:`.mesh`
(:class:`TreeMesh`, reading, unwrapping, branch axes), :mod:`.texels` (the surface behind each
texel, the fields, the gutter links); the whole run is :func:`barkgen.pipeline.make_tree`.
"""

from barkgen.tree.mesh import TreeMesh, default_tree_mesh, read_tree_mesh, surface_axis, unwrap
from barkgen.tree.skeleton import Limb, Skeleton, default_skeleton
from barkgen.tree.texels import TexelMap, level_charts, texel_map

__all__ = [
    "Limb",
    "Skeleton",
    "TexelMap",
    "TreeMesh",
    "default_skeleton",
    "default_tree_mesh",
    "level_charts",
    "read_tree_mesh",
    "surface_axis",
    "texel_map",
    "unwrap",
]
