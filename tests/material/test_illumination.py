"""The photo's broad light taken out before the analysis (issue 65): measured on a photo whose
light and albedo are known (the bundled sample with its own broad light flattened, a moss patch
painted in, under a trunk's curvature falloff), and the set's real size and live adjustments.
benchmarks/bench_relief.py --light measures the four scans and the shared photos."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage as ndi

import barkgen
from barkgen.color import linear_to_srgb, srgb_to_linear
from barkgen.errors import InvalidInputError
from barkgen.material import (
    Boundary,
    MaterialOptions,
    adjust_material,
    decode_illumination,
    encode_illumination,
    equalize_light,
    estimate_illumination,
    make_material,
)
from barkgen.material.illumination import relit

LUMA = np.array([0.2126, 0.7152, 0.0722])
SIZE = 256


@pytest.fixture(scope="module")
def albedo() -> np.ndarray:
    """The sample's colour (linear) without its broad luminance (a blur of an eighth of the
    width), a bright moss patch painted at the left (columns 30-90, rows 100-160)."""
    import cv2

    photo = barkgen.read_image(barkgen.sample_exemplar_path()).astype(np.float32) / 255.0
    photo = cv2.resize(photo[..., :3], (SIZE, SIZE), interpolation=cv2.INTER_AREA)
    linear = srgb_to_linear(photo).astype(np.float64)
    broad = ndi.gaussian_filter(linear @ LUMA, SIZE / 8, mode="reflect")
    linear = linear * (broad.mean() / broad)[..., None]
    mask = np.zeros((SIZE, SIZE))
    mask[100:160, 30:90] = 1.0
    mask = ndi.gaussian_filter(mask, 4)[..., None]
    moss = np.array([0.30, 0.42, 0.12]) / (np.array([0.30, 0.42, 0.12]) @ LUMA) * (linear.mean(0).mean(0) @ LUMA) * 1.3
    return np.clip(linear * (1 - mask) + linear / linear.mean((0, 1)) * moss * mask, 0.0, 1.0)


def trunk_light() -> np.ndarray:
    """A trunk photographed round its curve: 120 degrees of it, lit from 35 degrees off axis."""
    across = np.radians((np.arange(SIZE) / (SIZE - 1) - 0.5) * 120.0)
    return np.tile(0.15 + 0.85 * np.maximum(np.cos(across - np.radians(35.0)), 0.0), (SIZE, 1))


def low_error(estimate: np.ndarray, truth: np.ndarray) -> float:
    """Mean absolute difference of the two (linear) blurred by a sixteenth of the width, each
    channel's gain matched by least squares."""
    est, tru = estimate.reshape(-1, 3), truth.reshape(-1, 3)
    est = (est * ((est * tru).sum(0) / (est * est).sum(0))).reshape(truth.shape)
    sigma = (SIZE / 16, SIZE / 16, 0)
    return float(np.abs(ndi.gaussian_filter(est, sigma) - ndi.gaussian_filter(truth, sigma)).mean())


def test_a_trunks_falloff_is_taken_out_and_the_moss_kept(albedo):
    lit = linear_to_srgb(albedo * trunk_light()[..., None])
    equalized, light = equalize_light(lit)
    # the light found falls as the trunk's does (left of the light's axis brighter than the edge)
    assert np.corrcoef(np.log(light).mean(0), np.log(trunk_light()[0]))[0, 1] > 0.95
    estimate = srgb_to_linear(equalized)
    assert low_error(estimate, albedo) <= 0.35 * low_error(srgb_to_linear(lit), albedo)
    # the moss patch's own brightness over the bark around it stays (it is of another hue)
    patch, ring = np.s_[115:145, 45:75], np.s_[115:145, 95:125]
    truth_ratio = (albedo[patch] @ LUMA).mean() / (albedo[ring] @ LUMA).mean()
    ratio = (estimate[patch] @ LUMA).mean() / (estimate[ring] @ LUMA).mean()
    assert abs(np.log(ratio / truth_ratio)) < np.log(1.2), (ratio, truth_ratio)


def test_a_photo_in_even_light_is_left_as_it_is(albedo):
    """The bark's own patches (its plates, its moss) are not light: nothing stands above what
    the bark alone gives the estimate."""
    light = estimate_illumination(linear_to_srgb(albedo))
    assert float(np.abs(np.log(light)).max()) < 0.05


def test_strength_dtype_and_channels_are_kept(albedo):
    photo8 = (linear_to_srgb(albedo * trunk_light()[..., None]) * 255 + 0.5).astype(np.uint8)
    same, _ = equalize_light(photo8, 0.0)
    assert same is photo8
    for photo in (photo8, photo8.astype(np.uint16) * 257, photo8[..., 0], np.dstack([photo8, photo8[..., :1]])):
        out, light = equalize_light(photo, 1.0)
        assert out.dtype == photo.dtype and out.shape == photo.shape and light.shape == photo.shape[:2]
    out, light = equalize_light(photo8.astype(np.float32) / 255.0)
    back = relit(out, light, 1.0)
    unclipped = (out < 0.99).all(axis=2)
    assert np.abs(back - photo8 / 255.0)[unclipped].max() < 2e-3
    half, _ = equalize_light(photo8, 0.5)
    assert np.abs(half.astype(int) - photo8).mean() < np.abs(equalize_light(photo8)[0].astype(int) - photo8).mean()
    with pytest.raises(InvalidInputError, match="strength"):
        equalize_light(photo8, 1.5)


def test_the_light_wraps_where_the_photo_does(albedo):
    photo = linear_to_srgb(
        albedo * (0.6 + 0.4 * np.sin(np.linspace(0, 2 * np.pi, SIZE, endpoint=False)))[None, :, None]
    )
    light = estimate_illumination(photo, boundary=Boundary(True))
    shifted = estimate_illumination(np.roll(photo, 64, axis=1), boundary=Boundary(True))
    np.testing.assert_allclose(shifted, np.roll(light, 64, axis=1), rtol=0.02)
    # no step across the edge it wraps along
    assert abs(np.log(light[:, 0] / light[:, -1])).max() < 3 * abs(np.log(light[:, 1] / light[:, 0])).max() + 1e-3


def test_the_light_map_round_trips():
    light = np.exp(np.linspace(-2, 2, 64, dtype=np.float32)).reshape(8, 8)
    np.testing.assert_allclose(decode_illumination(encode_illumination(light)), light, rtol=2e-4)


def test_the_set_states_its_real_size_and_carries_its_light(albedo):
    photo = linear_to_srgb(albedo[:128, :128] * trunk_light()[:128, :128, None])
    material = make_material(photo, MaterialOptions(exemplar_wrap="no", k=2, width_m=0.4))
    meta = material.metadata()
    assert meta["width_m"] == pytest.approx(0.4) and meta["real_size"] == "given"
    assert meta["displacement_depth_m"] == pytest.approx(material.depth * 0.4 / 128, rel=1e-4)
    assert meta["light_equalization"] == 1.0 and material.illumination is not None
    assumed = make_material(photo, MaterialOptions(exemplar_wrap="no", k=2))
    assert assumed.metadata()["real_size"].startswith("assumed") and assumed.metadata()["width_m"] == 0.5
    # live adjustments: twice the relief is twice as deep and steeper; the light put back
    deeper = adjust_material(material, relief=2.0)
    assert deeper.depth == pytest.approx(2 * material.depth, rel=1e-5)
    assert np.median(deeper.normals[..., 2]) < np.median(material.normals[..., 2])
    kept = adjust_material(material, equalization=0.0)
    assert kept.equalization == 0.0 and kept.metadata()["light_equalization"] == 0.0
    kept_made = make_material(photo, MaterialOptions(exemplar_wrap="no", k=2, equalize_light=0.0))
    left, right = np.s_[:, :32], np.s_[:, -32:]
    assert (kept.color[left].mean() - kept.color[right].mean()) * (
        kept_made.color[left].mean() - kept_made.color[right].mean()
    ) > 0  # the light's side is back
    with pytest.raises(InvalidInputError, match="relief"):
        adjust_material(material, relief=0.0)
