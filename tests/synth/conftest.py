"""Fixtures of the synth tests: the bundled sample at 256 px, a photo-like texture that does not
tile, and a small texture-by-numbers label_case."""

from __future__ import annotations

import cv2
import numpy as np
import pytest


@pytest.fixture(scope="module")
def sample256() -> np.ndarray:
    """The bundled sample (a texture that tiles itself) at 256 px."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image

    return cv2.resize(read_image(sample_exemplar_path()), (256, 256), interpolation=cv2.INTER_AREA)


def _photo_like(seed: int = 0, shape=(96, 96)) -> np.ndarray:
    """A texture that does not tile: vertical furrows of random phase on a slope of colour."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:shape[0], 0:shape[1]].astype(np.float64)
    base = 110 + 50 * np.sin(x / 2.7 + rng.uniform(0, 6)) + 0.8 * y + rng.normal(0, 10, shape)
    return np.clip(np.stack([base, base * 0.9, base * 0.7], -1), 0, 255).astype(np.uint8)


@pytest.fixture(scope="session")
def photo_like():
    """``photo_like(seed=0, shape=(96, 96))``: a texture that does not tile (furrows on a slope)."""
    return _photo_like


def luminance_labels(image: np.ndarray, n: int = 2) -> np.ndarray:
    """Grey label map by luminance quantiles (a stand-in for the k-means label maps)."""
    lum = image.astype(np.float32).mean(axis=2)
    edges = np.quantile(lum, np.linspace(0, 1, n + 1)[1:-1])
    return (np.digitize(lum, edges) * (255 // (n - 1))).astype(np.uint8)


@pytest.fixture(scope="module")
def label_case(synthetic_exemplar):
    from barkgen.testing import shuffled_blocks

    ex = synthetic_exemplar[:40, :40]
    a = luminance_labels(ex)
    b = shuffled_blocks(a, 64, block=8, seed=2)
    return ex, a, b

