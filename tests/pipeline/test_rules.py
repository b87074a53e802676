"""The rules of a run (:mod:`barkgen.pipeline.rules`): checked once, before any work, each in
one line."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from barkgen import Canvas
from barkgen.errors import InvalidInputError
from barkgen.pipeline import GenerateOptions, analyze_photo, generate

PHOTO = np.full((64, 64, 3), 128, np.uint8)


@pytest.mark.parametrize(
    "options, kwargs, message",
    [
        (
            GenerateOptions(size=(64, 64)),
            {"canvas": Canvas((32, 64))},
            "the canvas is 64x32 px but the output is 64x64",
        ),
        (GenerateOptions(size=(64, 64), tile=True), {"canvas": Canvas((64, 64))}, "output is 64x64 px, tiled"),
        (GenerateOptions(size=(64, 64)), {"edits": [object()]}, "height edits apply"),
        (GenerateOptions(size=(64, 64)), {"labels_in": np.zeros((32, 32), np.uint8)}, "the label map is 32x32"),
        (GenerateOptions(size=(64, 64), model="bilayer"), {"labels_in": PHOTO[..., 0]}, "noise clusters"),
        (
            GenerateOptions(size=(64, 64), structure="cracks"),
            {"canvas": Canvas((64, 64), flow=np.zeros((64, 64), np.float32))},
            "cracks does not follow a flow field",
        ),
    ],
)
def test_a_run_breaking_a_rule_is_refused_before_any_work(options, kwargs, message, monkeypatch):
    import barkgen.pipeline.core as core

    def no_work(*args, **kw):
        raise AssertionError("the analysis started")

    monkeypatch.setattr(core, "_analysis_stage", no_work)
    with pytest.raises(InvalidInputError, match=message):
        generate(PHOTO, options, **kwargs)


def test_generate_and_analyze_photo_take_at_most_ten_parameters():
    for function in (generate, analyze_photo):
        assert len(inspect.signature(function).parameters) <= 10
