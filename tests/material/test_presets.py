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
from barkgen.io.material import material_file_names
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
        pixel_size_m=0.01,
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
        assert set(files[preset]) - {"bark.json", "bark_blender.py"} <= set(preset_file_names("bark", preset))
        assert set(files[preset]) <= set(material_file_names("bark", preset))


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
        "bark_blender.py",
    ]
    assert json.loads(files["bark.json"])["preset"] == "ambientcg"  # (every record states its preset)
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
    assert scale == pytest.approx(material.physical_size()["displacement_depth_m"], rel=1e-5)
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


def test_resampled_sets_are_the_same_bark_smaller():
    """A set of sizes from one seed (``--sizes``): the small set is the large one resampled
    (the colour distance to the large colour area-averaged <= 0.2 CIELAB, and pixel for pixel
    within 1 %), normals unit, the displacement's depth as a fraction of the width kept."""
    import cv2
    from conftest import bark_exemplar

    from barkgen import evaluate
    from barkgen.pipeline import GenerateOptions, generate

    photo = bark_exemplar("oak_furrowed_moss_01", 128)
    large = generate(photo, GenerateOptions(size=256, tile=True, material=True, seed=1)).material
    small = large.resampled((64, 64))
    assert small.shape == (64, 64) and np.abs(np.linalg.norm(small.normals, axis=2) - 1).max() < 1e-5
    assert small.depth / 64 == pytest.approx(large.depth / 256, rel=0.15)
    reference = cv2.resize(large.color, (64, 64), interpolation=cv2.INTER_AREA)
    # measured 0.0 (the same colours); the same colours 0.05 brighter are 1.9 away
    assert evaluate.colour_distance(small.color, reference) <= 0.2
    assert np.abs(small.color - reference).mean() < 0.01
    # the tile still closes: the resampled colour steps across its edge as inside
    inner = np.abs(np.diff(small.color, axis=1)).mean()
    assert np.abs(small.color[:, 0] - small.color[:, -1]).mean() < 2 * inner


def test_cli_sizes_writes_one_tagged_set_per_width(tmp_path):
    out = tmp_path / "out"
    r = run("generate", "-o", str(out), "--size", "256x128", "--sizes", "128,512", "--tile", "-q")
    assert r.returncode == 0, r.stderr
    from barkgen.io import read_image

    assert read_image(out / "texture.png").shape[:2] == (256, 512)  # as wide as the largest
    assert read_image(out / "sample_bark_seed0_128x64_Color.png").shape[:2] == (64, 128)
    assert read_image(out / "sample_bark_seed0_512x256_NormalGL.png").shape[:2] == (256, 512)
    assert not list(out.glob("*_Color.png"))[2:]  # two sets, no untagged one
    r = run("generate", "-o", str(out), "--sizes", "2x", "-q")
    assert r.returncode == 2 and "--sizes" in r.stderr and len(r.stderr.splitlines()) == 1


def test_the_exr_height_is_the_displacement_in_float(tmp_path):
    """``--exr-height``: NAME_Displacement.exr holds the displacement as 32-bit float, the
    16-bit PNG's values without their rounding."""
    OpenEXR = pytest.importorskip("OpenEXR")
    material = small_set()
    files = encode_material(material, "bark", exr_height=True)
    (tmp_path / "d.exr").write_bytes(files["bark_Displacement.exr"])
    with OpenEXR.File(str(tmp_path / "d.exr")) as exr:
        values = exr.channels()["Y"].pixels
    np.testing.assert_array_equal(values, material.displacement().astype(np.float32))
    png = pixels(files["bark_Displacement.png"]).astype(np.float64) / 65535
    assert np.abs(png - values).max() <= 0.5 / 65535 + 1e-7
    assert "bark_Displacement.exr" in json.loads(files["bark.json"])["files"]
    r = run("material", "-o", str(tmp_path / "m"), "--exr-height", "--name", "bark", "-q")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "m" / "bark_1K_Displacement.exr").stat().st_size > 0  # (the 1024 px sample)
