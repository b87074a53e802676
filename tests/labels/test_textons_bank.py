"""wang2003 §3.2 to the letter: the filter bank's three scales a half-octave apart and six
orientations, texton channels merged by what they are (their textons) or by colour, and each
channel shown over the photo."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run

from barkgen.errors import InvalidInputError
from barkgen.io import read_image, write_png
from barkgen.labels import auto_merge, channel_previews, filter_bank, texton_channels, texton_regions
from barkgen.labels.textons import FILTER_SCALES, N_ORIENTATIONS


def spectral_peak(kernel: np.ndarray) -> tuple[float, float]:
    """The filter's strongest frequency: its radius (radians per px) and its direction (degrees
    in [0, 180), +x right, rows down)."""
    size = 256
    padded = np.zeros((size, size))
    padded[: kernel.shape[0], : kernel.shape[1]] = kernel
    power = np.abs(np.fft.fft2(padded))
    iy, ix = np.unravel_index(np.argmax(power), power.shape)
    fy = np.fft.fftfreq(size)[iy] * 2 * np.pi
    fx = np.fft.fftfreq(size)[ix] * 2 * np.pi
    return float(np.hypot(fx, fy)), float(np.degrees(np.arctan2(fy, fx)) % 180.0)


def test_each_filter_has_its_scale_and_orientation():
    """Even filters (second derivative across the orientation) peak at sqrt(2) / sigma, odd ones
    (first derivative) at 1 / sigma, in the direction across their orientation; the three
    scales are a half-octave apart (sqrt 2), the six orientations 30 degrees apart."""
    bank = filter_bank()
    assert len(bank) == 36
    assert np.allclose(np.diff(np.log2(FILTER_SCALES)), 0.5)
    n = len(FILTER_SCALES) * N_ORIENTATIONS
    for phase, (filters, law) in enumerate(((bank[:n], np.sqrt(2.0)), (bank[n:], 1.0))):
        for s, sigma in enumerate(FILTER_SCALES):
            for o in range(N_ORIENTATIONS):
                radius, angle = spectral_peak(filters[s * N_ORIENTATIONS + o])
                assert radius == pytest.approx(law / sigma, rel=0.12), (phase, s, o)
                off = abs((angle - 180.0 * o / N_ORIENTATIONS + 90.0) % 180.0 - 90.0)
                assert off <= 6.0, (phase, s, o, angle)


def stripes(n: int = 96) -> np.ndarray:
    """Left half upright stripes, right half level stripes, both of the same two greys."""
    y, x = np.mgrid[0:n, 0:n]
    grey = np.where(x < n // 2, (x // 3) % 2, (y // 3) % 2).astype(np.float32)
    rng = np.random.default_rng(0)
    image = 0.35 + 0.3 * grey + rng.normal(0, 0.01, (n, n))
    return np.repeat(np.clip(image, 0, 1)[..., None], 3, axis=2).astype(np.float32)


def test_channels_merge_by_texture_or_by_colour():
    """By texture the two stripe directions become the two labels (each half one label), though
    both halves have the same two greys; by colour the greys do, in both halves."""
    image = stripes()
    textons, responses = texton_channels(image, 12, seed=0)
    by_texture = texton_regions(image, 2, n_textons=12, seed=0, merge_by="texture", min_region=16)
    left, right = by_texture[8:-8, 8:40], by_texture[8:-8, 56:-8]
    assert np.unique(left).size == 1 and np.unique(right).size == 1 and left[0, 0] != right[0, 0]
    groups = auto_merge(textons, image, 2, by="colour", responses=responses)
    by_colour = np.zeros(textons.shape, np.int32)
    for i, group in enumerate(groups):
        by_colour[np.isin(textons, group)] = i
    assert 0.2 < np.mean(by_colour[:, :48]) < 0.8 and 0.2 < np.mean(by_colour[:, 48:]) < 0.8
    with pytest.raises(InvalidInputError, match="texture or colour"):
        auto_merge(textons, image, 2, by="shape")


def test_each_channel_is_shown_over_the_photo(tmp_path):
    image = stripes(64)
    textons, _ = texton_channels(image, 6, seed=0)
    tiles = channel_previews(image, textons)
    assert len(tiles) == np.unique(textons).size
    photo = (np.clip(image, 0, 1) * 255).round().astype(np.uint8)
    for t, tile in zip(np.unique(textons), tiles):
        inside = textons == t
        assert np.array_equal(tile[inside], photo[inside])  # the channel at full brightness
        assert tile[~inside].mean() < 0.6 * photo[~inside].mean() + 40  # the rest dimmed (or edged)
    path = tmp_path / "photo.png"
    write_png(path, photo)
    done = run("textons", str(path), "-o", str(tmp_path / "t"), "--textons", "6", "--preview", str(tmp_path / "p.png"))
    assert done.returncode == 0, done.stderr
    assert read_image(tmp_path / "p.png").ndim == 3
    labelled = run("labels", str(path), "-o", str(tmp_path / "l.png"), "--method", "texton", "--merge-by", "colour")
    assert labelled.returncode == 0, labelled.stderr
    bad = run("labels", str(path), "-o", str(tmp_path / "m.png"), "--method", "texton", "--merge-by", "shape")
    assert bad.returncode == 2 and "texture or colour" in bad.stderr and "Traceback" not in bad.stderr
