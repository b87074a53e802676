"""Label maps from a photo: colour regions, texton channels, merging, edge label, CLI."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.errors import InvalidInputError
from barkgen.labels import (
    add_edge_label,
    auto_merge,
    color_regions,
    filter_bank,
    label_preview,
    merge_channels,
    parse_groups,
    remove_small_regions,
    texton_channels,
    texton_regions,
)

#: every photo of tests/data/bark (the team's copyleft three are not shipped)
PHOTOS = [
    "birch_smooth_lenticels_01",
    "fir_scaly_01",
    "furrowed_fine_01",
    "lichen_covered_01",
    "oak_furrowed_moss_01",
    "pine_plated_01",
    "willow_furrowed_01",
]


@pytest.fixture(scope="module")
def oak():
    from conftest import bark_exemplar

    return bark_exemplar("oak_furrowed_moss_01", 256)


def _luminance(img):
    return img.astype(np.float64).mean(axis=2)


# --------------------------------------------------------------------------------------------
# colour regions


@pytest.mark.parametrize("name", PHOTOS)
def test_color_regions_on_every_photo(name):
    from conftest import bark_exemplar

    from barkgen.testing import label_fractions, smallest_region

    img = bark_exemplar(name, 256)
    for k in (2, 3):
        lm = color_regions(img, k, seed=0)
        assert lm.shape == img.shape[:2] and lm.dtype == np.uint8
        values = np.unique(lm)
        assert len(values) == k and values[0] == 0 and values[-1] == 255  # evenly spread greys
        assert label_fractions(lm).min() >= 0.05
        assert smallest_region(lm) >= 33  # 0.05 % of 256^2
        # darkest region first
        lum = _luminance(img)
        means = [lum[lm == v].mean() for v in values]
        assert means == sorted(means)


def test_color_regions_same_seed_same_map_and_16_bit(oak):
    a = color_regions(oak, 3, seed=4)
    assert np.array_equal(a, color_regions(oak, 3, seed=4))
    wide = oak.astype(np.uint16) * 257
    b = color_regions(wide, 3, seed=4)
    assert (a == b).mean() > 0.97
    grey = color_regions(oak.mean(axis=2).astype(np.uint8), 2, seed=0)
    assert len(np.unique(grey)) == 2


def test_labels_follow_appearance(oak):
    from barkgen.testing import half_split_accuracy

    lm = color_regions(oak, 2, seed=0)
    assert half_split_accuracy(oak, lm) >= 0.9
    rng = np.random.default_rng(0)  # the same classifier cannot learn noise labels
    noise = np.where(rng.random(lm.shape) < 0.5, 0, 255).astype(np.uint8)
    assert half_split_accuracy(oak, noise) < 0.6


def test_small_regions_take_the_commonest_neighbour():
    codes = np.zeros((20, 20), np.int32)
    codes[:, 10:] = 1
    codes[4:6, 2:4] = 1  # 4 px island of 1 inside 0
    codes[12, 15] = 0  # 1 px island of 0 inside 1
    out = remove_small_regions(codes, 5)
    expected = np.zeros((20, 20), np.int32)
    expected[:, 10:] = 1
    assert np.array_equal(out, expected)


@pytest.mark.parametrize(
    "args, message",
    [
        ((0,), "from 1 to 16"),
        ((17,), "from 1 to 16"),
        ((2.5,), "from 1 to 16"),
    ],
)
def test_bad_k(oak, args, message):
    with pytest.raises(InvalidInputError, match=message):
        color_regions(oak, *args)


def test_tiny_photo_is_refused():
    with pytest.raises(InvalidInputError, match="at least"):
        color_regions(np.zeros((8, 8, 3), np.uint8), 2)


# --------------------------------------------------------------------------------------------
# edge label


def test_edge_label_is_the_same_for_input_and_output_maps():
    a = np.zeros((12, 12), np.uint8)
    a[:, 6:] = 255
    e = add_edge_label(a, 2)
    assert sorted(np.unique(e)) == [0, 128, 255]
    assert (e[:, 5:7] == 255).all() and (e[:, :4] == 0).all() and (e[:, 8:] == 128).all()
    b = a[::-1, ::-1].copy()  # another map with the same labels gets the same palette
    assert sorted(np.unique(add_edge_label(b, 2))) == [0, 128, 255]
    wide = add_edge_label(a, 6)
    assert (wide == 255).sum() == 12 * 6
    with pytest.raises(InvalidInputError):
        add_edge_label(a, 0)


# --------------------------------------------------------------------------------------------
# textons


def test_filter_bank_is_wang2003s():
    bank = filter_bank()
    assert len(bank) == 36
    for f in bank:
        assert abs(float(f.sum())) < 1e-4 and abs(float(np.abs(f).sum()) - 1) < 1e-4
    # odd filters are antisymmetric, even ones symmetric
    assert np.allclose(bank[0], bank[0][::-1, ::-1], atol=1e-6)
    assert np.allclose(bank[18], -bank[18][::-1, ::-1], atol=1e-6)


def test_texton_channels_merge_and_auto_merge(oak):
    textons, responses = texton_channels(oak, 12, seed=1)
    assert textons.shape == oak.shape[:2] and responses.shape == oak.shape[:2] + (36,)
    assert set(np.unique(textons)) == set(range(12))
    assert np.array_equal(textons, texton_channels(oak, 12, seed=1)[0])
    groups = auto_merge(textons, oak, 3)
    assert sorted(sum(groups, [])) == list(range(12)) and len(groups) == 3
    merged = merge_channels(textons, groups)
    lum = _luminance(oak)
    means = [lum[merged == v].mean() for v in np.unique(merged)]
    assert means == sorted(means)  # darkest group first
    assert np.array_equal(merge_channels(textons, ";".join(",".join(map(str, g)) for g in groups)), merged)
    lm = texton_regions(oak, 2, n_textons=12, seed=1)
    assert len(np.unique(lm)) == 2


@pytest.mark.parametrize(
    "groups, message",
    [
        ("0,1;;2", "empty group"),
        ("0,a;1", "comma-separated"),
        ("0,1", "leave out"),
        ("0,1,2;2,3", "two groups"),
    ],
)
def test_bad_groups(groups, message):
    tm = np.array([[0, 1], [2, 3]], np.uint8)
    with pytest.raises(InvalidInputError, match=message):
        merge_channels(tm, groups if ";" in groups else parse_groups(groups))


def test_preview_shows_photo_and_tinted_regions(oak):
    lm = color_regions(oak, 3, seed=0)
    p = label_preview(oak, lm)
    assert p.shape == (256, 2 * 256 + 4, 3) and p.dtype == np.uint8
    assert np.array_equal(p[:, :256], oak)
    assert not np.array_equal(p[:, 260:], oak)


def test_too_little_variation_gives_fewer_labels_with_a_warning():
    img = np.full((40, 40, 3), 120, np.uint8)
    img[:, :20] = 30
    with pytest.warns(UserWarning, match="only 2 distinct regions"):
        lm = color_regions(img, 3)
    assert sorted(np.unique(lm)) == [0, 255] and (lm[:, :20] == 0).all()
