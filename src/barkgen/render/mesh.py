"""A textured mesh (a tree and its bark atlas) seen from a few sides: a software render for
previews, no GPU (wang2003 §3.3's 3D view, laitoch2018 §5.4's bark on a tree).

Orthographic views round the vertical axis; each pixel is found by a z-buffer pass in numba
(:func:`barkgen.render._kernels.rasterize_mesh`) and shaded in numpy: the atlas's colour and AO,
its normal map turned into the surface by each vertex's tangent frame, one light and a sky.
"""

from __future__ import annotations

import numpy as np

from barkgen.color import linear_to_srgb, srgb_to_linear
from barkgen.errors import InvalidInputError
from barkgen.material.materialset import MaterialSet

#: the light of every view, from the upper left in front (view space: x right, y up, z out)
VIEW_LIGHT = np.array([-0.45, 0.6, 0.66])
#: the sky's share of the light, scaled by AO
SKY = 0.3
BACKGROUND = np.array([0.93, 0.94, 0.95])


def _sample(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear samples of ``image`` ``(h, w, C)`` at glTF ``uv`` ``(n, 2)`` (clamped)."""
    h, w = image.shape[:2]
    x = np.clip(uv[:, 0] * w - 0.5, 0, w - 1)
    y = np.clip(uv[:, 1] * h - 0.5, 0, h - 1)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    img = image.reshape(h, w, -1)
    top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
    bottom = img[y1, x0] * (1 - fx) + img[y1, x1] * fx
    return top * (1 - fy) + bottom * fy


def render_mesh(
    mesh,
    material: MaterialSet,
    *,
    size: int = 512,
    azimuth: float = 0.0,
    elevation: float = 10.0,
) -> np.ndarray:
    """``mesh`` (vertices, faces, glTF uv, normals; a :class:`barkgen.tree.TreeMesh`) with
    ``material``'s atlas, seen from ``azimuth`` degrees round the vertical axis and
    ``elevation`` above the horizon, framed to fit: uint8 sRGB ``(size, size, 3)``."""
    from barkgen.io.gltf import vertex_tangents
    from barkgen.render._kernels import rasterize_mesh

    if not 16 <= size <= 4096:
        raise InvalidInputError(f"a view is 16 to 4096 px a side, not {size}")
    az, el = np.radians(azimuth), np.radians(elevation)
    # the camera's frame: right, up and towards the viewer
    toward = np.array([np.sin(az) * np.cos(el), np.sin(el), np.cos(az) * np.cos(el)])
    right = np.array([np.cos(az), 0.0, -np.sin(az)])
    up = np.cross(toward, right)
    vertices = mesh.vertices.astype(np.float64)
    view = np.stack([vertices @ right, vertices @ up, vertices @ toward], axis=1)
    low, high = view[:, :2].min(axis=0), view[:, :2].max(axis=0)
    fit = 0.92 * size / float(max(high - low))
    centre = (low + high) / 2.0
    screen = np.empty_like(view)
    screen[:, 0] = size / 2.0 + (view[:, 0] - centre[0]) * fit
    screen[:, 1] = size / 2.0 - (view[:, 1] - centre[1]) * fit
    screen[:, 2] = -view[:, 2]
    triangle = np.full((size, size), -1, np.int64)
    bary = np.zeros((size, size, 3), np.float64)
    depth = np.full((size, size), np.inf)
    rasterize_mesh(screen, mesh.faces.astype(np.int64), size, size, triangle, bary, depth)
    out = np.empty((size, size, 3))
    out[:] = BACKGROUND
    hit = triangle >= 0
    corners = mesh.faces[triangle[hit]]
    w = bary[hit][:, :, None]
    normals = mesh.normals.astype(np.float64)
    tangents = vertex_tangents(vertices, normals, mesh.uv, mesh.faces)
    uv = (w * mesh.uv.astype(np.float64)[corners]).sum(axis=1)
    n = (w * normals[corners]).sum(axis=1)
    t = (w * tangents[corners, :3]).sum(axis=1)
    sign = np.sign((w * tangents[corners, 3:4]).sum(axis=1))
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    t -= (t * n).sum(axis=1, keepdims=True) * n
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-12)
    b = np.cross(n, t) * sign
    detail = _sample(material.normals.astype(np.float64), uv)
    shading = detail[:, :1] * t + detail[:, 1:2] * b + detail[:, 2:3] * n
    shading /= np.maximum(np.linalg.norm(shading, axis=1, keepdims=True), 1e-12)
    light = VIEW_LIGHT[0] * right + VIEW_LIGHT[1] * up + VIEW_LIGHT[2] * toward
    light /= np.linalg.norm(light)
    colour = srgb_to_linear(np.clip(_sample(material.color.astype(np.float64), uv), 0.0, 1.0))
    ao = _sample(material.ao.astype(np.float64)[..., None], uv)
    lit = colour * (SKY * ao + (1.0 - SKY) * np.clip(shading @ light, 0.0, None)[:, None] * np.sqrt(ao))
    out[hit] = linear_to_srgb(np.clip(lit, 0.0, 1.0))
    return np.floor(np.clip(out, 0.0, 1.0) * 255 + 0.5).astype(np.uint8)


def four_views(mesh, material: MaterialSet, size: int = 512) -> np.ndarray:
    """The mesh from the front, the right, the back and the left, side by side:
    ``(size, 4 * size, 3)`` uint8."""
    return np.concatenate(
        [render_mesh(mesh, material, size=size, azimuth=a) for a in (0.0, 90.0, 180.0, 270.0)], axis=1
    )
