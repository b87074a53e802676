"""Large levels solved window by window (:mod:`barkgen.synth._windows`): the windows cover the
level once, their halos wrap where the output tiles, the forbidden offsets survive the trip,
and a windowed solve is as good as a whole one, with no trace of the windows."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import bark_exemplar

from barkgen import Budget, Canvas
from barkgen.errors import InvalidInputError
from barkgen.evaluate import coherence, grid_step_ratio, longest_seam
from barkgen.synth import TBN_CONFIG, SynthesisConfig, synthesize, texture_by_numbers
from barkgen.synth._windows import WINDOW_HALO, window_grid
from barkgen.synth.seams.pieces import moved_offsets, offset_codes, offset_parts
from barkgen.testing import shuffled_blocks


def test_the_windows_cover_the_level_once_and_their_halos_wrap_where_it_tiles():
    shape = (300, 250)
    for tile in (True, False):
        for offset, count in ((0, 3 * 2), (64, 3 * (2 if tile else 3))):
            windows = window_grid(shape, 128, tile, offset=offset)
            assert len(windows) == count
            cover = np.zeros(shape, int)
            for w in windows:
                cover[w.target] += 1
                assert w.core[0].stop - w.core[0].start <= 128
            assert (cover == 1).all()
    first = window_grid(shape, 128, True)[0]
    assert first.rows[0] == shape[0] - WINDOW_HALO and len(first.rows) == 128 + 2 * WINDOW_HALO
    assert window_grid(shape, 128, False)[0].rows[0] == 0  # clipped at the edge
    # shifted by half a window round the torus: the last core runs over the edge to row 63
    last = window_grid(shape, 128, True, offset=64)[-1]
    assert last.rows[last.core[0]][-1] == 63


def test_forbidden_offsets_are_the_same_exemplar_pixels_from_the_new_positions():
    rng = np.random.default_rng(0)
    forbid = offset_codes(rng.integers(-50, 50, (6, 5)), rng.integers(-50, 50, (6, 5)))
    forbid[0, 0] = -1
    rows, cols = rng.integers(-9, 9, 6), rng.integers(-9, 9, 5)
    moved = moved_offsets(forbid, rows, cols)
    assert moved[0, 0] == -1
    assert np.array_equal(moved_offsets(moved, -rows, -cols), forbid)
    # a pixel moved down by r sees the same exemplar pixel r rows nearer
    (dy, dx), (my, mx) = offset_parts(forbid), offset_parts(moved)
    kept = forbid >= 0
    assert np.array_equal(my[kept], (dy - rows[:, None])[kept]) and np.array_equal(mx[kept], (dx - cols)[kept])


@pytest.fixture(scope="module")
def exemplar():
    return bark_exemplar("oak_furrowed_moss_01", 128)


def test_a_windowed_solve_is_as_good_as_a_whole_one_and_leaves_no_trace(exemplar):
    """512² tiled from a 128² photo, its two finest levels in 128 px windows: coherence within
    10 % of the whole solve's (measured 1.04-1.05x over seeds 3-5), no straight seam over 48 px,
    the windows' borders stepping no more than the pixels inside (1.00-1.02, the whole solve's
    0.98-0.99 on the same grid); the same bytes again for the same seed."""
    whole = synthesize(exemplar, 512, tile=True, seed=3)
    config = SynthesisConfig(window=128)
    windowed = synthesize(exemplar, 512, tile=True, seed=3, config=config)
    assert not np.array_equal(windowed.references, whole.references)
    c_whole = coherence(whole.image, exemplar, wrap=True)
    c_windowed = coherence(windowed.image, exemplar, wrap=True)
    assert c_windowed < 1.1 * c_whole
    periods = tuple(side if wraps else 0 for side, wraps in zip(exemplar.shape[:2], windowed.exemplar_wrap))
    assert longest_seam(windowed.references, tile=True, exemplar_wrap=periods) <= 48  # (whole: 29; seeds 4-5 29-37)
    assert grid_step_ratio(windowed.image, 128, tile=True) < 1.15
    again = synthesize(exemplar, 512, tile=True, seed=3, config=config)
    assert np.array_equal(again.image, windowed.image)
    # an output no larger than a window (and its halo) is solved whole: the same bytes
    small = synthesize(exemplar, 128 + 2 * WINDOW_HALO, tile=True, seed=3, config=config)
    assert np.array_equal(small.image, synthesize(exemplar, 128 + 2 * WINDOW_HALO, tile=True, seed=3).image)


def test_windowed_texture_by_numbers_follows_its_labels(exemplar):
    lum = exemplar.astype(np.float32).mean(axis=2)
    labels = np.where(lum > np.median(lum), 255, 0).astype(np.uint8)
    target = shuffled_blocks(labels, 512, block=32, seed=1)
    fidelity = []
    for window in (0, 128):
        out = texture_by_numbers(
            exemplar,
            labels,
            target,
            config=dataclasses.replace(TBN_CONFIG, window=window),
            canvas=Canvas((512, 512), tile=True),
            budget=Budget(seed=0),
        )
        fidelity.append(np.mean(labels[out.references[..., 0], out.references[..., 1]] == target))
    assert fidelity[1] > fidelity[0] - 0.01 and fidelity[1] > 0.95


def test_a_window_too_small_is_refused():
    with pytest.raises(InvalidInputError, match="window must be 0"):
        SynthesisConfig(window=32)


@pytest.mark.parametrize("tile", [True, False])
def test_a_windows_guide_is_projected_on_the_window_as_the_whole_levels(tile):
    """A windowed level keeps its target's guide image, never its projected neighbourhoods
    whole: each window's are projected on the window with a margin (round the torus when the
    level tiles, reflected at a level's edge otherwise), as the whole level's projection gives
    them, for windows inside, at the edges and across the torus' seam."""
    from barkgen.nnf import project_neighbourhoods
    from barkgen.synth.guides.guidance import LevelGuidance, guide_out_at

    rng = np.random.default_rng(4)
    image = rng.random((90, 70, 3), dtype=np.float32)
    projections = {size: (rng.normal(size=(4, size, size, 3)), rng.random((size, size, 3))) for size in (5, 9, 15)}
    empty = np.zeros(1, np.int32)
    guide = LevelGuidance(empty, empty[None], empty, empty, None, 0, 1.0, {}, {}, True, projections, image, tile)
    for window in window_grid(image.shape[:2], 32, tile, halo=8, offset=20):
        got = guide_out_at(guide, window.rows, window.cols)
        for size, (weights, mean) in projections.items():
            whole = project_neighbourhoods(image, weights, mean, wrap=tile).reshape(90, 70, -1)
            assert np.allclose(got[size], whole[np.ix_(window.rows, window.cols)], atol=1e-4), (size, window.core)
