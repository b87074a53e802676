"""A photo that tiles is a torus: every analysis of it behind the label maps (denoising, texton
filters, region clean-up, boundary distances, soft label channels) runs across its edges, so it
commutes with rolling the photo round, and a region cut by the edge is one region."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from barkgen._shared.arrays import Boundary
from barkgen.labels.regions import (
    NL_MEANS_REACH,
    color_regions,
    grow_small_labels,
    nl_means,
    remove_small_regions,
)
from barkgen.labels.textons import filter_responses
from barkgen.synth.guides.channels import boundary_distance, guide_channels

SHIFT = (37, 91)


@pytest.fixture(scope="module")
def sample128() -> np.ndarray:
    """The bundled sample (a texture that tiles itself) at 128 px."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image

    return cv2.resize(read_image(sample_exemplar_path()), (128, 128), interpolation=cv2.INTER_AREA)


def rolled(a: np.ndarray) -> np.ndarray:
    return np.roll(a, SHIFT, axis=(0, 1))


def codes_of(photo: np.ndarray) -> np.ndarray:
    """Three rough luminance classes with specks, for the clean-up to work on."""
    lum = photo.astype(np.float32).mean(axis=2)
    return np.digitize(lum, np.quantile(lum, [0.3, 0.6])).astype(np.int32)


def commutes(func, image) -> bool:
    """Rolling before ``func`` gives rolling after it (up to the float rounding of OpenCV's
    DFT filtering, 1e-17 here; an edge treated as a border differs by 0.1)."""
    return np.allclose(func(rolled(image)), rolled(func(image)), rtol=0, atol=1e-6)


def test_every_label_analysis_commutes_with_rolling_a_photo_that_tiles(sample128):
    codes = codes_of(sample128)
    analyses = {
        "denoising": (
            lambda im: Boundary(True).torus(lambda x: nl_means(x, 10.0), im, NL_MEANS_REACH),
            sample128.astype(np.float32) / 255.0,
        ),
        "texton filters": (lambda im: filter_responses(im, wrap=True), sample128),
        "small regions": (lambda c: remove_small_regions(c, 40, True), codes),
        "boundary distance": (lambda c: boundary_distance(c, 16.0, wrap=True), codes),
        "soft labels": (lambda c: guide_channels(c, c, 3, 1.0, exemplar_wrap=True)[0], codes),
    }
    for name, (func, image) in analyses.items():
        assert commutes(func, image), name
    # as a rectangle they do not: the photo's edges are borders
    assert not commutes(lambda c: boundary_distance(c, 16.0), codes)
    assert not commutes(lambda im: filter_responses(im), sample128)


def test_a_small_label_grows_across_the_edge():
    """A 2 x 2 speck on the first column grows to 16 px by a ring of one pixel: round the edge
    onto the last column when the map wraps (4 x 4 on the torus); when it does not, the ring
    stays inside and a second one starts."""
    codes = np.zeros((32, 32), np.int32)
    codes[10:12, 0:2] = 1
    grown = grow_small_labels(codes, 16 / codes.size, 2, True)
    assert (grown == 1).sum() == 16 and (grown[9:13, 31] == 1).all()
    flat = grow_small_labels(codes, 16 / codes.size, 2, False)
    assert (flat[:, 31] == 0).all() and (flat == 1).sum() == 16 and (flat[8] == 1).any()


def test_a_region_across_the_edge_is_one_region():
    """A 6 x 6 region round the corner of a map that wraps is 36 px (kept with a 30 px
    minimum); as a rectangle it is four 9 px corners, all dissolved."""
    codes = np.zeros((32, 32), np.int32)
    codes[np.ix_([29, 30, 31, 0, 1, 2], [29, 30, 31, 0, 1, 2])] = 1
    assert (remove_small_regions(codes, 30, True) == codes).all()
    assert (remove_small_regions(codes, 30, False) == 0).all()
    # wrapping along the rows only: two 18 px halves, both dissolved
    assert (remove_small_regions(codes, 30, (True, False)) == 0).all()
    assert (remove_small_regions(codes, 18, (True, False)) == codes).all()


def test_a_label_map_of_a_photo_that_tiles_tiles(sample128):
    """The colour label map of the sample, wrapped: its labels change across its own edges about
    as often as between neighbouring rows and columns inside it."""
    labels = color_regions(sample128, 3, wrap=True)
    inside = np.mean([(labels[1:] != labels[:-1]).mean(), (labels[:, 1:] != labels[:, :-1]).mean()])
    across = np.mean([(labels[0] != labels[-1]).mean(), (labels[:, 0] != labels[:, -1]).mean()])
    assert across <= 2.0 * inside + 0.02
