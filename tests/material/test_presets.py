"""Material sets named and packed as each engine reads them (issue 32, ``--preset``): the packed
channels are exactly the separate maps, each preset has its one normal convention, and the
Blender preset's MaterialX document validates with MaterialX's own checks."""

from __future__ import annotations

import io as _io
import json

import numpy as np
import pytest
from conftest import run
from PIL import Image

from barkgen.errors import InvalidInputError
from barkgen.io import encode_material
from barkgen.material import MaterialSet, decode_normals
from barkgen.material.presets import PRESETS, preset_file_names


def small_set(metalness: bool = False, opacity: bool = False) -> MaterialSet:
    rng = np.random.default_rng(5)
    h, w = 24, 32
    n = rng.normal(size=(h, w, 3)).astype(np.float32)
    n[..., 2] = np.abs(n[..., 2]) + 2
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    return MaterialSet(
        color=rng.random((h, w, 3), dtype=np.float32),
        height=rng.random((h, w), dtype=np.float32) * 4,
        normals=n,
        ao=rng.random((h, w), dtype=np.float32),
        roughness=rng.random((h, w), dtype=np.float32),
        metalness=rng.random((h, w), dtype=np.float32) if metalness else None,
        opacity=rng.random((h, w), dtype=np.float32) if opacity else None,
    )


def pixels(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(_io.BytesIO(data)))


@pytest.fixture(scope="module")
def sets():
    material = small_set(metalness=True)
    return material, {preset: encode_material(material, "bark", preset) for preset in PRESETS}


def test_packed_channels_are_the_separate_maps_exactly(sets):
    _, files = sets
    plain = files["ambientcg"]
    separate = {
        "ao": pixels(plain["bark_AmbientOcclusion.png"]),
        "roughness": pixels(plain["bark_Roughness.png"]),
        "metalness": pixels(plain["bark_Metalness.png"]),
    }
    for preset in ("unreal", "gltf"):
        orm = pixels(files[preset]["bark_ORM.png"])
        for channel, kind in enumerate(("ao", "roughness", "metalness")):
            np.testing.assert_array_equal(orm[..., channel], separate[kind], err_msg=f"{preset} {kind}")
    mask = pixels(files["unity"]["bark_MaskMap.png"])
    assert mask.shape[2] == 4
    np.testing.assert_array_equal(mask[..., 0], separate["metalness"])
    np.testing.assert_array_equal(mask[..., 1], separate["ao"])
    assert (mask[..., 2] == 255).all()  # no detail mask
    np.testing.assert_array_equal(mask[..., 3], 255 - separate["roughness"])  # smoothness


def test_each_preset_has_its_normal_convention(sets):
    material, files = sets
    gl = decode_normals(pixels(files["ambientcg"]["bark_NormalGL.png"]))
    assert np.degrees(np.arccos(np.clip((gl * material.normals).sum(2), -1, 1))).max() < 1.0
    dx = decode_normals(pixels(files["unreal"]["bark_NormalDX.png"]))
    np.testing.assert_allclose(dx[..., 1], -gl[..., 1], atol=1e-6)
    for preset in ("blender", "unity", "gltf"):
        names = [n for n in files[preset] if "Normal" in n]
        assert names == ["bark_NormalGL.png"], (preset, names)  # Node Wrangler wires the one there is
        meta = json.loads(files[preset]["bark.json"])
        assert meta["preset"] == preset and list(meta["normal_convention"]) == ["NormalGL"]
    assert "bark_NormalDX.png" not in files["gltf"] and "bark_NormalGL.png" not in files["unreal"]


def test_the_files_written_are_the_ones_named_before(sets):
    _, files = sets
    for preset in PRESETS:
        assert set(files[preset]) - {"bark.json"} <= set(preset_file_names("bark", preset))


def test_the_ambientcg_preset_is_todays_set_and_opacity_rides_in_alpha():
    material = small_set(opacity=True)
    files = encode_material(material, "bark", "ambientcg")
    assert sorted(files) == [
        "bark.json",
        "bark_AmbientOcclusion.png",
        "bark_Color.png",
        "bark_Displacement.png",
        "bark_NormalDX.png",
        "bark_NormalGL.png",
        "bark_Opacity.png",
        "bark_Roughness.png",
    ]
    assert "preset" not in json.loads(files["bark.json"])
    base = pixels(encode_material(material, "bark", "gltf")["bark_BaseColor.png"])
    assert base.shape[2] == 4
    np.testing.assert_array_equal(base[..., 3], pixels(files["bark_Opacity.png"]))


def test_the_blender_preset_writes_materialx_that_validates(sets):
    mx = pytest.importorskip("MaterialX")
    material, files = sets
    text = files["blender"]["bark.mtlx"].decode()
    doc = mx.createDocument()
    mx.readFromXmlString(doc, text)
    libraries = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), libraries)
    doc.setDataLibrary(libraries)
    valid, message = doc.validate()
    assert valid, message
    scale = float(doc.getNode("DS_bark").getInputValue("scale"))
    assert scale == pytest.approx(material.depth / material.shape[1], rel=1e-5)
    midlevel = float(doc.getNodeGraph("NG_bark").getNode("displacement_centred").getInputValue("in2"))
    assert midlevel == pytest.approx(material.midlevel, rel=1e-5)
    wired = {i.getAttribute("value") for i in doc.traverseTree() if i.getName() == "file"}
    assert wired == {
        "bark_Color.png",
        "bark_NormalGL.png",
        "bark_Roughness.png",
        "bark_Displacement.png",
        "bark_Metalness.png",
    }
    assert wired <= set(files["blender"])


def test_a_bad_preset_is_one_line(tmp_path):
    with pytest.raises(InvalidInputError, match="preset must be one of"):
        encode_material(small_set(), "bark", "maya")
    r = run("material", "-o", str(tmp_path / "m"), "--preset", "maya", "-q")
    assert r.returncode == 2 and "preset must be one of" in r.stderr and len(r.stderr.splitlines()) == 1
    assert not (tmp_path / "m").exists()
