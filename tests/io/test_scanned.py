"""Scanned material sets as exemplars (issue 32): a folder of maps recognised by their names
(ambientCG, Poly Haven, Megascans), decoded at their precision, normals as OpenGL unit vectors."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.errors import InvalidInputError
from barkgen.io import map_kind, read_scanned_set, recognise_set, write_png
from barkgen.io.scanned import UnplacedFileWarning
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
        (["a_Color.png", "b_Color.png"], "maps of two sets"),
        (["a.png", "b.png"], "maps of two sets"),
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


def test_a_file_it_cannot_place_is_named_in_one_line_and_the_set_made_from_the_rest():
    names = ["a_Color.png", "b_NormalGL.png", "b.png", "a_Translucency.png", "a_bump.png", "a_Height.png", "a.png"]
    with pytest.warns(UnplacedFileWarning) as caught:
        stem, maps = recognise_set(names, folder="SET")
    assert stem == "a" and maps == {"color": "a_Color.png", "height": "a_Height.png"}
    said = sorted(str(w.message) for w in caught)
    assert len(said) == 4 and all("\n" not in line and "left out" in line for line in said)
    for name in ("a_Translucency.png", "a_bump.png", "b.png", "b_NormalGL.png"):
        assert sum(line.startswith(f"SET/{name}:") for line in said) == 1, name


def test_maps_of_three_sizes_are_resampled_to_the_colours(tmp_path):
    """Colour 256, normal 64, height 32 (16-bit): all read at 256, area-averaged or bicubic,
    wrapping where each map tiles, the normals unit vectors, the height's 16 bits kept."""
    from barkgen.io.scanned_maps import resample_map

    y, x = np.mgrid[0:32, 0:32] / 32.0
    height = 0.5 + 0.4 * np.sin(2 * np.pi * x) * np.cos(2 * np.pi * y)  # tiles
    write_png(tmp_path / "s_Color.png", np.full((256, 256, 3), 120, np.uint8))
    write_png(tmp_path / "s_Height.png", np.round(height * 65535).astype(np.uint16)[..., None])
    angle = 0.3 * np.sin(2 * np.pi * np.mgrid[0:64, 0:64][1] / 64.0)
    normals = np.stack([np.sin(angle), np.zeros_like(angle), np.cos(angle)], axis=2)
    write_png(tmp_path / "s_NormalGL.png", encode_normals(normals, 16))
    scan = read_scanned_set(tmp_path)
    assert scan.height.shape == (256, 256) and scan.normals.shape == (256, 256, 3)
    assert scan.bits["height"] == 16 and scan.info["sizes"]["s_Height.png"] == [32, 32]
    assert scan.wraps["height"] == (True, True) and scan.wraps["normals"] == (True, True)
    assert np.abs(np.linalg.norm(scan.normals, axis=2) - 1).max() < 1e-5
    fine_y, fine_x = np.mgrid[0:256, 0:256]
    truth = 0.5 + 0.4 * np.sin(2 * np.pi * (fine_x + 0.5 - 4) / 256) * np.cos(2 * np.pi * (fine_y + 0.5 - 4) / 256)
    error = np.abs(scan.height - truth)
    assert error.max() < 6e-3  # bicubic's own error on a sine of 32 samples a period
    assert max(error[:4].max(), error[-4:].max(), error[:, :4].max(), error[:, -4:].max()) <= error[8:-8, 8:-8].max()
    # more levels than 8 bits hold: the 16 bits were kept through the resampling
    assert len(np.unique(scan.height)) > 256
    # area-averaged down: a 2x2 checker averages to its mean
    checker = np.indices((8, 8)).sum(0) % 2
    np.testing.assert_allclose(resample_map(checker.astype(np.float32), (4, 4)), 0.5, atol=1e-6)


def test_a_map_that_does_not_tile_is_not_resampled_round_its_edge():
    from barkgen.io.scanned_maps import own_wraps, resample_map

    ramp = np.repeat(np.linspace(0, 1, 32, dtype=np.float32)[:, None], 32, axis=1)  # a cliff last row -> first
    assert own_wraps(ramp)[0] is False
    up = resample_map(ramp, (128, 128), wraps=own_wraps(ramp))
    assert up[0].max() < 0.02 and up[-1].min() > 0.98  # no wrap: the edge rows are not blended together


def _relief(size: int = 96) -> tuple[np.ndarray, np.ndarray]:
    """A height in [0, 1] and its OpenGL normals, by the project's :func:`normal_map`."""
    from scipy import ndimage

    from barkgen.material.maps import normal_map

    rng = np.random.default_rng(3)
    height = ndimage.gaussian_filter(rng.random((size, size)), 3, mode="wrap")
    height = (height - height.min()) / np.ptp(height)
    return height, normal_map(height * 20.0)


def test_the_green_convention_is_told_from_the_height():
    """OpenGL's green rises where the height rises down the rows; DirectX's falls; a height
    stored as depth flips both slopes, and is still read right."""
    from barkgen.io.scanned_maps import normal_convention_evidence

    height, gl = _relief()
    flipped = gl * np.array([1, -1, 1], np.float32)
    assert normal_convention_evidence(gl, height)[0] == "gl"
    assert normal_convention_evidence(flipped, height)[0] == "dx"
    assert normal_convention_evidence(gl, 1 - height)[0] == "gl"
    assert normal_convention_evidence(gl, np.zeros_like(height))[0] is None


@pytest.mark.parametrize(
    ("name", "with_height", "read_as", "source"),
    [
        ("s_Normal.png", True, "dx", "height"),
        ("s_NormalGL.png", True, "dx", "height"),
        ("s_NormalDX.png", False, "dx", "name"),
        ("s_Normal.png", False, "gl", "default"),
    ],
)
def test_a_dx_normal_map_is_read_as_opengl(tmp_path, name, with_height, read_as, source):
    height, gl = _relief()
    write_png(tmp_path / "s_Color.png", np.full(height.shape + (3,), 99, np.uint8))
    pixels = encode_normals(gl, 16)
    pixels[..., 1] = 65535 - pixels[..., 1]  # DirectX
    write_png(tmp_path / name, pixels)
    if with_height:
        write_png(tmp_path / "s_Height.png", np.round(height * 65535).astype(np.uint16)[..., None])
    if name == "s_NormalGL.png":  # the name says GL, the height says DX: said in one line
        with pytest.warns(UserWarning, match=r"s_NormalGL.png: named GL but its green follows DX") as caught:
            scan = read_scanned_set(tmp_path)
        assert all("\n" not in str(w.message) for w in caught)
    else:
        scan = read_scanned_set(tmp_path)
    assert (scan.info["normal_convention"], scan.info["normal_convention_from"]) == (read_as, source)
    if read_as == "dx":
        assert np.degrees(np.arccos(np.clip((scan.normals * gl).sum(2), -1, 1))).max() < 0.1


def test_a_specular_map_becomes_roughness_where_the_set_has_none(tmp_path):
    from barkgen.io.scanned_maps import SPECULAR_ROUGHNESS

    write_png(tmp_path / "s_cc.png", np.full((16, 16, 3), 99, np.uint8))
    level = np.tile(np.linspace(0, 255, 16).astype(np.uint8), (16, 1))[..., None]
    write_png(tmp_path / "s_sc.png", level)
    scan = read_scanned_set(tmp_path)
    assert scan.info["roughness_from"] == "specular"
    assert scan.roughness[:, 0].min() == pytest.approx(SPECULAR_ROUGHNESS[1], abs=0.01)  # dull: rough
    assert scan.roughness[:, -1].max() == pytest.approx(SPECULAR_ROUGHNESS[0], abs=0.01)  # shiny: smooth
    assert (np.diff(scan.roughness, axis=1) <= 1e-6).all()
    write_png(tmp_path / "s_Roughness.png", level)  # a roughness map wins
    assert read_scanned_set(tmp_path).info["roughness_from"] == "roughness"


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
