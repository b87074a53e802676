"""The trunk as glTF 2.0 binary (``.glb``) with its material set's textures, and the vertex
tangents glTF asks for beside a normal texture (glTF 2.0 §3.7.2.1: without them a viewer makes
its own and the Khronos validator warns)."""

from __future__ import annotations

import json
import struct

import numpy as np

#: glTF component types -> numpy dtypes (glTF 2.0 §3.6.2.2)
_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
_GLB_MAGIC, _JSON, _BIN = 0x46546C67, 0x4E4F534A, 0x004E4942


def encode_glb(mesh, material) -> bytes:
    """The trunk as a glTF 2.0 binary with the material set's textures (needs the ``[gltf]`` extra).

    Base colour, normal (OpenGL, as glTF fixes) and one occlusion-roughness-metallic image
    (R = AO, G = roughness, B = metalness, 0 where the set has none) used for both slots; the
    vertices carry tangents (:func:`add_tangents`).

    Parameters
    ----------
    mesh : TrunkMesh or TreeMesh
        The trunk (:func:`barkgen.render.trunk_mesh`) or a tree (:mod:`barkgen.tree`): its
        ``vertices``, ``faces``, glTF ``uv`` and, when it has them, ``normals``.
    material : MaterialSet
        The set whose maps become its textures.

    Returns
    -------
    bytes
        The ``.glb`` file.

    Raises
    ------
    MissingExtraError
        trimesh is not installed (``pip install 'barkgen[gltf]'``).

    References
    ----------
    .. [1] laitoch2018, §5.4 (bark projected onto a cylinder).
    """
    from barkgen._shared.extras import require_extra

    require_extra("gltf", "glTF export")
    import trimesh
    from PIL import Image

    from barkgen._shared.arrays import as_uint8

    images = {name: as_uint8(pixels) for name, pixels in material.images("m").items()}
    metalness = images.get("m_Metalness.png", np.zeros_like(images["m_Roughness.png"]))
    orm_image = Image.fromarray(
        np.stack([images["m_AmbientOcclusion.png"], images["m_Roughness.png"], metalness], axis=-1)
    )
    pbr = trimesh.visual.material.PBRMaterial(
        name="bark",
        baseColorTexture=Image.fromarray(images["m_Color.png"]),
        normalTexture=Image.fromarray(images["m_NormalGL.png"]),
        occlusionTexture=orm_image,
        metallicRoughnessTexture=orm_image,
        metallicFactor=1.0 if "m_Metalness.png" in images else 0.0,
        roughnessFactor=1.0,
        doubleSided=False,
    )
    # trimesh keeps UVs with v up and flips them for glTF: hand it 1 - v
    uv = np.column_stack([mesh.uv[:, 0], 1.0 - mesh.uv[:, 1]])
    # a mesh that knows its normals (a tree's, continuous across its atlas's borders) gives them
    normals = getattr(mesh, "normals", None)
    tm = trimesh.Trimesh(
        vertices=mesh.vertices,
        faces=mesh.faces,
        vertex_normals=None if normals is None else np.asarray(normals, np.float64),
        visual=trimesh.visual.TextureVisuals(uv=uv, material=pbr),
        process=False,
    )
    exported = tm.export(file_type="glb", include_normals=True)
    assert isinstance(exported, bytes)  # (a GLB export is bytes)
    return add_tangents(exported)


def _chunks(glb: bytes) -> tuple[dict, bytearray]:
    magic, version, length = struct.unpack_from("<III", glb, 0)
    if magic != _GLB_MAGIC or version != 2 or length != len(glb):
        raise ValueError("not a glTF 2.0 binary")
    json_length, json_type = struct.unpack_from("<II", glb, 12)
    document = json.loads(glb[20 : 20 + json_length])
    offset = 20 + json_length
    binary = bytearray()
    if offset < length:
        bin_length, bin_type = struct.unpack_from("<II", glb, offset)
        if bin_type != _BIN or json_type != _JSON:
            raise ValueError("not a glTF 2.0 binary")
        binary = bytearray(glb[offset + 8 : offset + 8 + bin_length])
    return document, binary


def _glb(document: dict, binary: bytes | bytearray) -> bytes:
    text = json.dumps(document, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary = bytes(binary) + b"\0" * (-len(binary) % 4)
    length = 12 + 8 + len(text) + 8 + len(binary)
    return (
        struct.pack("<III", _GLB_MAGIC, 2, length)
        + struct.pack("<II", len(text), _JSON)
        + text
        + struct.pack("<II", len(binary), _BIN)
        + binary
    )


def _accessor(document: dict, binary: bytes | bytearray, index: int) -> np.ndarray:
    accessor = document["accessors"][index]
    view = document["bufferViews"][accessor["bufferView"]]
    dtype = np.dtype(_COMPONENTS[accessor["componentType"]])
    width = _WIDTHS[accessor["type"]]
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    stride = view.get("byteStride", width * dtype.itemsize)
    rows = np.ndarray(
        (accessor["count"], width), dtype=dtype, buffer=bytes(binary), offset=start, strides=(stride, dtype.itemsize)
    )
    return np.array(rows)


def vertex_tangents(positions: np.ndarray, normals: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per-vertex tangents ``(n, 4)``: the direction of increasing ``u`` in the surface,
    orthogonal to the normal, unit length, and ``w`` = ±1 the handedness of the basis whose
    bitangent points to increasing image-up (``1 - v`` of glTF's UVs), from the triangles'
    position and UV differences (Lengyel 2001), summed over the triangles at a vertex."""
    p = np.asarray(positions, np.float64)
    n = np.asarray(normals, np.float64)
    st = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).astype(np.float64)
    i0, i1, i2 = (faces[:, k] for k in range(3))
    e1, e2 = p[i1] - p[i0], p[i2] - p[i0]
    d1, d2 = st[i1] - st[i0], st[i2] - st[i0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    r = np.where(np.abs(det) > 1e-20, 1.0 / np.where(det == 0, 1.0, det), 0.0)[:, None]
    t = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r
    b = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r
    tangent, bitangent = np.zeros_like(p), np.zeros_like(p)
    for index in (i0, i1, i2):
        np.add.at(tangent, index, t)
        np.add.at(bitangent, index, b)
    tangent -= n * (n * tangent).sum(1, keepdims=True)  # Gram-Schmidt against the normal
    length = np.linalg.norm(tangent, axis=1, keepdims=True)
    # a vertex with no UV spread: any direction orthogonal to the normal
    fallback = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    tangent = np.where(length > 1e-12, tangent / np.maximum(length, 1e-12), fallback)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    handedness = np.where((np.cross(n, tangent) * bitangent).sum(1) < 0.0, -1.0, 1.0)
    return np.column_stack([tangent, handedness]).astype(np.float32)


def add_tangents(glb: bytes) -> bytes:
    """A ``.glb`` whose triangle primitives with a normal texture's inputs (``NORMAL``,
    ``TEXCOORD_0``) and no ``TANGENT`` get one (:func:`vertex_tangents`), appended to its
    binary chunk."""
    document, binary = _chunks(glb)
    for mesh in document.get("meshes", []):
        for primitive in mesh["primitives"]:
            attributes = primitive["attributes"]
            if "TANGENT" in attributes or not {"NORMAL", "TEXCOORD_0", "POSITION"} <= set(attributes):
                continue
            if primitive.get("mode", 4) != 4 or "indices" not in primitive:
                continue
            positions = _accessor(document, binary, attributes["POSITION"])
            tangents = vertex_tangents(
                positions,
                _accessor(document, binary, attributes["NORMAL"]),
                _accessor(document, binary, attributes["TEXCOORD_0"]),
                _accessor(document, binary, primitive["indices"]).reshape(-1, 3).astype(np.int64),
            )
            binary.extend(b"\0" * (-len(binary) % 4))
            document["bufferViews"].append(
                {"buffer": 0, "byteOffset": len(binary), "byteLength": tangents.nbytes, "target": 34962}
            )
            binary.extend(tangents.astype("<f4").tobytes())
            document["accessors"].append(
                {
                    "bufferView": len(document["bufferViews"]) - 1,
                    "componentType": 5126,
                    "count": len(tangents),
                    "type": "VEC4",
                }
            )
            attributes["TANGENT"] = len(document["accessors"]) - 1
    document["buffers"][0]["byteLength"] = len(binary)
    return _glb(document, binary)
