"""Scanned sets for the tests, named as the common libraries and engines name them: the team's
scans of tests/data (colour + normal, AO, roughness; see tests/data/SOURCES.md) area-averaged
to a small size and renamed; the height is the normals integrated on the torus (the scan's own
relief), gloss and specular the roughness inverted. Nothing is read from outside tests/data."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

DATA = Path(__file__).resolve().parents[1] / "data"

#: naming style -> (file name of each source map, or None where the style has no such map)
STYLES: dict[str, dict[str, str]] = {
    "ambientcg": {
        "color": "Bark001_1K_Color.png",
        "normal": "Bark001_1K_NormalGL.png",
        "height": "Bark001_1K_Displacement.png",
        "roughness": "Bark001_1K_Roughness.png",
        "ao": "Bark001_1K_AmbientOcclusion.png",
    },
    "polyhaven": {
        "color": "bark_brown_02_diff_1k.png",
        "normal": "bark_brown_02_nor_gl_1k.png",
        "height": "bark_brown_02_disp_1k.png",
        "arm": "bark_brown_02_arm_1k.png",
    },
    "megascans": {
        "color": "Bark_vdqmbhw_1K_Albedo.jpg",
        "normal": "Bark_vdqmbhw_1K_Normal.jpg",
        "height": "Bark_vdqmbhw_1K_Displacement.jpg",
        "gloss": "Bark_vdqmbhw_1K_Gloss.jpg",
        "specular": "Bark_vdqmbhw_1K_Specular.jpg",
        "ao": "Bark_vdqmbhw_1K_AO.jpg",
        "cavity": "Bark_vdqmbhw_1K_Cavity.jpg",
    },
    "substance": {
        "color": "OakBark_BaseColor.png",
        "normal": "OakBark_Normal.png",
        "height": "OakBark_Height.png",
        "roughness": "OakBark_Roughness.png",
        "ao": "OakBark_AmbientOcclusion.png",
        "metalness": "OakBark_Metallic.png",
    },
    "cc0textures": {
        "color": "Bark01_col.jpg",
        "normal": "Bark01_nrm.jpg",
        "height": "Bark01_disp.jpg",
        "roughness": "Bark01_rgh.jpg",
        "ao": "Bark01_AO.jpg",
    },
    "gamepack": {
        "color": "oakbark_cc.png",
        "normal": "oakbark_nm.png",
        "height": "oakbark_hm.png",
        "specular": "oakbark_sc.png",
    },
    "plain": {
        "color": "oak bark albedo.png",
        "normal": "oak bark nrm.png",
        "height": "oak bark bump.png",
        "gloss": "oak bark glossiness.png",
    },
}


def source_maps(size: int, name: str = "oak_furrowed_moss_01") -> dict[str, np.ndarray]:
    """A scan's maps at ``size`` px: colour, normal (OpenGL pixels), AO, roughness, height
    (uint16), gloss, specular (the roughness inverted), metalness (none: zeros)."""
    from barkgen._shared.arrays import Boundary
    from barkgen.io import read_image
    from barkgen.material import integrate_normals
    from barkgen.material.maps import decode_normals, encode_normals

    def small(image: np.ndarray, s: int = size) -> np.ndarray:
        out = cv2.resize(image, (s, s), interpolation=cv2.INTER_AREA)
        return out[:, :, None] if out.ndim == 2 else out

    color = small(read_image(DATA / "bark" / f"{name}.jpg"))
    normals = decode_normals(small(read_image(DATA / "bark_maps" / f"{name}_normal.jpg")))
    height = integrate_normals(normals, Boundary(True))
    height = (height - height.min()) / max(float(np.ptp(height)), 1e-6)
    ao = small(read_image(DATA / "bark_maps" / f"{name}_ao.jpg"))[..., :1]
    rough = small(read_image(DATA / "bark_maps" / f"{name}_roughness.jpg"))[..., :1]
    return {
        "color": color,
        "normal": encode_normals(normals, 8),
        "height": np.round(height * 65535).astype(np.uint16)[..., None],
        "roughness": rough,
        "ao": ao,
        "gloss": 255 - rough,
        "specular": 255 - rough,
        "metalness": np.zeros_like(rough),
        "cavity": ao,
        "arm": np.concatenate([ao, rough, np.zeros_like(rough)], axis=2),
    }


def dx(normal_pixels: np.ndarray) -> np.ndarray:
    """OpenGL normal-map pixels as DirectX's (green flipped)."""
    out = normal_pixels.copy()
    out[..., 1] = np.iinfo(out.dtype).max - out[..., 1]
    return out


def write_set(folder: Path, files: dict[str, np.ndarray]) -> Path:
    """Write ``file name -> pixels`` into ``folder`` (PNG, or JPEG at quality 95)."""
    from barkgen.io import write_png

    folder.mkdir(parents=True, exist_ok=True)
    for name, pixels in files.items():
        if name.lower().endswith(".jpg"):
            pixels = (pixels // 257).astype(np.uint8) if pixels.dtype == np.uint16 else pixels
            assert cv2.imwrite(
                str(folder / name),
                pixels[..., ::-1] if pixels.shape[2] == 3 else pixels[..., 0],
                [cv2.IMWRITE_JPEG_QUALITY, 95],
            )
        else:
            write_png(folder / name, pixels)
    return folder


def style_set(folder: Path, style: str, size: int = 128) -> Path:
    """The oak scan at ``size`` px named as ``style`` names a set (:data:`STYLES`)."""
    maps = source_maps(size)
    return write_set(folder, {name: maps[kind] for kind, name in STYLES[style].items()})


# --- the names of each library read -------------------------------------------------------


import pytest  # noqa: E402

from barkgen.io import map_kind, read_scanned_set  # noqa: E402

#: style -> what the set reads: its maps, and where its roughness comes from
READ = {
    "ambientcg": ({"normals", "height", "roughness", "ao"}, "roughness"),
    "polyhaven": ({"normals", "height", "roughness", "ao", "metalness"}, "arm"),
    "megascans": ({"normals", "height", "roughness", "ao"}, "gloss"),
    "substance": ({"normals", "height", "roughness", "ao", "metalness"}, "roughness"),
    "cc0textures": ({"normals", "height", "roughness", "ao"}, "roughness"),
    "gamepack": ({"normals", "height", "roughness"}, "specular"),
    "plain": ({"normals", "height", "roughness"}, "gloss"),
}


@pytest.mark.parametrize("style", sorted(STYLES))
def test_each_librarys_names_are_read(tmp_path, style, recwarn):
    folder = style_set(tmp_path / style, style, 64)
    scan = read_scanned_set(folder)
    maps, roughness_from = READ[style]
    assert set(scan.maps) == maps
    assert scan.info["roughness_from"] == roughness_from
    assert scan.info["normal_convention"] == "gl" and scan.info["normal_convention_from"] == "height"
    assert scan.files["color"] == STYLES[style]["color"]
    assert not [w for w in recwarn if "left out" in str(w.message)]  # every file placed


@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("oak_albedo.png", "color"),
        ("oak_basecolor.png", "color"),
        ("oak_diffuse.png", "color"),
        ("oakDiffuse.png", "color"),
        ("oak_nrm.png", "normal"),
        ("oak_bump.png", "height"),
        ("oak_height.png", "height"),
        ("oak_spec.png", "specular"),
        ("oak_gloss.png", "gloss"),
        ("oak_glossiness.png", "gloss"),
        ("oak-Normal-DirectX-4096.png", "normal_dx"),
        ("OAK.NORMAL.OPENGL.2K.png", "normal_gl"),
        ("Oak_Mixed_AO.png", "ao"),
        ("oak_ORM_2048px.png", "arm"),
    ],
)
def test_words_are_cut_at_separators_and_camel_case_tags_left_out(name, kind):
    assert map_kind(name) == (map_kind(name)[0], kind)
    assert map_kind(name)[0].lower() == "oak"
