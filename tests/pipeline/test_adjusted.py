"""An edit list's depth and light given to a run's material set after its edits
(:func:`barkgen.pipeline.adjusted_result`): what ``generate --edits`` and the web app's Save
both do."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from barkgen.errors import InvalidInputError
from barkgen.material import Boundary, EditList, MaterialSet, derived_maps
from barkgen.pipeline import GenerateResult, adjusted_result, check_edit_list


def _result(material: MaterialSet | None) -> GenerateResult:
    h, w = (24, 32) if material is None else material.shape
    labels = np.zeros((h, w), np.uint8)
    return GenerateResult(
        texture=np.zeros((h, w, 3), np.uint8),
        labels_in=labels,
        labels_out=labels,
        references=np.zeros((h, w, 2), np.int32),
        extras={},
        label_levels=[],
        report={"seed": 1},
        material=material,
    )


def _set() -> MaterialSet:
    y, x = np.mgrid[0:24, 0:32]
    height = (np.sin(x / 3.0) * 2 + np.cos(y / 4.0)).astype(np.float32)
    normals, ao = derived_maps(height, boundary=Boundary(True))
    light = np.exp(0.5 * np.cos(np.pi * x / 31)).astype(np.float32)  # brighter to the left
    return MaterialSet(
        color=np.full((24, 32, 3), 0.4, np.float32),
        height=height,
        normals=normals,
        ao=ao,
        roughness=np.ones((24, 32), np.float32),
        tile=True,
        pixel_size_m=0.01,
        illumination=light,
        equalization=1.0,
    )


def test_the_depth_scales_the_height_and_the_light_relights_the_colour():
    run = _result(_set())
    assert adjusted_result(run, EditList()) is run  # nothing to change: the run itself
    adjusted = adjusted_result(run, EditList((), 2.0, 0.25))
    material = adjusted.material
    assert material is not None and run.material is not None
    np.testing.assert_allclose(material.height, 2 * run.material.height)
    assert material.physical_size()["displacement_depth_m"] == pytest.approx(2 * run.material.depth * 0.01, rel=1e-6)
    assert material.equalization == 0.25
    # three quarters of the light put back: brighter where the photo was lit, darker elsewhere
    np.testing.assert_allclose(material.color, run.material.relit_color(0.25))
    assert material.color[:, 0].mean() > 0.4 > material.color[:, -1].mean()
    assert adjusted.report == {"seed": 1, "adjusted": {"relief": 2.0, "light_equalization": 0.25}}


def test_a_run_without_a_set_or_with_a_scanned_relief_is_refused_in_one_line():
    check_edit_list(EditList((), 1.0, None), material=False)  # edits alone: generate's own check
    with pytest.raises(InvalidInputError, match="turn material on"):
        check_edit_list(EditList((), 2.0, None), material=False)
    with pytest.raises(InvalidInputError, match="turn material on"):
        adjusted_result(_result(None), EditList((), 1.0, 0.5))
    scanned = _result(dataclasses.replace(_set(), scanned=("normals", "height")))
    with pytest.raises(InvalidInputError, match="scan's own"):
        adjusted_result(scanned, EditList((), 1.5, None))
    assert adjusted_result(scanned, EditList((), 1.0, 0.5)).material.equalization == 0.5  # type: ignore[union-attr]
