"""Scanned material sets as exemplars (issue 32): a folder of maps recognised by their names
(ambientCG, Poly Haven, Megascans), decoded at their precision, normals as OpenGL unit vectors."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.errors import InvalidInputError
from barkgen.io import map_kind, read_scanned_set, recognise_set, write_png
from barkgen.material import encode_normals


@pytest.mark.parametrize(
    ("name", "stem", "kind"),
    [
        ("Bark001_2K_Color.png", "Bark001", "color"),
        ("Bark001_2K-PNG_NormalGL.png", "Bark001", "normal_gl"),
        ("Bark001_2K_NormalDX.png", "Bark001", "normal_dx"),
        ("Bark001_2K_Displacement.tif", "Bark001", "height"),
        ("Bark001_2K_AmbientOcclusion.jpg", "Bark001", "ao"),
        ("Bark001_Metalness.png", "Bark001", "metalness"),
        ("Bark001_Opacity.png", "Bark001", "opacity"),
        ("bark_willow_02_diff_4k.jpg", "bark_willow_02", "color"),
        ("bark_willow_02_nor_gl_4k.exr.png", "bark_willow_02", "normal_gl"),
        ("bark_willow_02_nor_dx_1k.png", "bark_willow_02", "normal_dx"),
        ("bark_willow_02_rough_1k.png", "bark_willow_02", "roughness"),
        ("bark_willow_02_arm_1k.png", "bark_willow_02", "arm"),
        ("bark_willow_02_disp_1k.png", "bark_willow_02", "height"),
        ("Bark_4K_Albedo.jpg", "Bark", "color"),
        ("Bark_4K_Gloss.jpg", "Bark", "gloss"),
        ("Bark_4K_Cavity.jpg", "Bark", "cavity"),
        ("Bark_4K_Height.jpg", "Bark", "height"),
        ("BARK_4K_NORMAL.JPG", "BARK", "normal"),
        ("birch_smooth_lenticels_01.jpg", "birch_smooth_lenticels_01", None),
    ],
)
def test_a_maps_kind_is_read_from_its_name(name, stem, kind):
    assert map_kind(name) == (stem, kind)


def test_a_set_is_its_maps_and_a_bare_photo_is_its_colour():
    stem, maps = recognise_set(["oak.jpg", "oak_normal.jpg", "oak_ao.jpg", "oak_roughness.jpg", "notes.txt"])
    assert stem == "oak" and maps == {
        "color": "oak.jpg",
        "normal": "oak_normal.jpg",
        "ao": "oak_ao.jpg",
        "roughness": "oak_roughness.jpg",
    }
    # ambientCG ships a preview picture named like the set: with a _Color map it is left out
    _, maps = recognise_set(["Bark001.png", "Bark001_2K_Color.png", "Bark001_2K_NormalGL.png"])
    assert maps["color"] == "Bark001_2K_Color.png"
    # both conventions of one normal map: the OpenGL one is read
    _, maps = recognise_set(["a_Color.png", "a_NormalGL.png", "a_NormalDX.png"])
    assert "normal_gl" in maps and "normal_dx" not in maps


@pytest.mark.parametrize(
    ("names", "message"),
    [
        (["a_Color.png", "a_diff.png"], "two color maps"),
        (["a_Color.png", "b_NormalGL.png"], "maps of two sets"),
        (["a_Color.png", "b.png"], "not a map of a"),
        (["a_NormalGL.png", "a_Roughness.png"], "no colour map"),
    ],
)
def test_a_set_that_is_not_one_is_refused_in_one_line(names, message):
    with pytest.raises(InvalidInputError, match=message) as info:
        recognise_set(names, folder="SET")
    assert "\n" not in str(info.value)


def _set(folder, normals, *, dx=False, bits=8, gloss=None):
    folder.mkdir()
    h, w = normals.shape[:2]
    rng = np.random.default_rng(0)
    write_png(folder / "s_Color.png", rng.integers(0, 255, (h, w, 3), dtype=np.uint8))
    pixels = encode_normals(normals, bits)
    if dx:
        pixels[..., 1] = np.iinfo(pixels.dtype).max - pixels[..., 1]
    write_png(folder / f"s_Normal{'DX' if dx else 'GL'}.png", pixels)
    if gloss is not None:
        write_png(folder / "s_Gloss.png", gloss)
    return folder


def test_dx_normals_and_gloss_are_read_as_opengl_and_roughness(tmp_path):
    normals = np.zeros((20, 24, 3), np.float32)
    normals[..., 1], normals[..., 2] = 0.6, 0.8  # tilted towards +y (up, OpenGL)
    gloss = np.full((20, 24), 51, np.uint8)
    gl = read_scanned_set(_set(tmp_path / "gl", normals))
    dx = read_scanned_set(_set(tmp_path / "dx", normals, dx=True, gloss=gloss))
    np.testing.assert_allclose(gl.normals, dx.normals, atol=1e-6)
    assert gl.normals[0, 0, 1] == pytest.approx(0.6, abs=0.01)
    np.testing.assert_allclose(dx.roughness, 1 - 51 / 255, atol=1e-6)
    assert gl.maps == ("normals",) and set(dx.maps) == {"normals", "roughness"}


def test_sixteen_bit_maps_keep_their_precision(tmp_path):
    angle = np.linspace(0, 0.3, 24, dtype=np.float32)[None, :].repeat(20, 0)
    normals = np.stack([np.sin(angle), np.zeros_like(angle), np.cos(angle)], axis=2)
    scan = read_scanned_set(_set(tmp_path / "s", normals, bits=16))
    assert scan.bits["normal_gl"] == 16
    eight = read_scanned_set(_set(tmp_path / "eight", normals, bits=8))

    def error(read):
        return np.degrees(np.arccos(np.clip((read.astype(np.float64) * normals).sum(2), -1, 1))).max()

    assert error(scan.normals) < 0.05 < error(eight.normals)


def test_maps_of_different_sizes_are_refused(tmp_path):
    write_png(tmp_path / "s_Color.png", np.zeros((20, 24, 3), np.uint8))
    write_png(tmp_path / "s_Roughness.png", np.zeros((20, 20), np.uint8))
    with pytest.raises(InvalidInputError, match="differ in size"):
        read_scanned_set(tmp_path)


def _zip(members: dict[str, bytes], *, compress: bool = False) -> bytes:
    import io
    import zipfile

    buffer = io.BytesIO()
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(buffer, "w", method) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return buffer.getvalue()


def test_a_zipped_set_is_read_flat_and_checked_before_unpacking():
    from barkgen.io import encode_png, read_set_zip, scanned_set_from_files

    colour = encode_png(np.full((32, 32, 3), 90, np.uint8))
    rough = encode_png(np.full((32, 32, 1), 40000, np.uint16))
    data = _zip(
        {
            "textures/bark_02_diff_1k.png": colour,
            "textures/bark_02_rough_1k.png": rough,
            "bark_02.blend.txt": b"not an image",
            "__MACOSX/textures/._bark_02_diff_1k.png": b"junk",
            "textures/.hidden.png": b"junk",
        }
    )
    files = read_set_zip(data, max_unpacked_bytes=10**6)
    assert sorted(files) == ["bark_02_diff_1k.png", "bark_02_rough_1k.png"]
    scan = scanned_set_from_files(files)
    assert scan.name == "bark_02" and scan.maps == ("roughness",)
    assert scan.roughness.dtype == np.float32 and np.allclose(scan.roughness, 40000 / 65535)
    # a zip bomb: its declared sizes are refused before anything is unpacked
    bomb = _zip({"a_Color.png": bytes(5 * 10**6)}, compress=True)
    assert len(bomb) < 10**5
    with pytest.raises(InvalidInputError, match="unpack to 5 MB, more than the 1 MB allowed"):
        read_set_zip(bomb, max_unpacked_bytes=10**6)
    for payload, said in (
        (b"PK\x03\x04 broken", "not a zip"),
        (_zip({"readme.txt": b"hi"}), "holds no image"),
        (_zip({"a/x_Color.png": colour, "b/x_Color.png": colour}), "two files named x_Color.png"),
    ):
        with pytest.raises(InvalidInputError, match=said):
            read_set_zip(payload, max_unpacked_bytes=10**6, where="set.zip")
