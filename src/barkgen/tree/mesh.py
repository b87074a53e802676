"""Tree meshes: the built-in tree (:func:`default_tree_mesh`), a user's glTF/GLB or OBJ mesh with
UVs (:func:`read_tree_mesh`, trimesh), UV atlases made by xatlas where a mesh has none, and the
branch axis of every vertex.

UVs follow glTF: (0, 0) is the texture's top-left corner, ``v`` grows down the image.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from barkgen.errors import ImageReadError, InvalidInputError


@dataclass
class TreeMesh:
    """A tree's surface with its UV atlas.

    Attributes
    ----------
    vertices : ndarray of float32, shape (n, 3)
        Metres, y up.
    faces : ndarray of int64, shape (m, 3)
        Counter-clockwise seen from outside.
    uv : ndarray of float32, shape (n, 2)
        Texture coordinates (glTF: v down the image), in [0, 1].
    axis : ndarray of float32, shape (n, 3)
        The branch axis at each vertex (unit, in the surface's tangent plane: up and out along
        the branch).
    radius : ndarray of float32, shape (n,)
        The branch's radius at each vertex (metres), where known (the built-in tree), else NaN.
    source : str
        Where it came from (a file, or ``"built-in tree, seed N"``).
    """

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray
    axis: np.ndarray
    radius: np.ndarray
    source: str = ""

    @property
    def normals(self) -> np.ndarray:
        """Unit vertex normals: the area-weighted face normals round each point of the surface,
        the copies of a vertex split along a chart border summed together (so the shading
        does not break where the atlas does)."""
        v = self.vertices.astype(np.float64)
        f = self.faces
        _, point = np.unique(np.round(v, 6), axis=0, return_inverse=True)
        point = point.ravel()
        face_normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        summed = np.zeros((int(point.max()) + 1, 3))
        for k in range(3):
            np.add.at(summed, point[f[:, k]], face_normals)
        normals = summed[point]
        return (normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)).astype(np.float32)


def _tangent(axis: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``axis`` made tangent to the surface (its normal part removed), unit."""
    axis = axis - (axis * normals).sum(axis=1, keepdims=True) * normals
    return (axis / np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-12)).astype(np.float32)


def unwrap(
    vertices: np.ndarray, faces: np.ndarray, resolution: int = 2048
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A UV atlas by xatlas: ``(vertex_map, faces, uv)``, the vertices split along the charts'
    borders (``vertices[vertex_map]`` are the new ones), uv in [0, 1] (glTF), charts packed with
    a gutter of a few texels at ``resolution`` (needs the ``[tree]`` extra).

    xatlas runs in a child process (:mod:`barkgen.tree._unwrap`, 0.2 s more): it holds the
    interpreter for its whole call (the built-in tree: 2.5 s), and Ctrl-C stops a child at once.
    """
    import subprocess
    import sys

    from barkgen._shared.extras import require_extra

    require_extra("tree", "unwrapping a mesh")
    given = io.BytesIO()
    np.savez(given, vertices=np.asarray(vertices, np.float32), faces=np.asarray(faces, np.int64), resolution=resolution)
    # the module's file as a script (its folder not on the path): numpy and xatlas, not barkgen
    script = Path(__file__).with_name("_unwrap.py")
    child = subprocess.run([sys.executable, "-P", str(script)], input=given.getvalue(), capture_output=True)
    if child.returncode != 0:
        lines = child.stderr.decode(errors="replace").strip().splitlines() or [f"exit status {child.returncode}"]
        raise InvalidInputError(f"xatlas could not unwrap the mesh: {lines[-1]}")
    made = np.load(io.BytesIO(child.stdout))
    return made["vertex_map"].astype(np.int64), made["faces"].astype(np.int64), made["uv"].astype(np.float32)


def default_tree_mesh(seed: int = 0, *, cell: float | None = None, resolution: int = 2048) -> TreeMesh:
    """The built-in tree (:mod:`barkgen.tree.skeleton`): a trunk with two branches and a twig,
    smooth collars, unwrapped by xatlas for an atlas of ``resolution`` texels.

    Parameters
    ----------
    seed : int
        Varies the branches' angles and lengths a little.
    cell : float, optional
        The marching-cubes cell in metres (default :data:`barkgen.tree.skeleton.CELL`).
    resolution : int
        The atlas's width the charts are packed for.

    Returns
    -------
    TreeMesh
    """
    from barkgen._shared.extras import require_extra
    from barkgen.tree.skeleton import CELL, axis_and_radius, default_skeleton, skeleton_surface

    require_extra("tree", "the built-in tree")
    import trimesh

    skeleton = default_skeleton(seed)
    vertices, faces = skeleton_surface(skeleton, cell or CELL)
    # marching cubes' staircase smoothed away (Taubin: no shrinking)
    surface = trimesh.Trimesh(vertices, faces, process=False)
    trimesh.smoothing.filter_taubin(surface, iterations=10)
    vertices = np.asarray(surface.vertices, np.float32)
    vertex_map, faces, uv = unwrap(vertices, faces, resolution)
    vertices = vertices[vertex_map]
    axis, radius = axis_and_radius(skeleton, vertices.astype(np.float64))
    mesh = TreeMesh(
        vertices, faces, uv, axis.astype(np.float32), radius.astype(np.float32), f"built-in tree, seed {seed}"
    )
    mesh.axis = _tangent(axis, mesh.normals.astype(np.float64))
    return mesh


def surface_axis(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, neighbours: int = 24) -> np.ndarray:
    """The branch axis at each vertex of a mesh with no skeleton: the direction along which
    the surface's normals vary least over its ``neighbours`` nearest vertices — on a branch,
    the normals turn round it and not along it — taken up the tree (y > 0), made tangent."""
    from scipy.spatial import cKDTree

    v = vertices.astype(np.float64)
    n = normals.astype(np.float64)
    _, near = cKDTree(v).query(v, k=min(int(neighbours), len(v)))
    around = n[near]  # (vertices, neighbours, 3)
    _, vectors = np.linalg.eigh(np.einsum("vki,vkj->vij", around, around))
    axis = vectors[:, :, 0]  # the least varying direction
    axis *= np.where(axis[:, 1:2] < 0, -1.0, 1.0)
    return _tangent(axis, n)


def _atlas_problem(uv: np.ndarray, faces: np.ndarray) -> str | None:
    """Why a mesh's UVs are no atlas a texture can be synthesized into, or None: UVs outside the
    unit square (a texture that repeats), or triangles that share texels (their summed UV area
    over a tenth above the area they cover)."""
    from barkgen.tree._kernels import rasterize

    if uv.size and (uv.min() < -1e-3 or uv.max() > 1.0 + 1e-3):
        return "UVs outside [0, 1]"
    corners = uv.astype(np.float64)[faces]
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    summed = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    side = 512
    triangle = np.full((side, side), -1, np.int32)
    rasterize(corners * side, side, side, triangle, np.zeros((side, side, 3)))
    covered = float((triangle >= 0).mean())
    if summed > 1.1 * covered + 4.0 / side:
        return "UVs that overlap"
    return None


def read_tree_mesh(path: str | os.PathLike, *, resolution: int = 2048) -> TreeMesh:
    """A tree mesh from a glTF/GLB or OBJ file (trimesh; needs the ``[tree]`` extra): its own UVs,
    or, where it has none or they are no atlas (they repeat a tiling texture, or triangles
    share texels), an atlas made by xatlas; its branch axes from its normals
    (:func:`surface_axis`).

    Raises
    ------
    ImageReadError
        A missing or unreadable file.
    InvalidInputError
        An empty mesh, one that is not a surface of triangles, or one with non-manifold edges.
    """
    from barkgen._shared.extras import require_extra

    require_extra("tree", "reading tree meshes")
    import trimesh

    path = Path(path)
    if not path.is_file():
        raise ImageReadError(f"{path}: no such file")
    try:
        loaded = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many kinds on a bad file
        raise ImageReadError(f"{path}: not a mesh trimesh can read ({type(exc).__name__}: {exc})") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise InvalidInputError(f"{path}: holds no triangles")
    vertices = np.asarray(loaded.vertices, np.float32)
    faces = np.asarray(loaded.faces, np.int64)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    if (counts > 2).any():
        raise InvalidInputError(
            f"{path}: {int((counts > 2).sum())} edges are shared by more than two triangles (not a manifold surface)"
        )
    uv = getattr(loaded.visual, "uv", None)
    reason: str | None = "no UVs"
    if uv is not None and len(uv) == len(vertices):
        # trimesh gives OBJ's and glTF's UVs with v up: back to glTF's v down
        uv = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).astype(np.float32)
        reason = _atlas_problem(uv, faces)
    if reason is not None:
        vertex_map, faces, uv = unwrap(vertices, faces, resolution)
        vertices = vertices[vertex_map]
        source = f"{path} ({reason}: unwrapped by xatlas)"
    else:
        source = str(path)
    mesh = TreeMesh(
        vertices,
        faces,
        np.asarray(uv, np.float32),
        np.zeros_like(vertices),
        np.full(len(vertices), np.nan, np.float32),
        source,
    )
    mesh.axis = surface_axis(mesh.vertices, mesh.faces, mesh.normals)
    return mesh
