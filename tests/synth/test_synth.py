"""The synthesizer: behaviour (shapes, determinism, tiling, references, extras, errors) and
measured quality on real bark with the team's texeval."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.errors import InvalidInputError, MemoryBudgetError
from barkgen.synth import SynthesisConfig, apply_references, synthesize


def test_any_size_non_square_tileable(synthetic_exemplar):
    res = synthesize(synthetic_exemplar, (37, 150), tile=True, seed=3)
    assert res.image.shape == (37, 150, 3) and res.image.dtype == np.uint8
    assert res.references.shape == (37, 150, 2)
    assert res.exemplar_shape == synthetic_exemplar.shape[:2]


def test_output_pixels_are_exemplar_pixels(synthetic_exemplar):
    """Discrete solver: with ``blend="none"`` every output pixel is copied from the exemplar,
    never averaged; by default only the pixels next to a border between pieces change (the
    colour's seams blended in the gradient domain), and the borders step less."""
    from conftest import border_distance, border_step_ratio

    exact = synthesize(synthetic_exemplar, 80, seed=1, config=SynthesisConfig(blend="none"))
    refs = exact.references
    assert refs[..., 0].max() < synthetic_exemplar.shape[0] and refs.min() >= 0
    copy = synthetic_exemplar[refs[..., 0], refs[..., 1]]
    assert np.array_equal(exact.image, copy) and exact.blend == "none"
    blended = synthesize(synthetic_exemplar, 80, seed=1)
    assert blended.blend == "gradient" and np.array_equal(blended.references, refs)
    far = border_distance(refs, synthetic_exemplar.shape[:2], tile=False) >= 8
    assert far.mean() > 0.02
    diff = np.abs(blended.image.astype(int) - copy.astype(int)).max(axis=-1)
    assert np.mean(diff[far] <= 1) > 0.9 and diff[far].mean() < 0.25 * diff[~far].mean()
    assert (border_step_ratio(blended.image, refs, synthetic_exemplar.shape[:2])
            < 0.9 * border_step_ratio(copy, refs, synthetic_exemplar.shape[:2]))


def test_grey_and_16_bit_exemplars(synthetic_exemplar):
    grey16 = synthetic_exemplar[:, :, 0].astype(np.uint16) * 257
    res = synthesize(grey16, (50, 60), seed=0, config=SynthesisConfig(blend="none"))
    assert res.image.shape == (50, 60) and res.image.dtype == np.uint16
    assert set(np.unique(res.image)) <= set(np.unique(grey16))
    blended = synthesize(grey16, (50, 60), seed=0)  # blended in 16 bits, not rounded to 8
    assert blended.image.shape == (50, 60) and blended.image.dtype == np.uint16
    assert not set(np.unique(blended.image)) <= set(np.unique(grey16))


def test_same_seed_same_bytes_different_seed_different(synthetic_exemplar):
    a = synthesize(synthetic_exemplar, 96, tile=True, seed=5)
    b = synthesize(synthetic_exemplar, 96, tile=True, seed=5)
    c = synthesize(synthetic_exemplar, 96, tile=True, seed=6)
    assert a.image.tobytes() == b.image.tobytes()
    assert np.array_equal(a.references, b.references)
    assert np.mean(np.any(a.image != c.image, axis=-1)) > 0.5


def test_thread_count_does_not_change_the_result(synthetic_exemplar):
    one = synthesize(synthetic_exemplar, 96, tile=True, seed=2, config=SynthesisConfig(threads=1))
    two = synthesize(synthetic_exemplar, 96, tile=True, seed=2, config=SynthesisConfig(threads=2))
    assert np.array_equal(one.references, two.references)


def test_extras_follow_the_same_references(synthetic_exemplar):
    """Extra maps are continuous maps (height, normals, roughness): they go through the same
    references in the gradient domain, so inside each copied piece they step exactly as the
    exemplar's map does there, and across the pieces' borders they have no cliffs."""
    # a height of the texture's own shapes: where two pieces meet, the copy has a cliff
    height = (synthetic_exemplar.astype(np.uint16).sum(axis=2) * 80).astype(np.uint16)
    res = synthesize(synthetic_exemplar, (96, 96), seed=4, extra={"height": height})
    out = res.extras["height"]
    assert out.shape == (96, 96, 1) and out.dtype == np.uint16
    from conftest import assert_continuous_copy

    assert_continuous_copy(out[:, :, 0], height, res.references, tolerance=0.35)


def test_a_run_stopped_at_a_level_is_that_level_of_the_full_run(synthetic_exemplar):
    """``stop_level``: the references at that level are the full run's (same seed, same draws);
    resuming from them finishes a valid output; a level outside the pyramid is refused."""
    from barkgen.pyramid import count_levels, level_shape
    from barkgen.synth import matching_features, solve

    config = SynthesisConfig(coarsest_exemplar=8, blend="none")
    features = matching_features(synthetic_exemplar, None, 0.0)
    n_levels = count_levels(synthetic_exemplar.shape[:2], (96, 96), config.coarsest_exemplar)
    assert n_levels >= 3
    levels = {}

    def keep(name, image):
        if name.endswith("_result"):
            levels[int(name[5:-7])] = image

    from barkgen.synth import AnalysisCache

    args = dict(n_levels=n_levels, config=config, seed=4, tile=True)
    # the stopped run analyses only the levels it solves; the full run then goes on below them
    cache = AnalysisCache()
    stopped = solve(exemplar=synthetic_exemplar, extras={}, features=features, out_shape=(96, 96), stop_level=1, cache=cache, **args)
    (levels_kept,) = cache._entries.values()
    assert levels_kept[0] is None and all(la is not None for la in levels_kept[1:])
    solve(exemplar=synthetic_exemplar, extras={}, features=features, out_shape=(96, 96), debug=keep, cache=cache, **args)
    (levels_now,) = cache._entries.values()
    assert levels_now[0] is not None and all(a is b for a, b in zip(levels_now[1:], levels_kept[1:]))
    assert len(cache) == 1
    h, w = level_shape(synthetic_exemplar.shape[:2], 1)
    assert stopped.exemplar_shape == (h, w) and stopped.references.shape == (48, 48, 2)
    assert stopped.references[..., 0].max() < h and stopped.references[..., 1].max() < w
    assert np.array_equal(stopped.image, levels[1])
    flat = (stopped.references[..., 0] * w + stopped.references[..., 1]).astype(np.int32)
    resumed = solve(exemplar=synthetic_exemplar, extras={}, features=features, out_shape=(96, 96), start=(1, flat), **args)
    assert np.array_equal(resumed.image, synthetic_exemplar[resumed.references[..., 0],
                                                            resumed.references[..., 1]])
    with pytest.raises(InvalidInputError, match="stop_level"):
        solve(exemplar=synthetic_exemplar, extras={}, features=features, out_shape=(96, 96), stop_level=n_levels, **args)


def test_thread_budget_sizes_every_pool_and_gives_them_back():
    """Inside a run every library's pool has the run's thread count and BLAS one thread
    (its spinning pool collapsed beside other busy processes); after it, the counts are back."""
    import cv2
    import faiss
    import numba
    import scipy.fft
    from threadpoolctl import threadpool_info

    from barkgen._shared.threads import thread_budget

    def counts():
        # (an OpenMP build of OpenBLAS, faiss's own, shares OpenMP's count with faiss)
        blas = sorted({p["num_threads"] for p in threadpool_info()
                       if p["user_api"] == "blas" and p.get("threading_layer") != "openmp"})
        return (numba.get_num_threads(), cv2.getNumThreads(), faiss.omp_get_max_threads(),
                scipy.fft.get_workers(), blas)

    before = counts()
    with thread_budget(1) as n:
        assert n == 1 and counts() == (1, 1, 1, 1, [1])
    assert counts() == before
    cores = numba.config.NUMBA_NUM_THREADS
    with thread_budget(None) as n, thread_budget(cores + 5) as m:
        assert n == m == cores and counts()[:4] == (cores,) * 4 and counts()[4] == [1]
    assert counts() == before


def test_upsampled_references_are_the_childs_of_each_parent():
    """Exact up-sampling: each output pixel's reference is the child of its parent's with the
    pixel's own parity; past an odd exemplar's edge it wraps or stays on the last row/column."""
    from barkgen.synth import upsample_references

    rng = np.random.default_rng(0)
    coarse = np.stack([rng.integers(0, 5, (4, 6)), rng.integers(0, 7, (4, 6))], axis=-1)
    fine = upsample_references(coarse, (8, 11), (10, 14))
    assert fine.shape == (8, 11, 2) and fine.dtype == np.int32
    ys, xs = np.mgrid[0:8, 0:11]
    assert np.array_equal(fine[..., 0], 2 * coarse[ys // 2, xs // 2, 0] + ys % 2)
    assert np.array_equal(fine[..., 1], 2 * coarse[ys // 2, xs // 2, 1] + xs % 2)
    edge = np.array([[[4, 6]]])  # an exemplar of 9 x 13: children past row 8 and column 12
    assert upsample_references(edge, (2, 2), (9, 13))[1, 1].tolist() == [8, 12]
    assert upsample_references(edge, (2, 2), (9, 13), (True, True))[1, 1].tolist() == [0, 0]


def test_apply_references_rejects_wrong_size(synthetic_exemplar):
    res = synthesize(synthetic_exemplar, 40, seed=0)
    with pytest.raises(InvalidInputError):
        apply_references(res.references, np.zeros((10, 10), np.uint8))


@pytest.mark.parametrize("bad", [
    dict(exemplar=np.zeros((12, 40, 3), np.uint8), size=64),
    dict(size=(0, 10)),
    dict(size=(-5, 10)),
    dict(size="abc"),
    dict(extra={"height": np.zeros((5, 5), np.uint8)}),
    dict(exemplar=np.zeros((40, 40, 4), np.uint8), size=64),
])
def test_invalid_inputs(synthetic_exemplar, bad):
    kwargs = dict(exemplar=synthetic_exemplar, size=64)
    kwargs.update(bad)
    with pytest.raises(InvalidInputError):
        synthesize(kwargs.pop("exemplar"), kwargs.pop("size"), **kwargs)


def test_memory_budget_is_checked_before_work(synthetic_exemplar):
    with pytest.raises(MemoryBudgetError, match="budget"):
        synthesize(synthetic_exemplar, (50_000, 50_000), config=SynthesisConfig(max_memory=2**30))


def test_config_is_validated():
    with pytest.raises(InvalidInputError):
        SynthesisConfig(k=0)
    with pytest.raises(InvalidInputError):
        SynthesisConfig(schedule_finest=((4, 1),))


# ---- measured quality on real bark (texeval) ------------------------------------------------


def _shuffled_blocks(exemplar: np.ndarray, shape: tuple[int, int], block: int, seed: int) -> np.ndarray:
    """Naive baseline: random exemplar blocks pasted on a grid (visible seams everywhere)."""
    rng = np.random.default_rng(seed)
    out = np.empty(shape + exemplar.shape[2:], exemplar.dtype)
    for y in range(0, shape[0], block):
        for x in range(0, shape[1], block):
            sy = rng.integers(0, exemplar.shape[0] - block + 1)
            sx = rng.integers(0, exemplar.shape[1] - block + 1)
            patch = exemplar[sy:sy + block, sx:sx + block]
            out[y:y + block, x:x + block] = patch[: shape[0] - y, : shape[1] - x]
    return out


@pytest.mark.parametrize("name", ["pine_plated_01", "fissured_gray_01", "oak_furrowed_moss_01"])
def test_quality_on_real_bark(texeval, name):
    """128 px exemplar -> 256 px tileable output, against a baseline of randomly pasted 32 px
    exemplar blocks (coherent inside, unoptimised seams) scored in the same run."""
    from conftest import bark_exemplar

    ex = bark_exemplar(name, 128)
    res = synthesize(ex, 256, tile=True, seed=0)
    a, b = res.image, synthesize(ex, 256, tile=True, seed=1).image
    # an exemplar that tiles is used as a torus, so output patches may lie across its edge:
    # texeval is given it padded round, or it would count those as patches it never had
    wy, wx = res.exemplar_wrap
    ev = texeval.TexEval(np.pad(ex, ((8 * wy, 8 * wy), (8 * wx, 8 * wx), (0, 0)), mode="wrap"))
    m = ev.evaluate(a, output2=b, tile=True)
    m_b = ev.evaluate(b, tile=True)
    base = [ev.evaluate(_shuffled_blocks(ex, (256, 256), 32, s), tile=True) for s in (0, 1)]
    # seams hidden in the texture (two seeds against two block layouts: one pair varies by ~10 %)
    coherence = (m["coherence"] + m_b["coherence"]) / 2
    assert coherence < 0.92 * np.mean([bl["coherence"] for bl in base])
    base = base[0]
    assert m["completeness"] < base["completeness"]  # the whole exemplar is used
    assert 0.9 <= m["sharpness_ratio"] <= 1.1  # no blur, no noise
    assert m["seam_ratio"] <= 1.15  # tiles seamlessly
    assert m["largest_copy"] <= 0.35  # copy-size control
    assert m["diversity"] >= 0.8  # seeds give different textures
