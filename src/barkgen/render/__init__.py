"""A bark material on a tree trunk: a software render for previews and a glTF-ready mesh
(laitoch2018 §5.4: bark projected onto a cylinder; wang2003 §3.3's 3D view under a light).

No GPU, no display: :func:`render_trunk` rasterizes a displaced cylinder row by row in numba;
:func:`trunk_mesh` builds the displaced cylinder as vertices, faces and UVs, which
:func:`barkgen.io.encode_glb` encodes as glTF 2.0 with its textures.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from barkgen.color import linear_to_srgb, srgb_to_linear
from barkgen.errors import InvalidInputError
from barkgen.material.materialset import MaterialSet
from barkgen.material.shading import Light
from barkgen.render._kernels import render_rows

#: a light from the upper left, in front: shows relief without flattening it
DEFAULT_LIGHT = Light(135.0, 35.0)
#: share of ambient (sky) light, scaled by AO
AMBIENT = 0.3
#: limits that keep a preview under ~1 GB and a mesh under ~4 M vertices
MAX_PREVIEW = 8192
MAX_SEGMENTS = 2048
BACKGROUND = np.array([0.010, 0.011, 0.013], np.float32)


@dataclass(frozen=True)
class TrunkView:
    """Parameters of :func:`render_trunk` and :func:`trunk_mesh`: ``repeat``: how many times
    the texture goes round the trunk (its aspect is kept along the trunk); ``displacement``:
    relief scale (1 = the material's own depth); ``light``; ``radius``: the trunk's radius as a
    share of the image width."""

    repeat: float = 2.0
    displacement: float = 1.0
    light: Light = DEFAULT_LIGHT
    radius: float = 0.36

    def __post_init__(self) -> None:
        if not (np.isfinite(self.repeat) and 0.25 <= self.repeat <= 64):
            raise InvalidInputError(f"repeat must be in [0.25, 64], not {self.repeat:g}")
        if not (np.isfinite(self.displacement) and 0 <= self.displacement <= 100):
            raise InvalidInputError(f"displacement must be in [0, 100], not {self.displacement:g}")
        if not 0.05 <= self.radius <= 0.5:
            raise InvalidInputError(f"radius must be in [0.05, 0.5] of the width, not {self.radius:g}")


def _stack_maps(material: MaterialSet) -> np.ndarray:
    maps = np.empty(material.shape + (9,), np.float32)
    maps[..., :3] = srgb_to_linear(material.color)
    maps[..., 3] = material.displacement()
    maps[..., 4:7] = material.normals
    maps[..., 7] = material.ao
    maps[..., 8] = material.roughness
    return maps


def render_trunk(
    material: MaterialSet, size: tuple[int, int] = (1024, 1024), view: TrunkView | None = None
) -> np.ndarray:
    """Render ``material`` on a vertical trunk seen from the side; ``size`` ``(height, width)``;
    returns uint8 sRGB ``(height, width, 3)``."""
    view = view or TrunkView()
    out_h, out_w = (int(s) for s in size)
    if not (16 <= out_h <= MAX_PREVIEW and 16 <= out_w <= MAX_PREVIEW):
        raise InvalidInputError(f"preview size must be 16..{MAX_PREVIEW} px a side, not {out_w}x{out_h}")
    radius = view.radius * out_w
    tex_w = material.shape[1]
    texel = 2 * np.pi * radius / view.repeat / tex_w  # screen px per texel
    amplitude = material.depth * texel * view.displacement
    linear = render_rows(
        _stack_maps(material),
        out_h,
        out_w,
        radius,
        texel,
        amplitude,
        material.midlevel,
        view.light.vector.astype(np.float64),
        AMBIENT,
        BACKGROUND,
    )
    return np.floor(linear_to_srgb(linear) * 255 + 0.5).astype(np.uint8)


@dataclass
class TrunkMesh:
    """A displaced open cylinder: ``vertices`` (n, 3) metres (y up), ``faces`` (m, 3)
    counter-clockwise seen from outside, ``uv`` (n, 2) with v = 0 at the texture's top row
    (glTF), the seam's vertices duplicated."""

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray


def trunk_mesh(
    material: MaterialSet, *, segments: int = 256, radius_m: float = 0.15, view: TrunkView | None = None
) -> TrunkMesh:
    """The trunk as a mesh whose vertices carry the relief (displacement baked into the
    geometry; the normal map adds the detail between vertices). ``segments`` around; rings
    along keep square cells; the trunk is as tall as its circumference. Of ``view`` only
    ``repeat`` and ``displacement`` apply (a mesh has no light, and its radius is ``radius_m``)."""
    view = view or TrunkView()
    if not 8 <= segments <= MAX_SEGMENTS:
        raise InvalidInputError(f"segments must be 8..{MAX_SEGMENTS}, not {segments}")
    rings = segments
    tex_h, tex_w = material.shape
    circumference = 2 * np.pi * radius_m
    metres_per_texel = circumference / view.repeat / tex_w
    disp = material.displacement()
    amplitude = material.depth * metres_per_texel * view.displacement
    j = np.arange(segments + 1)
    i = np.arange(rings + 1)
    u = j / segments * view.repeat  # texture repeats round the trunk
    v = i / rings * view.repeat * tex_w / tex_h  # and keeps its aspect along it
    ty = np.floor((v * tex_h) % tex_h).astype(int)
    tx = np.floor((u * tex_w) % tex_w).astype(int)
    tx[-1] = tx[0]  # the seam's two copies of a vertex take the same relief: no crack
    r = radius_m + (disp[ty[:, None], tx[None, :]] - material.midlevel) * amplitude
    theta = j / segments * 2 * np.pi
    x = r * np.sin(theta)[None, :]
    z = r * np.cos(theta)[None, :]
    y = np.broadcast_to((circumference * (1 - i / rings))[:, None], r.shape)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    uu, vv = np.meshgrid(u, v)
    uv = np.stack([uu, vv], axis=-1).reshape(-1, 2)
    idx = np.arange((rings + 1) * (segments + 1)).reshape(rings + 1, segments + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, d], 1)])
    return TrunkMesh(vertices=vertices.astype(np.float32), faces=faces.astype(np.int64), uv=uv.astype(np.float32))


__all__ = ["DEFAULT_LIGHT", "TrunkMesh", "TrunkView", "render_trunk", "trunk_mesh"]
