"""The trunk preview and mesh (:mod:`barkgen.render`, its kernels :mod:`barkgen.render._kernels`)
on small hand-made material sets: the image's shape and frame, the silhouette, the light's side,
the albedo, the relief; the mesh's grid, radius, height, seam and outward faces."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.color import linear_to_srgb
from barkgen.errors import InvalidInputError
from barkgen.material.materialset import MaterialSet
from barkgen.material.shading import Light
from barkgen.render import BACKGROUND, TrunkView, real_repeat, render_trunk, trunk_mesh
from barkgen.render._kernels import _bilinear

SIZE = (48, 96)


def material(height=None, color=(0.5, 0.5, 0.5), shape=(32, 64)) -> MaterialSet:
    """A matte material: flat normals, full AO, roughness 1; ``height`` (h, w) or flat."""
    h, w = shape
    normals = np.zeros((h, w, 3), np.float32)
    normals[..., 2] = 1
    return MaterialSet(
        color=np.broadcast_to(np.float32(color), (h, w, 3)).copy(),
        height=np.zeros((h, w), np.float32) if height is None else height.astype(np.float32),
        normals=normals,
        ao=np.ones((h, w), np.float32),
        roughness=np.ones((h, w), np.float32),
        tile=True,
    )


def on_trunk(image: np.ndarray) -> np.ndarray:
    """Pixels of the trunk: those that differ from the background of their row."""
    return np.abs(image.astype(int) - image[:, :1].astype(int)).sum(axis=2) > 0


def test_the_render_is_srgb_of_the_asked_size_on_the_background():
    image = render_trunk(material(), SIZE)
    assert image.shape == SIZE + (3,) and image.dtype == np.uint8
    # the corners are the background (darkening downwards), in sRGB
    top = np.floor(linear_to_srgb(BACKGROUND) * 255 + 0.5)
    assert np.array_equal(image[0, 0], top) and np.array_equal(image[0, -1], top)
    assert image[-1, 0].sum() < image[0, 0].sum()
    # a flat trunk is a band of 2 x radius, centred, the same on every row
    mask = on_trunk(image)
    width = 2 * TrunkView().radius * SIZE[1]
    assert (np.abs(mask.sum(axis=1) - width) <= 2).all()
    cols = np.flatnonzero(mask[0])
    assert abs((cols[0] + cols[-1]) / 2 - (SIZE[1] - 1) / 2) <= 1


def test_the_lit_side_follows_the_light():
    flat = material()
    right = render_trunk(flat, SIZE, TrunkView(light=Light(0.0, 30.0))).astype(float)
    left = render_trunk(flat, SIZE, TrunkView(light=Light(180.0, 30.0))).astype(float)
    half = SIZE[1] // 2
    assert right[:, half + 8 : half + 28].mean() > 1.5 * right[:, half - 28 : half - 8].mean()
    assert left[:, half - 28 : half - 8].mean() > 1.5 * left[:, half + 8 : half + 28].mean()
    # the same trunk lit from either side: mirror images (to the sampling's pixel)
    assert np.abs(right - left[:, ::-1]).mean() < 3
    # lit from the viewer, the middle is the brightest and the rims darken
    front = render_trunk(flat, SIZE, TrunkView(light=Light(0.0, 90.0))).astype(float).mean(axis=(0, 2))
    assert front[half - 2 : half + 2].mean() > front[half - 30 : half + 30].mean() > front[half - 33]


def test_the_albedo_colours_the_trunk_only():
    red = render_trunk(material(color=(0.8, 0.2, 0.1)), SIZE)
    grey = render_trunk(material(), SIZE)
    mask = on_trunk(grey)
    r, g, b = (red[..., c][mask].astype(float).mean() for c in range(3))
    assert r > 2 * g > 2 * b
    assert np.array_equal(red[~mask], grey[~mask])


def test_the_relief_shows_on_the_silhouette_and_displacement_scales_it():
    rows = np.arange(32)
    ridges = np.repeat((np.sin(2 * np.pi * rows / 8) * 6)[:, None], 64, axis=1)  # rings round the trunk
    flat = on_trunk(render_trunk(material(ridges), SIZE, TrunkView(displacement=0.0))).sum(axis=1)
    some = on_trunk(render_trunk(material(ridges), SIZE, TrunkView(displacement=1.0))).sum(axis=1)
    more = on_trunk(render_trunk(material(ridges), SIZE, TrunkView(displacement=3.0))).sum(axis=1)
    assert np.ptp(flat) <= 1 < np.ptp(some) < np.ptp(more)


def test_bad_sizes_and_views_are_refused():
    with pytest.raises(InvalidInputError, match="preview size"):
        render_trunk(material(), (8, 96))
    for bad in (dict(repeat=0.0), dict(displacement=-1.0), dict(radius=0.6)):
        with pytest.raises(InvalidInputError):
            TrunkView(**bad)
    with pytest.raises(InvalidInputError, match="segments"):
        trunk_mesh(material(), segments=4)


def test_bilinear_sampling_hits_texels_and_wraps():
    img = np.arange(12, dtype=np.float64).reshape(3, 4, 1)
    assert _bilinear(img, 2.0, 1.0, 0) == img[1, 2, 0]
    assert _bilinear(img, 1.5, 0.0, 0) == pytest.approx((img[0, 1, 0] + img[0, 2, 0]) / 2)
    assert _bilinear(img, 3.5, 0.0, 0) == pytest.approx((img[0, 3, 0] + img[0, 0, 0]) / 2)  # wraps in u
    assert _bilinear(img, 0.0, 2.5, 0) == pytest.approx((img[2, 0, 0] + img[0, 0, 0]) / 2)  # and in v
    assert _bilinear(img, 4.0 + 1.0, -3.0 + 1.0, 0) == img[1, 1, 0]


def test_the_mesh_is_a_closed_grid_of_outward_faces():
    segments, radius = 16, 0.2
    mesh = trunk_mesh(material(), segments=segments, radius_m=radius)
    n = (segments + 1) ** 2
    assert mesh.vertices.shape == (n, 3) and mesh.uv.shape == (n, 2)
    assert mesh.faces.shape == (2 * segments * segments, 3) and mesh.faces.max() == n - 1
    # flat: every vertex on the cylinder, which is as tall as its circumference
    assert np.allclose(np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 2]), radius, atol=1e-6)
    assert np.isclose(mesh.vertices[:, 1].max(), 2 * np.pi * radius) and np.isclose(mesh.vertices[:, 1].min(), 0)
    grid = mesh.vertices.reshape(segments + 1, segments + 1, 3)
    assert np.allclose(grid[:, 0], grid[:, -1], atol=1e-6)  # the seam's copies coincide
    # counter-clockwise seen from outside: every face's normal points away from the axis
    a, b, c = (mesh.vertices[mesh.faces[:, i]].astype(np.float64) for i in range(3))
    normals = np.cross(b - a, c - a)
    centres = (a + b + c) / 3
    radial = centres * [1, 0, 1]
    assert ((normals * radial).sum(axis=1) > 0).all()
    # uv: repeat times round, v down from the top, the aspect kept
    assert mesh.uv[:, 0].max() == pytest.approx(2.0) and mesh.uv[:, 1].max() == pytest.approx(4.0)


def test_the_mesh_carries_the_relief():
    height = np.full((32, 64), -4, np.float32)
    height[:, :32] = 4  # half the texture raised, half sunk (height 0: the trunk's radius)
    mesh = trunk_mesh(material(height), segments=16, radius_m=0.2, view=TrunkView(repeat=1.0))
    radii = np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 2]).reshape(17, 17)
    assert (radii[:, :8] > 0.2).all() and (radii[:, 9:16] < 0.2).all()
    flat = trunk_mesh(material(height), segments=16, radius_m=0.2, view=TrunkView(repeat=1.0, displacement=0.0))
    assert np.allclose(np.hypot(flat.vertices[:, 0], flat.vertices[:, 2]), 0.2, atol=1e-6)


def test_a_set_of_known_size_wraps_at_its_real_width_and_moves_the_vertices_by_its_depth_in_metres():
    """A set 0.4 m wide (its pixel size known) on a trunk of radius 0.15 m: the texture
    goes round round(0.94 / 0.4) = 2 times, and the mesh's radii span the set's depth in metres
    (``NAME.json``'s ``displacement_depth_m``), whatever the repeat; twice with displacement 2."""
    rng = np.random.default_rng(4)
    y, x = np.mgrid[0:32, 0:64]
    height = np.sin(x / 3.0) * 3 + np.cos(y / 2.0) * 2 + rng.normal(0, 0.2, (32, 64))
    known = material(height).with_width_m(0.4)
    depth_m = known.physical_size()["displacement_depth_m"]
    assert depth_m == pytest.approx(known.depth * 0.4 / 64)
    mesh = trunk_mesh(known, segments=256, radius_m=0.15)
    assert mesh.uv[:, 0].max() == pytest.approx(2.0)  # round(2 pi 0.15 / 0.4) = round(2.36)
    radii = np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 2])
    assert np.ptp(radii) == pytest.approx(depth_m, rel=0.03)
    # height 0 on the trunk's radius: the radii are the height in metres about it
    assert radii.min() == pytest.approx(0.15 + known.height.min() * known.pixel_size_m, rel=1e-4)
    deeper = trunk_mesh(known, segments=256, radius_m=0.15, view=TrunkView(displacement=2.0))
    assert np.ptp(np.hypot(deeper.vertices[:, 0], deeper.vertices[:, 2])) == pytest.approx(2 * depth_m, rel=0.03)
    # a repeat asked for is kept, the depth stays in metres
    four = trunk_mesh(known, segments=256, radius_m=0.15, view=TrunkView(repeat=4.0))
    assert four.uv[:, 0].max() == pytest.approx(4.0)
    assert np.ptp(np.hypot(four.vertices[:, 0], four.vertices[:, 2])) == pytest.approx(depth_m, rel=0.03)
    # a trunk thinner than the set: once round, squeezed; unknown size: as before (2 round)
    assert real_repeat(0.4, 0.03) == 1 and real_repeat(0.4, 1.0) == 16
    assert trunk_mesh(material(height), segments=16).uv[:, 0].max() == pytest.approx(2.0)
