""":func:`barkgen.evaluate.label_share` and :func:`barkgen.evaluate.direction_agreement`: how a
result's reference map follows its target label map."""

from __future__ import annotations

import numpy as np
import pytest

from barkgen.errors import InvalidInputError
from barkgen.evaluate import direction_agreement, label_share


def _identity(shape: tuple[int, int]) -> np.ndarray:
    return np.stack(np.mgrid[0 : shape[0], 0 : shape[1]], -1).astype(np.int32)


def test_a_line_copied_along_itself_agrees_and_one_copied_across_disagrees():
    exemplar = np.full((48, 48), 255, np.uint8)
    exemplar[24, :] = 0  # a horizontal crack
    refs = _identity((48, 48))
    assert label_share(exemplar, exemplar, refs, 0) == 1.0
    assert direction_agreement(exemplar, exemplar, refs, 0) == pytest.approx(1.0, abs=1e-3)
    # the target's crack runs down; its pixels copy the exemplar's horizontal crack, turned
    target = exemplar.T.copy()
    turned = refs[:, :, ::-1].copy()
    assert label_share(exemplar, target, turned, 0) == 1.0
    assert direction_agreement(exemplar, target, turned, 0) == pytest.approx(-1.0, abs=1e-3)
    # filled from the bark: no share; from a photo without cracks, no direction to compare
    bark = refs.copy()
    bark[..., 0] = 5
    assert label_share(exemplar, exemplar, bark, 0) == 0.0
    assert np.isnan(direction_agreement(np.full_like(exemplar, 255), exemplar, refs, 0))
    assert np.isnan(label_share(exemplar, np.full((4, 4), 255, np.uint8), refs[:4, :4], 0))


def test_colour_labels_and_bad_references_are_told_apart():
    exemplar = np.zeros((8, 8, 3), np.uint8)
    exemplar[:, :4] = (200, 10, 10)
    refs = _identity((8, 8))
    assert label_share(exemplar, exemplar, refs, (200, 10, 10)) == 1.0
    with pytest.raises(InvalidInputError, match="integer array of shape"):
        label_share(exemplar, exemplar, refs[:4], (200, 10, 10))
    with pytest.raises(InvalidInputError, match="points outside"):
        label_share(exemplar, exemplar, refs + 8, (200, 10, 10))
