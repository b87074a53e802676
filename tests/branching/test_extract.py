"""Automatic extraction of crack networks (barkgen.branching.extract)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from barkgen.branching.extract import crack_mask, default_step, extract_structure, overlay_structure
from barkgen.branching.structure import Structure
from barkgen.errors import InvalidInputError

#: photo-like crack networks: conftest's drawn ones (size, seed, cell, grey: in place of the
#: team's dried-mud photos, which are copyleft) and the plated pine of tests/data, whose plates
#: are parted by a network of dark fissures (its top-left 512 px)
NETWORKS = [(256, 0, 40, False), (512, 1, 32, False), (512, 2, 40, True), "pine_plated_01"]

HALF_WIDTH = 3  # px: the drawn cracks are 2 * HALF_WIDTH wide
# a T (a side crack leaves the main crack), a Y (the side crack forks) and a closed cell on the
# main crack (its far side starts on the main crack and ends on it again: a merge)
LINES = [
    [(10, 90), (80, 95), (150, 92), (245, 100)],  # main crack, edge to edge
    [(150, 92), (152, 150), (150, 190)],  # T: side crack down from the main one
    [(150, 190), (112, 235)],  # Y: the side crack forks ...
    [(150, 190), (190, 232)],  # ... in two
    [(60, 94), (58, 35), (115, 30), (118, 93)],  # cell above the main crack
]


def _synthetic(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(noisy light image with dark cracks, true crack mask, true skeleton) of 256 x 256 px."""
    rng = np.random.default_rng(seed)
    image = np.full((256, 256), 190.0) + rng.normal(0, 6, (256, 256))
    image = cv2.GaussianBlur(image, (0, 0), 0.7)
    mask = np.zeros((256, 256), np.uint8)
    skel = np.zeros((256, 256), np.uint8)
    for line in LINES:
        pts = np.asarray(line, np.int32).reshape(-1, 1, 2)
        cv2.polylines(mask, [pts], False, 1, 2 * HALF_WIDTH)
        cv2.polylines(skel, [pts], False, 1, 1)
    image[mask > 0] = 60 + rng.normal(0, 4, int(mask.sum()))
    return np.clip(image, 0, 255).astype(np.uint8), mask.astype(bool), skel.astype(bool)


def _drawn(structure: Structure) -> np.ndarray:
    canvas = np.zeros((structure.height, structure.width), np.uint8)
    for b in structure.branches:
        cv2.polylines(canvas, [np.round(b.xy).astype(np.int32).reshape(-1, 1, 2)], False, 1, 1)
    return canvas.astype(bool)


def _distance_to(mask: np.ndarray) -> np.ndarray:
    return cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


def _check_structure(s: Structure, shape: tuple[int, int]) -> None:
    s.validate()
    assert s.size == (shape[1], shape[0])
    assert 2 <= s.step <= 8
    for b in s.branches:
        assert b.points.shape[0] >= 2 and b.points.shape[1] == 3
        assert np.isfinite(b.points).all()
        assert (b.thickness > 0).all()
    # the JSON form round-trips
    Structure.from_dict(s.to_dict())


def _luminance(image: np.ndarray) -> np.ndarray:
    from barkgen.color import rgb_to_lab

    rgb = image.astype(np.float32) / 255.0
    if rgb.ndim == 2:
        rgb = rgb[:, :, None]
    if rgb.shape[2] == 1:
        rgb = np.repeat(rgb, 3, axis=2)
    return rgb_to_lab(rgb)[..., 0]


# --------------------------------------------------------------------------- synthetic


def test_crack_mask_matches_drawn_cracks():
    image, truth, _ = _synthetic()
    mask = crack_mask(image)
    assert mask.shape == truth.shape and mask.dtype == bool
    iou = (mask & truth).sum() / (mask | truth).sum()
    assert iou > 0.75, iou


def test_skeleton_follows_drawn_cracks():
    image, _, truth = _synthetic()
    s = extract_structure(image)
    _check_structure(s, image.shape)
    drawn = _drawn(s)
    # every drawn skeleton point is near the extracted skeleton, and vice versa (mostly)
    near_extracted = _distance_to(drawn)[truth] <= 1.5
    near_truth = _distance_to(truth)[drawn] <= 1.5
    assert near_extracted.mean() > 0.93, near_extracted.mean()
    assert near_truth.mean() > 0.95, near_truth.mean()
    thickness = np.concatenate([b.thickness for b in s.branches])
    assert abs(np.median(thickness) - HALF_WIDTH) < 0.3 * HALF_WIDTH, np.median(thickness)


def test_hierarchy_has_furcations_and_a_merge():
    image, _, _ = _synthetic()
    s = extract_structure(image)
    roots = [b for b in s.branches if b.parent is None]
    assert len(roots) == 1  # one connected network
    # the T, the Y and the cell: at least 3 furcations, and the cell closes with a merge
    assert sum(b.parent is not None for b in s.branches) == 3
    assert sum(b.joins is not None for b in s.branches) == 1
    assert s.junctions() == 4
    cell = next(b for b in s.branches if b.joins is not None)
    assert cell.parent == cell.joins == 0  # starts and ends on the main crack
    assert 150 < cell.length() < 200
    # the longest branch is the main crack and comes first
    assert s.branches[0].length() == max(b.length() for b in s.branches)
    assert s.branches[0].length() > 200
    # a child starts where it leaves its parent, a merge ends where it meets its target
    for b in s.branches:
        if b.parent is not None:
            p = s.branches[b.parent].xy[b.parent_vertex]
            assert np.hypot(*(b.xy[0] - p)) <= s.step
        if b.joins is not None:
            q = s.branches[b.joins].xy[b.join_vertex]
            assert np.hypot(*(b.xy[-1] - q)) <= 2 * s.step + HALF_WIDTH


def test_vertices_are_evenly_spaced_at_the_step():
    image, _, _ = _synthetic()
    s = extract_structure(image, step=4)
    assert s.step == 4
    for b in s.branches:
        seg = np.hypot(*np.diff(b.xy, axis=0).T)
        assert seg.max() <= 4 + 1e-6
        if len(seg) > 2:
            assert np.median(seg) > 3.0  # a polyline resampled at h, not a pixel chain
    assert default_step(np.array([0.7, 1.0, 1.2])) == 2
    assert default_step(np.array([4.6, 5.0, 5.2])) == 5
    assert default_step(np.array([20.0])) == 8


def test_colour_and_dtype_variants_agree():
    image, truth, _ = _synthetic()
    grey = crack_mask(image)
    rgb = crack_mask(np.repeat(image[:, :, None], 3, axis=2))
    as_float = crack_mask(image.astype(np.float32) / 255.0)
    as_16 = crack_mask(image.astype(np.uint16) * 257)
    for m in (rgb, as_float, as_16):
        assert (m ^ grey).mean() < 0.002


def test_label_map_picks_the_darkest_label():
    image, truth, _ = _synthetic()
    # a hand-drawn two-label map: black cracks on white, as (H, W) and as RGB
    labels = np.where(truth, 0, 255).astype(np.uint8)
    assert (crack_mask(image, labels) == truth).all()
    rgb = np.zeros(truth.shape + (3,), np.uint8)
    rgb[truth] = (200, 30, 30)
    rgb[~truth] = (30, 200, 30)
    assert (crack_mask(image, rgb) == truth).all()
    s = extract_structure(image, labels)
    _check_structure(s, image.shape)
    assert any(b.joins is not None for b in s.branches)
    assert abs(np.median(np.concatenate([b.thickness for b in s.branches])) - HALF_WIDTH) < 1.0


def test_overlay_is_an_rgb_preview():
    image, _, _ = _synthetic()
    s = extract_structure(image)
    out = overlay_structure(image, s)
    assert out.shape == image.shape + (3,) and out.dtype == np.uint8
    # the branches are drawn in colour on a grey photo
    sat = out.max(axis=2).astype(int) - out.min(axis=2)
    assert (sat > 100).mean() > 0.01
    assert (sat[_drawn(s)] > 60).mean() > 0.8


# --------------------------------------------------------------------------- bad input


def test_uniform_image_has_no_cracks():
    with pytest.raises(InvalidInputError, match="no cracks found"):
        extract_structure(np.full((128, 128, 3), 128, np.uint8))
    assert not crack_mask(np.full((64, 64), 0.5, np.float32)).any()


def test_smooth_gradient_has_no_cracks():
    x = np.linspace(0, 1, 200)
    ramp = (np.add.outer(x, x) * 100 + 50).astype(np.uint8)
    with pytest.raises(InvalidInputError, match="no cracks found"):
        extract_structure(ramp)
    vignette = (200 - 120 * np.hypot(*np.meshgrid(x - 0.5, x - 0.5))).astype(np.uint8)
    with pytest.raises(InvalidInputError, match="no cracks found"):
        extract_structure(vignette)


def test_single_label_map_has_no_cracks():
    image, _, _ = _synthetic()
    with pytest.raises(InvalidInputError, match="no cracks found"):
        extract_structure(image, np.zeros(image.shape, np.uint8))
    with pytest.raises(InvalidInputError, match="single label"):
        crack_mask(image, np.full(image.shape + (3,), 7, np.uint8))


def test_bad_arguments():
    image, _, _ = _synthetic()
    with pytest.raises(InvalidInputError, match="label map must be"):
        crack_mask(image, np.zeros((10, 10), np.uint8))
    with pytest.raises(InvalidInputError, match="step"):
        extract_structure(image, step=0)
    with pytest.raises(InvalidInputError, match="at least"):
        crack_mask(np.zeros((8, 8), np.uint8))
    with pytest.raises(InvalidInputError, match="image"):
        crack_mask(np.zeros((32, 32, 5), np.uint8))


# --------------------------------------------------------------------------- photo-like networks


@pytest.mark.parametrize("network", NETWORKS, ids=str)
def test_real_crack_networks(network):
    from conftest import BARK, crack_photo

    from barkgen.io import read_image

    if isinstance(network, str):
        image = read_image(BARK / f"{network}.jpg")[:512, :512]
    else:
        size, seed, cell, grey = network
        image = crack_photo(size, seed, cell=cell, grey=grey)
    s = extract_structure(image)
    _check_structure(s, image.shape[:2])
    assert len(s.branches) > 10
    assert sum(b.parent is not None for b in s.branches) > 10
    assert sum(b.joins is not None for b in s.branches) > 5
    # the skeleton lies on the cracks: darker than the photo's median, on average
    lum = _luminance(image)
    on = _drawn(s)
    assert lum[on].mean() < np.median(lum) - 5, (lum[on].mean(), np.median(lum))
    # and it covers the photo, not one corner of it
    ys, xs = np.nonzero(on)
    assert np.ptp(xs) > 0.8 * image.shape[1] and np.ptp(ys) > 0.8 * image.shape[0]
    # thickness is a crack's half-width in pixels, not a plate's
    assert 0.5 <= np.median(np.concatenate([b.thickness for b in s.branches])) < 6
