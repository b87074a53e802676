"""Texture-by-numbers' guides (:mod:`barkgen.synth.guides`): label maps encoded over one palette,
their pyramids and boundary distances, the guidance a level's kernels take, the label clean-up,
and the initialisations of laitoch2018 §3.4."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from barkgen import Canvas
from barkgen.errors import InvalidInputError
from barkgen.pyramid import gaussian_pyramid
from barkgen.synth.guides.channels import (
    boundary_distance,
    encode_label_maps,
    label_pyramid,
    thin_codes,
    thin_label_channels,
)
from barkgen.synth.guides.initialization import random_initialization, smart_initialization


def test_encode_label_maps_shares_one_palette():
    a = np.array([[10, 20], [30, 20]], np.uint8)
    b = np.array([[30, 30, 10]], np.uint8)
    lm = encode_label_maps(a, b, (2, 2))
    assert lm.n_labels == 3
    assert np.array_equal(lm.palette[lm.exemplar][..., 0], a)
    assert np.array_equal(lm.palette[lm.target][..., 0], b)


def test_colour_label_maps_and_grey_saved_as_rgb_are_accepted():
    a = np.zeros((4, 4, 3), np.uint8)
    a[:2] = (255, 0, 0)
    b = np.zeros((3, 5, 3), np.uint8)
    b[1] = (255, 0, 0)
    lm = encode_label_maps(a, b)
    assert lm.n_labels == 2 and lm.target.sum() == 5
    grey_rgb = np.repeat(np.array([[0, 9]], np.uint8)[..., None], 3, axis=2)
    assert encode_label_maps(np.array([[0, 9]], np.uint8), grey_rgb).n_labels == 2


@pytest.mark.parametrize(
    "a, b, message",
    [
        (np.zeros((4, 4), np.uint8), np.full((4, 4), 7, np.uint8), "does not have"),
        (np.arange(100, dtype=np.uint8).reshape(10, 10), np.zeros((4, 4), np.uint8), "at most 64"),
        (np.zeros((4, 4), np.uint8), np.zeros((4, 4, 3), np.uint8) + [1, 2, 3], "grey"),
        (np.zeros((5, 4), np.uint8), np.zeros((4, 4), np.uint8), "must match"),
    ],
)
def test_bad_label_maps_are_refused(a, b, message):
    with pytest.raises(InvalidInputError, match=message):
        encode_label_maps(a, b, a.shape[:2] if a.shape[0] != 5 else (4, 4))


def test_label_pyramid_keeps_the_majority():
    codes = np.zeros((16, 16), np.int32)
    codes[:, 10:] = 1
    levels = label_pyramid(codes, 2, 3)
    assert [lv.shape for lv in levels] == [(16, 16), (8, 8), (4, 4)]
    assert (levels[1][:, :4] == 0).all() and (levels[1][:, 6:] == 1).all()
    assert (levels[2][:, 0] == 0).all() and (levels[2][:, 3] == 1).all()


def test_a_thin_line_keeps_its_place_and_direction_where_the_label_pyramid_loses_it():
    """A 1 px line vanishes from the label pyramid's coarse levels; its proximity channel
    still peaks on it there, and its direction channels say horizontal (-1, 0) or vertical
    (1, 0) as the doubled angle, round the map's wrap."""
    codes = np.zeros((64, 64), np.int32)
    codes[20, :] = 1  # a horizontal line
    codes[:, 45] = 1  # a vertical one
    thin = np.array([1], np.int32)
    channels = thin_label_channels(codes, thin)
    assert channels.shape == (64, 64, 3) and channels.dtype == np.float32
    assert channels[20, 5, 0] == pytest.approx(1.0) and channels[22, 5, 0] == pytest.approx(np.exp(-1.0), abs=0.02)
    assert channels[20, 5, 1] < -0.9 and abs(channels[20, 5, 2]) < 0.1
    assert channels[50, 45, 1] > 0.9 and abs(channels[50, 45, 2]) < 0.1
    assert label_pyramid(codes, 2, 4)[3].max() == 0  # the lines are lost to the majority vote
    coarse = gaussian_pyramid(channels, 4)[3]
    assert int(np.argmax(coarse[:, 0, 0])) in (2, 3) and coarse[:, 0, 0].max() > 2 * np.median(coarse[:, 0, 0])
    # round the wrap: a line on row 0 is near the last row
    edge = np.zeros((32, 32), np.int32)
    edge[0] = 1
    assert thin_label_channels(edge, thin, wrap=True)[31, 9, 0] == pytest.approx(np.exp(-0.5), abs=0.02)
    assert thin_label_channels(edge, thin)[31, 9, 0] < 1e-5
    palette = encode_label_maps(np.array([[0, 255]], np.uint8), np.array([[0]], np.uint8)).palette
    assert list(thin_codes(palette, [255])) == [1]
    with pytest.raises(InvalidInputError, match="thin label 7 is not a label"):
        thin_codes(palette, [7])


def test_boundary_distance_is_close_to_euclidean():
    codes = np.zeros((40, 40), np.int32)
    codes[15:25, 15:25] = 1
    got = boundary_distance(codes)
    ys, xs = np.nonzero(got == 0)
    assert {(y, x) for y, x in zip(ys, xs)} >= {(15, 15), (24, 24), (14, 20)}
    yy, xx = np.mgrid[0:40, 0:40]
    exact = np.min(np.hypot(yy[..., None] - ys, xx[..., None] - xs), axis=-1)
    assert np.abs(got - exact).max() < 0.1 * exact.max() + 1.0
    assert boundary_distance(codes, clip=3.0).max() == 3.0


def test_random_initialization_respects_labels(label_case):
    _, a, b = label_case
    lm = encode_label_maps(a, b)
    refs = random_initialization(lm.exemplar, lm.target, np.random.default_rng(0))
    assert np.array_equal(lm.exemplar.ravel()[refs], lm.target)


def test_smart_initialization_copies_coherent_regions_with_the_right_labels(label_case):
    _, a, b = label_case
    lm = encode_label_maps(a, b)
    refs = smart_initialization(lm.exemplar, lm.target, np.random.default_rng(0))
    assert refs.min() >= 0
    assert (lm.exemplar.ravel()[refs] == lm.target).mean() > 0.9
    # coherent: most horizontal neighbours continue the same exemplar piece
    w = lm.exemplar.shape[1]
    continued = (refs[:, 1:] == refs[:, :-1] + 1) & (refs[:, 1:] % w != 0)
    assert continued.mean() > 0.5
    rand = random_initialization(lm.exemplar, lm.target, np.random.default_rng(0))
    assert continued.mean() > 5 * ((rand[:, 1:] == rand[:, :-1] + 1).mean())


def test_an_unguided_level_has_an_empty_guidance_and_a_guided_one_its_tables():
    """:func:`level_guidance`: without a guide, the kernels get empty tables; with one, the
    level's label tables and, for each neighbourhood size of the level's schedule, the label
    neighbourhoods of the exemplar and of the target in their appearance space."""
    from barkgen.synth import Guidance, SynthesisConfig, guide_channels, level_guide
    from barkgen.synth.guides.guidance import level_guidance

    config = SynthesisConfig()
    empty = level_guidance(None, 0, 2, config, Canvas((8, 8), exemplar_wrap=(False, False)))
    assert not empty.guided and empty.guide_ex == {} and empty.guide_out == {}
    assert empty.expected is None and empty.n_random == 0

    a = np.zeros((16, 16), np.int32)
    a[:, 8:] = 1
    b = np.zeros((12, 10), np.int32)
    b[6:] = 1
    ga, gb = guide_channels(a, b, 2, 1.0)
    guidance = Guidance(
        levels=[level_guide(a, b, 2)],
        exemplar_guides=[ga],
        target_guides=[gb],
        initial_references=random_initialization,
        components=3,
    )
    level = level_guidance(guidance, 0, 2, config, Canvas((12, 10), exemplar_wrap=(False, False)))
    assert level.guided and level.n_random == guidance.random_candidates
    assert np.array_equal(level.ex_labels, a.ravel()) and np.array_equal(level.target, b)
    sizes = sorted({s for s, _ in config.schedule_finest})
    assert sorted(level.guide_ex) == sorted(level.guide_out) == sizes
    for size in sizes:
        assert level.guide_ex[size].shape == (16 * 16, 3)
        assert level.guide_out[size].shape == (12, 10, 3)


def test_the_label_clean_up_continues_a_neighbouring_piece():
    """:func:`enforce_labels`: a pixel whose reference has the wrong label takes the reference
    its neighbours' piece continues to it; the others keep theirs."""
    from barkgen.synth import exemplar_grid
    from barkgen.synth.guides.guidance import LevelGuidance, enforce_labels

    ex_labels = np.zeros(8 * 8, np.int32)
    ex_labels[6 * 8 + 6] = 1  # one exemplar pixel of another label
    yy, xx = np.mgrid[0:5, 0:5]
    refs = ((yy + 1) * 8 + (xx + 1)).astype(np.int32)  # one piece, offset (1, 1)
    stray = refs.copy()
    stray[2, 2] = 6 * 8 + 6
    target = np.zeros((5, 5), np.int32)
    guide = LevelGuidance(ex_labels, target, ex_labels, np.zeros(3, np.int32), None, 0, 1.0, {}, {}, True)
    # the solver's level as enforce_labels reads it: its exemplar grid, its guide, its tile
    level = SimpleNamespace(
        analysis=SimpleNamespace(grid=exemplar_grid((8, 8), (False, False))), guide=guide, tile=False
    )
    out = enforce_labels(stray, level, 3)
    assert np.array_equal(out, refs)
    assert np.array_equal(enforce_labels(refs, level, 3), refs)


@pytest.mark.parametrize("tile", [True, False])
@pytest.mark.parametrize("n_labels", [3, 11])
def test_a_target_guide_made_where_it_is_read_is_the_whole_pyramids(tile, n_labels):
    """A windowed solve's target guide (issue 69) is made a window at a time from the labels: at
    every level, whole or in windows (round a torus of odd side too, where the pyramid's grid
    does not run on), it is the whole pyramid's to float rounding, and it holds no level."""
    import cv2

    from barkgen.synth.guides.channels import soft_labels
    from barkgen.synth.guides.target import TargetGuideLevel, target_guide_pyramid

    rng = np.random.default_rng(3)
    exemplar = rng.integers(0, n_labels, (64, 80)).astype(np.int32)
    blobs = cv2.resize(rng.random((30, 27)), (301, 333)) * n_labels  # odd sides
    target = np.clip(blobs.astype(np.int32), 0, n_labels - 1)
    recipe, _ = soft_labels(exemplar, n_labels, 2.5)
    whole = gaussian_pyramid(recipe(target, tile), 4, (tile, tile))
    made = target_guide_pyramid(target, recipe, 4, tile, made_where_read=2)
    assert [type(level) for level in made[:2]] == [TargetGuideLevel, TargetGuideLevel]
    assert all(isinstance(level, np.ndarray) for level in made[2:])
    for lvl, (lazy, full) in enumerate(zip(made, whole)):
        assert np.asarray(lazy).shape == full.shape
        np.testing.assert_allclose(np.asarray(lazy), full, atol=1e-5)
        if lvl >= 2:
            continue
        h, w = full.shape[:2]
        for top, left, side in ((0, 0, 40), (h - 20, w - 30, 50), (10, 20, 33)):
            rows = np.arange(top, top + side) % h if tile else np.arange(top, min(top + side, h))
            cols = np.arange(left, left + side) % w if tile else np.arange(left, min(left + side, w))
            window = lazy[np.ix_(rows, cols)]
            np.testing.assert_allclose(window, full[np.ix_(rows, cols)], atol=1e-5)
