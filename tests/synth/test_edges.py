"""The exemplar's edges (:mod:`barkgen.synth._edges`): an exemplar that tiles itself is told from
one that does not, and the ``exemplar_wrap`` settings."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.errors import InvalidInputError
from barkgen.synth import exemplar_wraps, resolve_exemplar_wrap, synthesize
from barkgen.synth._edges import edge_step_shares


def test_a_texture_that_tiles_is_told_from_one_that_does_not(sample256, photo_like):
    assert exemplar_wraps(sample256) == (True, True)
    # the same texture cut in the middle: its edges no longer meet
    assert exemplar_wraps(sample256[40:200, 30:220]) == (False, False)
    # rolled by half it still tiles (the torus has no edge)
    assert exemplar_wraps(np.roll(sample256, (128, 100), axis=(0, 1))) == (True, True)
    assert exemplar_wraps(photo_like()) == (False, False)
    sy, sx = edge_step_shares(sample256)
    assert sy < 0.3 and sx < 0.3
    cy, cx = edge_step_shares(sample256[40:200, 30:220])
    assert cy > 0.5 and cx > 0.5


def test_exemplar_wrap_settings(photo_like):
    img = photo_like()
    assert resolve_exemplar_wrap("yes", img) == (True, True)
    assert resolve_exemplar_wrap("no", img) == (False, False)
    assert resolve_exemplar_wrap((True, False), img) == (True, False)
    for bad in ("maybe", (True,), 3):
        with pytest.raises(InvalidInputError):
            resolve_exemplar_wrap(bad, img)
    with pytest.raises(InvalidInputError):
        synthesize(img, 32, exemplar_wrap="sometimes")
