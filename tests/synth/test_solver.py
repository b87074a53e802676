"""The discrete solver (:mod:`barkgen.synth._solver`, mazzolini2012 §4.1, laitoch2018 §3.3):
stopping and resuming at a level, the thread budget, exact up-sampling, the level context and
its keyword-only entry point."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.errors import InvalidInputError
from barkgen.synth import SynthesisConfig


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

    from barkgen.synth import AnalysisCache, Budget, Canvas, SolverInputs

    inputs = SolverInputs(synthetic_exemplar, features, n_levels, config)
    canvas = Canvas((96, 96), tile=True, exemplar_wrap=(False, False))
    # the stopped run analyses only the levels it solves; the full run then goes on below them
    cache = AnalysisCache()
    stopped = solve(inputs, canvas, Budget(seed=4, cache=cache), stop_level=1)
    (levels_kept,) = cache._entries.values()
    assert levels_kept[0] is None and all(la is not None for la in levels_kept[1:])
    solve(inputs, canvas, Budget(seed=4, cache=cache, debug=keep))
    (levels_now,) = cache._entries.values()
    assert levels_now[0] is not None and all(a is b for a, b in zip(levels_now[1:], levels_kept[1:]))
    assert len(cache) == 1
    h, w = level_shape(synthetic_exemplar.shape[:2], 1)
    assert stopped.exemplar_shape == (h, w) and stopped.references.shape == (48, 48, 2)
    assert stopped.references[..., 0].max() < h and stopped.references[..., 1].max() < w
    assert np.array_equal(stopped.image, levels[1])
    flat = (stopped.references[..., 0] * w + stopped.references[..., 1]).astype(np.int32)
    resumed = solve(inputs, canvas, Budget(seed=4), start=(1, flat))
    assert np.array_equal(resumed.image, synthetic_exemplar[resumed.references[..., 0], resumed.references[..., 1]])
    with pytest.raises(InvalidInputError, match="stop_level"):
        solve(inputs, canvas, Budget(seed=4), stop_level=n_levels)


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
        blas = sorted(
            {
                p["num_threads"]
                for p in threadpool_info()
                if p["user_api"] == "blas" and p.get("threading_layer") != "openmp"
            }
        )
        return (
            numba.get_num_threads(),
            cv2.getNumThreads(),
            faiss.omp_get_max_threads(),
            scipy.fft.get_workers(),
            blas,
        )

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


def test_solve_takes_its_inputs_canvas_and_budget_then_keywords(synthetic_exemplar):
    """``solve(inputs, canvas, budget, *, ...)``: what is copied, what the output is and how the
    run works are three objects; everything else is a keyword, refused by position before any
    work."""
    import inspect

    from barkgen.synth import Budget, Canvas, SolverInputs, matching_features, solve

    parameters = inspect.signature(solve).parameters.values()
    assert [p.name for p in parameters if p.kind != inspect.Parameter.KEYWORD_ONLY] == ["inputs", "canvas", "budget"]
    assert len(parameters) <= 10
    features = matching_features(synthetic_exemplar, None, 0.0)
    inputs = SolverInputs(synthetic_exemplar, features, 2, SynthesisConfig())
    with pytest.raises(TypeError):
        solve(inputs, Canvas((32, 32), exemplar_wrap=(False, False)), Budget(), None)  # noqa - on purpose


def _level(synthetic_exemplar, config):
    from barkgen.synth import AnalysisCache, matching_features

    features = matching_features(synthetic_exemplar, None, 0.0)
    return AnalysisCache().analyse(features, 2, config)


def _context(la, config, rng, tile, seam_channels):
    """Level 1 of 2 of a 40x48 output (20x24 at that level), unguided."""
    from barkgen.synth import Canvas, SolverInputs
    from barkgen.synth._level import level_context

    inputs = SolverInputs(np.zeros((1, 1, 1)), np.zeros((1, 1, 1), np.float32), 2, config, seam_channels=seam_channels)
    return level_context(la, 1, inputs, Canvas((40, 48), tile=tile), rng, None)


def test_a_level_context_carries_the_level_and_cannot_be_changed(synthetic_exemplar):
    """:class:`LevelContext` holds what a level's steps share: unguided, its guide is empty; its
    seam image is the level's first ``seam_channels`` feature channels as an image; it is frozen."""
    import dataclasses

    from barkgen.synth._level import LevelContext

    config = SynthesisConfig(coarsest_exemplar=8)
    levels = _level(synthetic_exemplar, config)
    la = levels[1]
    rng = np.random.default_rng(0)
    ctx = _context(la, config, rng, True, 1)
    assert isinstance(ctx, LevelContext)
    assert (ctx.level, ctx.n_levels, ctx.shape, ctx.tile) == (1, 2, (20, 24), True)
    assert ctx.analysis is la and ctx.config is config and ctx.rng is rng
    assert not ctx.guide.guided and ctx.guide.guide_ex == {} and ctx.guide.expected is None
    assert ctx.seam_image.shape == (la.height, la.width, 1)
    assert np.array_equal(ctx.seam_image.reshape(-1), la.features[:, 0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        ctx.level = 0


def test_the_coarsest_state_draws_from_the_contexts_generator(synthetic_exemplar):
    """Unguided, the coarsest level starts from references drawn uniformly over the level's
    exemplar by the solve's one generator (so the same seed gives the same start)."""
    from barkgen.synth._level import initial_state

    config = SynthesisConfig(coarsest_exemplar=8)
    la = _level(synthetic_exemplar, config)[1]
    ctx = _context(la, config, np.random.default_rng(5), False, None)
    refs = initial_state(ctx, None)
    expected = np.random.default_rng(5).integers(0, la.height * la.width, size=(20, 24), dtype=np.int32)
    assert refs.dtype == np.int32 and np.array_equal(refs, expected)
    assert ctx.seam_image.shape[2] == la.features.shape[1]  # seam_channels None: all channels
