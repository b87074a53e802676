"""The trunk's glTF binary passes the Khronos glTF validator with no error and no warning
(issue 32): it carries tangents, unit and orthogonal to the normals, in the handedness the
normal map needs."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import validate_glb as validate

from barkgen.io import encode_glb, vertex_tangents
from barkgen.material import Boundary, MaterialSet
from barkgen.render import trunk_mesh


def small_set(metalness: bool) -> MaterialSet:
    rng = np.random.default_rng(2)
    h, w = 64, 64
    y, x = np.mgrid[0:h, 0:w]
    height = (np.sin(x / 4.0) * 2 + np.cos(y / 6.0)).astype(np.float32)
    from barkgen.material import derived_maps

    normals, ao = derived_maps(height, boundary=Boundary(True))
    return MaterialSet(
        color=rng.random((h, w, 3), dtype=np.float32),
        height=height,
        normals=normals,
        ao=ao,
        roughness=rng.random((h, w), dtype=np.float32),
        tile=True,
        metalness=rng.random((h, w), dtype=np.float32) if metalness else None,
    )


def test_tangents_follow_u_and_the_image_up():
    """On a flat quad facing +z with u along +x and the image's up along +y, the tangent is +x
    and the basis is right-handed (w = 1); mirrored u gives -x and still a unit vector."""
    positions = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)  # glTF: v grows down the image
    tangents = vertex_tangents(positions, normals, uv, faces)
    np.testing.assert_allclose(tangents, np.tile([1.0, 0.0, 0.0, 1.0], (4, 1)), atol=1e-6)
    mirrored = vertex_tangents(positions, normals, uv * [-1, 1] + [1, 0], faces)
    np.testing.assert_allclose(mirrored[:, :3], np.tile([-1.0, 0.0, 0.0], (4, 1)), atol=1e-6)
    assert (mirrored[:, 3] == -1).all()


@pytest.mark.parametrize("metalness, width_m", [(False, None), (True, 0.3)])
def test_the_trunk_glb_passes_the_khronos_validator_clean(tmp_path, metalness, width_m):
    """With and without metalness; at the set's real size (its width known) and not."""
    pygltflib = pytest.importorskip("pygltflib")
    material = small_set(metalness).with_width_m(width_m)
    path = tmp_path / "trunk.glb"
    path.write_bytes(encode_glb(trunk_mesh(material, segments=32), material))
    report = validate(path)
    assert (report["errors"], report["warnings"]) == (0, 0), report["messages"]
    gltf = pygltflib.GLTF2().load(str(path))
    attributes = gltf.meshes[0].primitives[0].attributes
    assert attributes.TANGENT is not None
    blob = gltf.binary_blob()

    def read(index: int, width: int) -> np.ndarray:
        accessor = gltf.accessors[index]
        view = gltf.bufferViews[accessor.bufferView]
        start = (view.byteOffset or 0) + (accessor.byteOffset or 0)
        return np.frombuffer(blob, np.float32, accessor.count * width, start).reshape(-1, width)

    tangents, normals = read(attributes.TANGENT, 4), read(attributes.NORMAL, 3)
    np.testing.assert_allclose(np.linalg.norm(tangents[:, :3], axis=1), 1.0, atol=1e-5)
    assert np.abs((tangents[:, :3] * normals).sum(1)).max() < 1e-4
    assert set(np.unique(tangents[:, 3])) <= {-1.0, 1.0}
