"""The one set-up path of synthesize and texture-by-numbers (:mod:`barkgen.synth._setup`): inputs
validated, the memory budget checked before any work, the exemplar's wrap, features, levels."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.errors import InvalidInputError, MemoryBudgetError
from barkgen.synth import SynthesisConfig, synthesize


@pytest.mark.parametrize(
    "bad",
    [
        dict(exemplar=np.zeros((12, 40, 3), np.uint8), size=64),
        dict(size=(0, 10)),
        dict(size=(-5, 10)),
        dict(size="abc"),
        dict(extra={"height": np.zeros((5, 5), np.uint8)}),
        dict(exemplar=np.zeros((40, 40, 4), np.uint8), size=64),
    ],
)
def test_invalid_inputs(synthetic_exemplar, bad):
    kwargs = dict(exemplar=synthetic_exemplar, size=64)
    kwargs.update(bad)
    with pytest.raises(InvalidInputError):
        synthesize(kwargs.pop("exemplar"), kwargs.pop("size"), **kwargs)


def test_memory_budget_is_checked_before_work(synthetic_exemplar):
    with pytest.raises(MemoryBudgetError, match="budget"):
        synthesize(synthetic_exemplar, (50_000, 50_000), config=SynthesisConfig(max_memory=2**30))


def test_windowed_finest_levels_are_budgeted_as_a_window_and_a_few_bytes_a_pixel():
    """A 16384² solve whose finest levels go in 1024 px windows needs one window's working
    arrays and what its levels hold whole (about 64 B a pixel, 17 GiB), not a whole solve's
    (54 GiB, which refused ``generate``'s 16384² texture stage on a 24 GiB machine); a budget
    below that is still refused."""
    from barkgen.synth._setup import WINDOWED_SOLVE_BYTES_PER_PIXEL, check_memory

    photo = np.zeros((1024, 1024, 3), np.uint8)

    def fits(window: int, budget: int) -> bool:
        try:
            check_memory(photo, {}, (16384, 16384), 5, SynthesisConfig(window=window, max_memory=budget), guided=True)
        except MemoryBudgetError:
            return False
        return True

    assert fits(1024, 20 * 2**30) and not fits(0, 20 * 2**30)
    assert not fits(1024, WINDOWED_SOLVE_BYTES_PER_PIXEL * 16384**2)  # (the window's own on top)


def test_the_set_up_is_what_synthesize_runs(synthetic_exemplar):
    """:func:`set_up` then :meth:`SolveSetup.solve` is :func:`synthesize`, byte for byte; a grey
    ``(h, w)`` exemplar is given back as a grey image."""
    from barkgen.synth import Budget, Canvas, matching_features
    from barkgen.synth._setup import SolveSetup, set_up

    config = SynthesisConfig()
    canvas = Canvas((40, 56), tile=True, exemplar_wrap="no")
    setup = set_up(synthetic_exemplar, None, config, canvas, Budget(seed=3))
    assert isinstance(setup, SolveSetup)
    assert setup.exemplar.shape == synthetic_exemplar.shape and setup.canvas.shape == (40, 56)
    assert setup.wrap == (False, False) and not setup.flat and setup.inputs.n_levels >= 2
    assert np.array_equal(setup.inputs.features, matching_features(synthetic_exemplar, None, config.extra_weight))
    direct = synthesize(synthetic_exemplar, (40, 56), seed=3, tile=True, exemplar_wrap="no")
    assert np.array_equal(setup.solve().image, direct.image)
    grey = set_up(synthetic_exemplar[:, :, 0], None, config, Canvas((40, 40)), Budget(seed=0))
    assert grey.flat and grey.exemplar.shape[2] == 1 and grey.solve().image.ndim == 2


def test_the_set_up_checks_in_order_inputs_front_memory_then_wrap(synthetic_exemplar):
    """Validation first, then the front's own checks, then the memory budget, and only then is
    the exemplar's wrap resolved (a bad wrap setting on an impossible size is a budget error)."""
    from barkgen.synth import Budget, Canvas
    from barkgen.synth._setup import Front, set_up

    seen = []

    class Refusing(Front):
        def check(self, ex):
            seen.append(ex.shape)
            raise InvalidInputError("the front's own inputs do not fit")

    budget = SynthesisConfig(max_memory=2**30)
    with pytest.raises(InvalidInputError):  # validation before the front
        set_up(synthetic_exemplar, None, budget, Canvas((0, 10), exemplar_wrap="no"), Budget(), front=Refusing())
    assert seen == []
    with pytest.raises(InvalidInputError, match="front"):  # the front before the budget
        set_up(
            synthetic_exemplar, None, budget, Canvas((50_000, 50_000), exemplar_wrap="no"), Budget(), front=Refusing()
        )
    assert seen == [synthetic_exemplar.shape]
    with pytest.raises(MemoryBudgetError):  # the budget before the wrap setting
        set_up(synthetic_exemplar, None, budget, Canvas((50_000, 50_000), exemplar_wrap="sometimes"), Budget())


def test_a_front_adds_its_channels_to_the_memory_estimate(synthetic_exemplar):
    """A guided front's added feature channels and label tables make its estimate larger: a
    budget just above the plain estimate refuses the guided job."""
    from barkgen.synth import estimate_memory
    from barkgen.synth._setup import Front, check_memory

    config = SynthesisConfig()
    plain = estimate_memory(synthetic_exemplar.shape[:2], (512, 512), 3, 1, 3, config)
    just_enough = SynthesisConfig(max_memory=plain + 1)
    check_memory(synthetic_exemplar, {}, (512, 512), 3, just_enough)

    class Guided(Front):
        added_channels = 1
        guided = True

    with pytest.raises(MemoryBudgetError):
        check_memory(synthetic_exemplar, {}, (512, 512), 3 + Guided.added_channels, just_enough, guided=Guided.guided)
