"""Gaussian pyramids and level sizes (:mod:`barkgen.pyramid`): ceil halving, so that a
reference at level l + 1 has exactly its four children at level l; the levels' blur keeps what
is smooth, keeps constants and, on an image that tiles, runs round its edges."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.pyramid import count_levels, gaussian_pyramid, level_shape


def test_level_shapes_halve_rounding_up():
    assert level_shape((33, 64), 0) == (33, 64)
    assert [level_shape((33, 64), lvl) for lvl in (1, 2, 3, 6, 7)] == [(17, 32), (9, 16), (5, 8), (1, 1), (1, 1)]
    for shape in [(1, 1), (2, 3), (31, 64), (100, 7)]:
        for lvl in range(5):
            fine, coarse = level_shape(shape, lvl), level_shape(shape, lvl + 1)
            # every coarse pixel (y, x) has its children (2y + dy, 2x + dx) inside, or on the last row/column
            assert all(2 * c - 1 <= f <= 2 * c for f, c in zip(fine, coarse)), (shape, lvl)


@pytest.mark.parametrize(
    "exemplar, output, expected",
    [
        ((128, 200), (256, 256), 3),  # the exemplar's 128 px: 128, 64, 32
        ((512, 512), (64, 100), 3),  # the output's 64 px: 64, 32, 16
        ((20, 500), (256, 256), 1),  # too small for any coarser level
        ((512, 512), (10, 10), 1),
    ],
)
def test_count_levels_keeps_the_coarsest_levels_big_enough(exemplar, output, expected):
    n = count_levels(exemplar, output)
    assert n == expected
    assert min(level_shape(exemplar, n - 1)) >= 32 or n == 1
    assert min(level_shape(output, n - 1)) >= 16 or n == 1


def test_the_pyramid_has_the_level_shapes_and_keeps_level_0():
    rng = np.random.default_rng(0)
    image = rng.random((45, 70, 3)).astype(np.float64)
    levels = gaussian_pyramid(image, 4)
    assert [lvl.shape for lvl in levels] == [level_shape((45, 70), i) + (3,) for i in range(4)]
    assert all(lvl.dtype == np.float32 and lvl.flags.c_contiguous for lvl in levels)
    assert np.array_equal(levels[0], image.astype(np.float32))
    # the blur averages: noise shrinks level by level, the mean stays
    assert levels[1].std() < 0.6 * levels[0].std() and levels[2].std() < levels[1].std()
    assert abs(levels[3].mean() - image.mean()) < 0.02


@pytest.mark.parametrize("wrap", [(False, False), (True, True), (True, False)])
def test_constants_stay_constant(wrap):
    image = np.full((37, 50, 2), 0.25, np.float32)
    image[..., 1] = 0.75
    for lvl in gaussian_pyramid(image, 4, wrap=wrap):
        assert np.allclose(lvl[..., 0], 0.25, atol=1e-6) and np.allclose(lvl[..., 1], 0.75, atol=1e-6)


def test_a_smooth_image_comes_through_as_its_own_samples():
    """Down one level, a slow wave is the wave at every other pixel, scaled by the 5-tap binomial
    kernel's response ((1 + cos 2 pi f) / 2)^2; with wrap, at the borders too."""
    y, x = np.mgrid[0:64, 0:96].astype(np.float32)
    wave = (np.sin(2 * np.pi * x / 32) * np.cos(2 * np.pi * y / 16))[..., None]
    gain = ((1 + np.cos(2 * np.pi / 32)) / 2) ** 2 * ((1 + np.cos(2 * np.pi / 16)) / 2) ** 2
    wrapped = gaussian_pyramid(wave, 2, wrap=(True, True))[1]
    assert np.allclose(wrapped, gain * wave[::2, ::2], atol=2e-3)
    reflected = gaussian_pyramid(wave, 2)[1]
    assert np.allclose(reflected[2:-2, 2:-2], gain * wave[4:-4:2, 4:-4:2], atol=2e-3)
    assert not np.allclose(reflected, gain * wave[::2, ::2], atol=2e-3)  # its borders are not the torus'


def test_wrap_makes_the_pyramid_shift_with_the_tile():
    """On a tiling image with wrap, shifting by 2**l pixels shifts level l by one: the blur
    runs round the edges. Only along the axes that wrap."""
    rng = np.random.default_rng(1)
    tile = rng.random((32, 48, 1)).astype(np.float32)
    base = gaussian_pyramid(tile, 3, wrap=(True, True))
    shifted = gaussian_pyramid(np.roll(tile, (4, -8), axis=(0, 1)), 3, wrap=(True, True))
    for lvl in (1, 2):
        step = 1 << lvl
        assert np.allclose(shifted[lvl], np.roll(base[lvl], (4 // step, -8 // step), axis=(0, 1)), atol=1e-5)
    rows_only = gaussian_pyramid(tile, 2, wrap=(True, False))[1]
    rolled = gaussian_pyramid(np.roll(tile, 2, axis=0), 2, wrap=(True, False))[1]
    assert np.allclose(rolled, np.roll(rows_only, 1, axis=0), atol=1e-5)
    rolled_x = gaussian_pyramid(np.roll(tile, 2, axis=1), 2, wrap=(True, False))[1]
    assert not np.allclose(rolled_x, np.roll(rows_only, 1, axis=1), atol=1e-5)
