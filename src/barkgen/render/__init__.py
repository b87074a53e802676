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


#: times the texture goes round the trunk when neither the view nor the set's real size says
DEFAULT_REPEAT = 2.0


@dataclass(frozen=True)
class TrunkView:
    """Parameters of :func:`render_trunk` and :func:`trunk_mesh`: ``repeat``: how many times
    the texture goes round the trunk (its aspect is kept along the trunk; ``None``: as the
    set's real size gives it on a mesh, :func:`real_repeat`, else :data:`DEFAULT_REPEAT`);
    ``displacement``: relief scale (1 = the material's own depth); ``light``; ``radius``: the
    trunk's radius as a share of the image width."""

    repeat: float | None = None
    displacement: float = 1.0
    light: Light = DEFAULT_LIGHT
    radius: float = 0.36

    def __post_init__(self) -> None:
        if self.repeat is not None and not (np.isfinite(self.repeat) and 0.25 <= self.repeat <= 64):
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
    repeat = view.repeat if view.repeat is not None else DEFAULT_REPEAT
    texel = 2 * np.pi * radius / repeat / tex_w  # screen px per texel
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


def real_repeat(width_m: float, radius_m: float) -> int:
    """How many times a set ``width_m`` metres wide goes round a trunk of ``radius_m`` at its
    real size: the circumference over the width, rounded to a whole number (at least 1) so that
    the texture meets itself at the seam. The rounding stretches or squeezes the texture round
    the trunk (by at most a quarter from two repeats on; a trunk thinner than the set is
    wide takes it once, squeezed)."""
    return max(1, round(2 * np.pi * radius_m / width_m))


def trunk_mesh(
    material: MaterialSet, *, segments: int = 256, radius_m: float = 0.15, view: TrunkView | None = None
) -> TrunkMesh:
    """The trunk as a mesh whose vertices carry the relief (displacement baked into the
    geometry; the normal map adds the detail between vertices).

    ``segments`` around; rings along keep square cells; the trunk is as tall as its
    circumference. Of ``view`` only ``repeat`` and ``displacement`` apply (a mesh has no light,
    and its radius is ``radius_m``).

    At the set's real size, when its pixel size is known (:attr:`MaterialSet.pixel_size_m`):
    the texture covers its real width round the trunk, ``repeat`` = circumference / width
    rounded to a whole number >= 1 (:func:`real_repeat`) so that it wraps seamlessly, and the
    vertices move by the height in metres, ``height_px * pixel_size_m * view.displacement``
    (the displacement's whole range is ``NAME.json``'s ``displacement_depth_m``). A
    ``view.repeat`` given still sets the repeat; the depth stays in metres. Without a pixel
    size: ``view.repeat`` (default :data:`DEFAULT_REPEAT`), and a height pixel is as long as a
    texel is wide on the trunk.
    """
    view = view or TrunkView()
    if not 8 <= segments <= MAX_SEGMENTS:
        raise InvalidInputError(f"segments must be 8..{MAX_SEGMENTS}, not {segments}")
    rings = segments
    tex_h, tex_w = material.shape
    circumference = 2 * np.pi * radius_m
    size_m = material.pixel_size_m
    repeat = view.repeat
    if repeat is None:
        repeat = DEFAULT_REPEAT if size_m is None else real_repeat(size_m * tex_w, radius_m)
    metres_per_px = size_m if size_m is not None else circumference / repeat / tex_w
    height = material.height.astype(np.float64) * (metres_per_px * view.displacement)
    j = np.arange(segments + 1)
    i = np.arange(rings + 1)
    u = j / segments * repeat  # texture repeats round the trunk
    v = i / rings * repeat * tex_w / tex_h  # and keeps its aspect along it
    ty = np.floor((v * tex_h) % tex_h).astype(int)
    tx = np.floor((u * tex_w) % tex_w).astype(int)
    tx[-1] = tx[0]  # the seam's two copies of a vertex take the same relief: no crack
    r = radius_m + height[ty[:, None], tx[None, :]]
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


__all__ = ["DEFAULT_LIGHT", "DEFAULT_REPEAT", "TrunkMesh", "TrunkView", "real_repeat", "render_trunk", "trunk_mesh"]
