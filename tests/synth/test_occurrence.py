"""Costs that spread the references over the exemplar (:mod:`barkgen.synth._occurrence`): the
occurrence penalty (kaspar2015 §5), the controllable jitter and the label-area balance."""

from __future__ import annotations

import numpy as np

from barkgen.synth import LabelBalance, LevelAnalysis
from barkgen.synth._occurrence import box_blur, jitter_references, occurrence_penalty


def _level(h: int, w: int, wrap=(False, False), scale: float = 2.0) -> LevelAnalysis:
    cy, cx = np.divmod(np.arange(h * w, dtype=np.int32), np.int32(w))
    return LevelAnalysis(h, w, None, cy, cx, {}, {}, None, scale, wrap)


def test_even_use_costs_nothing_overuse_costs_and_unused_regions_are_favoured():
    level = _level(16, 16)
    even = np.arange(16 * 16, dtype=np.int32).reshape(16, 16)
    assert np.allclose(occurrence_penalty(even, level, 1.0, 1), 0.0, atol=1e-6)
    crowded = np.full((16, 16), 5 * 16 + 5, np.int32)  # every output pixel copies one pixel
    cost = occurrence_penalty(crowded, level, 1.0, 1).reshape(16, 16)
    assert cost[5, 5] > 0 and cost[12, 12] == np.float32(-1.0 * level.scale)  # unused: the bonus
    assert np.all(occurrence_penalty(crowded, level, 0.0, 1) == 0)  # weight 0: no cost at all


def test_a_window_is_costed_as_part_of_its_level():
    """A window's cost with the rest of the level's use given (``outside``) is the whole level's
    cost; on its own the window would look under-used and get bonuses instead."""
    level = _level(16, 16)
    rng = np.random.default_rng(0)
    refs = rng.integers(0, 256, (64, 64), dtype=np.int32)
    window = refs[:24, :24]
    rest = np.bincount(refs.ravel(), minlength=256) - np.bincount(window.ravel(), minlength=256)
    whole = occurrence_penalty(refs, level, 1.0, 1)
    assert np.allclose(occurrence_penalty(window, level, 1.0, 1, outside=(rest.astype(np.float32), refs.size)), whole)
    assert not np.allclose(occurrence_penalty(window, level, 1.0, 1), whole)


def test_a_label_the_target_does_not_want_gets_neither_cost_nor_bonus():
    level = _level(8, 8)
    expected = np.ones(64, np.float32)
    expected[:32] = 0  # the first four rows' label is not wanted
    refs = np.full((4, 4), 40, np.int32)
    cost = occurrence_penalty(refs, level, 1.0, 1, expected).reshape(8, 8)
    assert np.all(cost[:3] == 0)  # far from any wanted pixel: no share, no cost, no bonus
    assert cost[5, 0] > 0 and cost[7, 7] < 0  # the crowded wanted region costs, an unused one is favoured


def test_jitter_moves_each_reference_by_seeded_offsets_clipped_or_round_the_torus():
    """Rows then columns of offsets in [-amplitude, amplitude] from the generator; clipped to
    the exemplar along an axis that does not wrap, round it along one that does."""
    level = _level(10, 12)
    refs = np.arange(120, dtype=np.int32).reshape(10, 12)
    assert jitter_references(refs, level, 0, np.random.default_rng(0)) is refs
    rng = np.random.default_rng(0)
    jy = rng.integers(-2, 3, size=refs.shape, dtype=np.int32)
    jx = rng.integers(-2, 3, size=refs.shape, dtype=np.int32)
    moved = jitter_references(refs, level, 2, np.random.default_rng(0))
    assert moved.dtype == np.int32
    assert np.array_equal(moved, np.clip(refs // 12 + jy, 0, 9) * 12 + np.clip(refs % 12 + jx, 0, 11))
    torus = jitter_references(refs, _level(10, 12, (True, True)), 2, np.random.default_rng(0))
    assert np.array_equal(torus, (refs // 12 + jy) % 10 * 12 + (refs % 12 + jx) % 12)


def test_the_box_blur_wraps_round_the_axes_that_wrap():
    image = np.zeros((6, 6), np.float32)
    image[0, 0] = 9.0
    flat = box_blur(image, 3, (False, False))
    torus = box_blur(image, 3, (True, True))
    assert torus[5, 5] == np.float32(1.0) and flat[5, 5] == 0.0
    assert np.isclose(torus.sum(), 9.0)


def test_the_label_balance_makes_a_label_the_output_has_too_much_of_dearer():
    shares = [np.array([[1.0, 0.0], [0.0, 1.0]], np.float32)]  # pixel 0 is label 0, pixel 1 label 1
    balance = LabelBalance(shares=shares, fractions=np.array([0.5, 0.5], np.float32), weight=1.0)
    too_much_of_0 = np.array([[0, 0, 0, 1]], np.int32)
    cost = balance.penalty(too_much_of_0, 0, 1.0)
    assert cost[0] > 0 > cost[1]
    assert np.allclose(balance.penalty(np.array([[0, 1]], np.int32), 0, 1.0), 0.0)
