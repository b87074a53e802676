"""Shape from shading and the joint fit of light and height (wang2003 §3.4; issue 33, part 2):
on rendered surfaces whose height and light are known."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import ndimage as ndi

from barkgen.color import linear_to_srgb
from barkgen.errors import InvalidInputError
from barkgen.material import (
    Boundary,
    HeightConfig,
    Light,
    MaterialOptions,
    estimate_height,
    make_material,
    normal_map,
    shading,
)
from barkgen.material.shading import (
    fit_light_azimuth,
    shading_confidence,
    shape_from_shading,
    with_shading_height,
)


def furrowed(n: int = 192, seed: int = 4) -> np.ndarray:
    """A tileable height (px) of upright furrows: noise stretched along the rows, as bark's."""
    noise = np.random.default_rng(seed).normal(0, 1, (n, n))
    height = ndi.gaussian_filter(noise, (6, 2), mode="wrap")
    return (height / height.std() * 1.5).astype(np.float32)


def photographed(height: np.ndarray, light: Light, *, occlusion: float = 0.0) -> np.ndarray:
    """``height`` under ``light`` with an ambient of 0.25 (sRGB, grey albedo 0.5), darkened in
    its low places by ``occlusion`` (what a sky's light does to furrows)."""
    shade = 0.25 + 0.75 * np.maximum(shading(normal_map(height, boundary=Boundary(True)), light), 0.0)
    low = ndi.gaussian_filter(height, 2, mode="wrap")
    shade = shade * (1.0 - occlusion * (low < 0) * np.minimum(-low / 2, 1.0))
    return np.repeat(linear_to_srgb(0.5 * shade)[..., None], 3, axis=2).astype(np.float32)


def band(height: np.ndarray) -> np.ndarray:
    return height - ndi.gaussian_filter(height, 16, mode="wrap")


def corr(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.corrcoef(np.ravel(a), np.ravel(b))[0, 1])


def azimuth_error(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def test_shape_from_shading_recovers_a_height_the_luminance_does_not_show():
    """Under a directional light the luminance follows the slope along the light, so it says
    nothing of the height itself; integrated along the light it gives the height back."""
    height = furrowed()
    photo = photographed(height, Light(30.0, 35.0))
    assert abs(corr(band(photo[..., 0]), band(height))) < 0.15
    assert corr(band(shape_from_shading(photo, 30.0, boundary=Boundary(True))), band(height)) > 0.7
    # told the opposite light, the same shading gives the height upside down
    assert corr(band(shape_from_shading(photo, 210.0, boundary=Boundary(True))), band(height)) < -0.7


@pytest.fixture(scope="module")
def pine_scan():
    """The plated pine's scanned normals and AO, and its colour photo flattened (its fine
    luminance divided out: an albedo without the photo's own shading), full size."""
    from conftest import BARK, BARK_MAPS

    from barkgen._shared.arrays import unit_float
    from barkgen.io import read_image
    from barkgen.material import decode_normals
    from barkgen.material.height import luminance

    maps = BARK_MAPS
    normals = decode_normals(read_image(maps / "pine_plated_01_normal.jpg"))
    ao = read_image(maps / "pine_plated_01_ao.jpg").astype(np.float32)
    ao = (ao[..., 0] if ao.ndim == 3 else ao) / 255.0
    photo = unit_float(read_image(BARK / "pine_plated_01.jpg"))
    lum = np.maximum(luminance(photo), 1e-3)
    albedo = np.clip(photo * (ndi.gaussian_filter(lum, 16) / lum)[..., None], 0, 1)
    return normals, ao, albedo.astype(np.float32)


@pytest.mark.parametrize("azimuth", [30.0, 150.0, 260.0])
def test_the_joint_fit_finds_the_light_of_a_rendered_scan(pine_scan, azimuth):
    """The scanned pine, lit from three sides at 35° with its own AO: the azimuth whose
    integrated shading agrees best with the light-independent height cues is the light's,
    within 20°, and make_material finds it too. (bench_relief.py measures all four scans.)"""
    from barkgen.color import srgb_to_linear

    normals, ao, albedo = pine_scan
    shade = (0.25 + 0.75 * np.maximum(shading(normals, Light(azimuth, 35.0)), 0.0)) * ao
    photo = np.clip(linear_to_srgb(srgb_to_linear(albedo) * shade[..., None]), 0, 1).astype(np.float32)
    cue = estimate_height(photo)
    found, agreement = fit_light_azimuth(photo, cue)
    assert azimuth_error(found, azimuth) <= 20 and agreement > 0.04
    material = make_material(photo, MaterialOptions(exemplar_wrap="no"))
    # make_material's cues add the label map: the same fit, within the same margin
    assert azimuth_error(material.light.azimuth, azimuth) <= 20 and material.light.correlation > 0.04


def test_the_shading_joins_the_height_as_far_as_it_is_trusted():
    height = furrowed(96)
    photo = photographed(height, Light(60.0, 35.0))
    cue = np.zeros_like(height) + np.linspace(0, 1, 96, dtype=np.float32)[None, :]
    assert np.array_equal(with_shading_height(photo, cue, Light(60.0, 35.0), weight=0.0, boundary=Boundary(True)), cue)
    joint = with_shading_height(photo, height, Light(60.0, 35.0), weight=1.0, boundary=Boundary(True))
    assert corr(band(joint), band(height)) > 0.9
    assert shading_confidence(Light(60.0, 35.0), given=True) == 1.0
    assert shading_confidence(Light(60.0, 35.0, 0.01), given=False) == 0.0
    assert shading_confidence(Light(60.0, 35.0, 0.5), given=False) == 1.0


def test_the_shading_weight_is_checked():
    with pytest.raises(InvalidInputError, match="shading's weight"):
        HeightConfig(shading_weight=-1.0)
    # a light the user gives is trusted: its shape from shading joins the height; weight 0
    # leaves the cues' height as it is
    height = furrowed(128)
    photo = photographed(height, Light(60.0, 35.0), occlusion=0.3)
    given = MaterialOptions(light=Light(60.0, 35.0), exemplar_wrap="yes", k=2, equalize_light=0.0)
    joined = make_material(photo, given)
    off = make_material(photo, dataclasses.replace(given, height=HeightConfig(shading_weight=0.0)))
    assert np.allclose(off.height, estimate_height(photo, off_labels(photo), boundary=Boundary(True)), atol=1e-4)
    assert corr(band(joined.height), band(height)) > corr(band(off.height), band(height)) + 0.2


def off_labels(photo: np.ndarray) -> np.ndarray:
    """The label map make_material makes for ``photo`` (k 2, seed 0, wrapping)."""
    from barkgen.labels import color_regions
    from barkgen.labels.regions import to_codes

    return to_codes(color_regions(photo, 2, seed=0, wrap=(True, True)))[0]
