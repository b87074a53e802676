"""Bark for a whole tree (issue 34): the built-in tree's surface and atlas, the fields and the
chart-border links of an atlas, meshes read from files, bad meshes refused in one line, and the
tree command end to end (its glb through the Khronos validator)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import bark_exemplar, run, validate_glb

from barkgen.errors import InvalidInputError
from barkgen.io import write_png
from barkgen.tree import default_skeleton, default_tree_mesh, read_tree_mesh, texel_map


@pytest.fixture(scope="module")
def tree_mesh():
    return default_tree_mesh(0, resolution=512)


def test_the_built_in_tree_is_a_closed_surface_with_branches_and_an_atlas(tree_mesh):
    import trimesh

    assert len(default_skeleton(0).limbs) >= 3  # a trunk and at least two branches
    mesh = tree_mesh
    welded = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)
    assert welded.is_watertight and welded.euler_number == 2  # one closed surface: smooth collars, no holes
    assert mesh.uv.min() >= 0.0 and mesh.uv.max() <= 1.0
    # outward triangles, unit normals, axes tangent to the surface and up the trunk
    v = mesh.vertices.astype(np.float64)
    face_normals = np.cross(v[mesh.faces[:, 1]] - v[mesh.faces[:, 0]], v[mesh.faces[:, 2]] - v[mesh.faces[:, 0]])
    centres = v[mesh.faces].mean(axis=1)
    low_trunk = (centres[:, 1] > 0.2) & (centres[:, 1] < 0.9)
    assert np.mean((face_normals[low_trunk] * (centres[low_trunk] * [1, 0, 1])).sum(axis=1) > 0) > 0.99
    assert np.allclose(np.linalg.norm(mesh.normals, axis=1), 1, atol=1e-5)
    assert np.abs((mesh.axis * mesh.normals).sum(axis=1)).max() < 1e-4
    trunk = (v[:, 1] > 0.2) & (v[:, 1] < 0.9)
    assert np.median(mesh.axis[trunk, 1]) > 0.95
    # the same seed, the same tree
    again = default_tree_mesh(0, resolution=512)
    assert np.array_equal(again.vertices, mesh.vertices) and np.array_equal(again.uv, mesh.uv)


def test_texels_know_their_surface_their_direction_and_their_other_side(tree_mesh):
    texels = texel_map(tree_mesh, (256, 256), photo_width_px=256)
    assert 0.25 < texels.covered.mean() < 0.9
    assert np.isfinite(texels.flow).all() and np.abs(texels.flow).max() <= 90.0
    assert np.allclose(np.median(texels.scale[texels.covered]), 1.0, atol=0.01)  # the photo's own resolution
    # every link joins two texels at (almost) the same surface point, across a chart border
    links = texels.links
    assert links.target.size > 100
    points = texels.positions.reshape(-1, 3)
    apart = np.linalg.norm(points[links.target] - points[links.source], axis=1)
    assert np.median(apart) * texels.texels_per_metre < 1.0
    assert not texels.covered.reshape(-1)[links.target].any() and texels.covered.reshape(-1)[links.source].all()
    # a texel's field turns the photo's upright fissures onto the branch axis: check on the trunk
    rows, cols = np.nonzero(texels.covered)
    y = texels.positions[rows, cols, 1]
    trunk = (y > 0.3) & (y < 0.8)
    assert trunk.sum() > 100


def test_meshes_are_read_with_their_uvs_or_unwrapped_and_bad_ones_refused(tmp_path):
    import trimesh

    cylinder = trimesh.creation.cylinder(radius=0.2, height=2.0, sections=48)
    cylinder.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))  # along y
    path = tmp_path / "branch.obj"
    cylinder.export(path)
    mesh = read_tree_mesh(path, resolution=256)
    assert "unwrapped by xatlas" in mesh.source
    side = np.abs(mesh.normals[:, 1]) < 0.2
    assert np.median(np.abs(mesh.axis[side, 1])) > 0.95  # along the cylinder
    # UVs that repeat one texture over every face (a tiling bark's, as tree generators give): no atlas
    tiled = trimesh.Trimesh(cylinder.vertices, cylinder.faces, process=False)
    tiled.visual = trimesh.visual.TextureVisuals(
        uv=np.tile([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], (len(tiled.vertices), 1))[: len(tiled.vertices)]
    )
    tiled.export(tmp_path / "tiled.obj")
    assert "UVs that overlap: unwrapped by xatlas" in read_tree_mesh(tmp_path / "tiled.obj", resolution=256).source
    empty = tmp_path / "empty.obj"
    empty.write_text("# nothing\n")
    with pytest.raises(Exception, match="no triangles|not a mesh"):
        read_tree_mesh(empty)
    fan = tmp_path / "fan.obj"  # three triangles on one edge: not a surface
    fan.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 2 5\n")
    with pytest.raises(InvalidInputError, match="more than two triangles"):
        read_tree_mesh(fan)


def test_tree_command_end_to_end(tmp_path):
    import json

    out = tmp_path / "tree"
    # a fissured bark at 256 px (the fissured grey one of the team's collection is copyleft)
    photo = tmp_path / "oak_furrowed_moss_01.png"
    write_png(photo, bark_exemplar("oak_furrowed_moss_01", 256))
    done = run("tree", "-o", str(out), "--size", "256x256", "--photo", str(photo), "--k", "2", "-q")
    assert done.returncode == 0, done.stderr
    files = {p.name for p in out.iterdir()}
    set_name = "oak_furrowed_moss_01_seed0_256x256"  # the photo's name, the seed, the atlas's size
    assert {"tree.glb", "tree_preview.png", f"{set_name}_Color.png", f"{set_name}_NormalGL.png", "report.json"} <= files
    report = json.loads((out / "report.json").read_text())
    assert "tree.glb" in report["files"] and report["flow"]["copies"] >= 7
    checked = validate_glb(out / "tree.glb")
    assert checked["errors"] == 0, checked
    # the glb is a tree mesh barkgen reads back as it is: its own UVs are an atlas
    back = read_tree_mesh(out / "tree.glb", resolution=256)
    assert back.source == str(out / "tree.glb") and len(back.faces) > 1000
    assert back.uv.min() >= 0 and back.uv.max() <= 1
    bad = tmp_path / "bad"
    done = run("tree", str(tmp_path / "missing.glb"), "-o", str(bad), "-q")
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and not bad.exists()


def test_chart_heights_are_levelled_across_their_borders():
    from barkgen.synth import OutputLinks
    from barkgen.tree import TexelMap, level_charts

    h, w = 64, 64
    covered = np.zeros((h, w), bool)
    covered[:, 4:28] = True  # chart A
    covered[:, 36:60] = True  # chart B, apart in the flat atlas, its left edge A's right on the surface
    rows = np.arange(h)
    target = np.concatenate([rows * w + 28, rows * w + 29])  # A's gutter ...
    source = np.concatenate([rows * w + 36, rows * w + 37])  # ... shows B's first columns
    links = OutputLinks((h, w), target, source)
    texels = TexelMap(
        (h, w),
        covered,
        np.where(covered, 0, -1),
        np.zeros((h, w, 3), np.float32),
        np.zeros((h, w), np.float32),
        np.ones((h, w), np.float32),
        links,
        100.0,
    )
    height = np.zeros((h, w), np.float32)
    height[:, 36:60] = 5.0 + 0.05 * rows[:, None]  # B drifts away from A along the border
    levelled = level_charts(height, texels)
    across_before = np.abs(height[:, 27] - height[:, 36]).mean()
    across_after = np.abs(levelled[:, 27] - levelled[:, 36]).mean()
    assert across_before > 5 and across_after < 0.5, (across_before, across_after)
    # inside a chart the slopes stay (a smooth correction)
    assert np.abs(np.diff(levelled[:, 40]) - np.diff(height[:, 40])).max() < 0.1
