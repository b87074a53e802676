"""Synthesis along orientation and scale fields (issue 34): the turned copies' geometry, normals
turned with the bark, the engine, texture-by-numbers and generate following a field, and bad
fields refused in one line."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run

from barkgen.errors import InvalidInputError
from barkgen.synth import Budget, Canvas, OrientedExemplar, check_flow, orient_exemplar, synthesize, texture_by_numbers


def _stripes(size: int = 64, period: float = 6.0, seed: int = 0) -> np.ndarray:
    """Upright stripes (they run up the screen), tileable, with some noise."""
    rng = np.random.default_rng(seed)
    x = np.arange(size)[None, :]
    grey = 128 + 90 * np.sin(2 * np.pi * x / period * np.ones((size, 1))) + rng.normal(0, 12, (size, size))
    return np.repeat(np.clip(grey, 0, 255).astype(np.uint8)[..., None], 3, axis=2)


def _stripe_direction(image: np.ndarray) -> float:
    """The direction stripes run in (degrees, counter-clockwise on screen, mod 180), from the
    structure tensor of the whole image."""
    grey = image[..., 0].astype(np.float64)
    gx = np.gradient(grey, axis=1)
    gy = -np.gradient(grey, axis=0)  # up the screen
    jxx, jyy, jxy = (gx * gx).sum(), (gy * gy).sum(), (gx * gy).sum()
    across = 0.5 * np.degrees(np.arctan2(2 * jxy, jxx - jyy))
    return float(np.mod(across + 90.0, 180.0))


def _angle_error(a: float, b: float) -> float:
    return abs((a - b + 90.0) % 180.0 - 90.0)


def test_the_copies_sample_the_exemplar_where_they_say():
    rng = np.random.default_rng(1)
    labels = rng.integers(0, 5, (48, 40)).astype(np.uint8)
    field = np.array([[0.0, 30.0], [95.0, -170.0]], np.float32).repeat(8, 0).repeat(8, 1)
    scale = np.array([[1.0, 2.0], [1.0, 0.5]], np.float32).repeat(8, 0).repeat(8, 1)
    for wrap in ((True, True), (False, False)):
        oriented = orient_exemplar(labels.shape, field, scale, wrap=wrap)
        assert oriented.n_copies == 4 and sorted(oriented.angles) == [-165.0, 0.0, 30.0, 90.0]
        atlas = oriented.atlas(labels, kind="labels")
        assert atlas.shape == oriented.atlas_shape and atlas.dtype == np.uint8
        valid = oriented.valid()
        refs = np.argwhere(valid)[None, :, :]
        coords = oriented.exemplar_coordinates(refs)[0]
        rows = np.clip(np.floor(coords[:, 0] + 0.5).astype(int), 0, 48) % 48
        cols = np.clip(np.floor(coords[:, 1] + 0.5).astype(int), 0, 40) % 40
        assert np.mean(atlas[valid] == labels[rows, cols]) > 0.98  # (ties at half pixels aside)
        # each output pixel wants the copy of its turn and scale
        target = oriented.target(field, scale)
        turns, scales = oriented.turns(np.stack([target * oriented.pitch + oriented.margin, target * 0], -1))
        assert np.allclose(np.mod(turns - field + 180, 360) - 180, 0, atol=7.5)
        assert np.allclose(np.log2(scales / scale), 0, atol=0.26)
        again = OrientedExemplar.from_dict(oriented.to_dict())
        assert again == oriented
    # a copy turned by a quarter is the exemplar turned (on its torus, no resampling)
    photo = rng.integers(0, 255, (32, 32, 3)).astype(np.uint8)
    quarter = orient_exemplar(
        photo.shape[:2], np.full((4, 4), 90.0, np.float32), np.ones((4, 4), np.float32), wrap=(True, True)
    )
    copy = quarter.atlas(photo)[quarter.margin : quarter.margin + 32]
    assert any(np.array_equal(copy, np.roll(np.rot90(photo), (dy, dx), (0, 1))) for dy in range(32) for dx in range(32))


def test_normals_turn_with_the_bark():
    normals = np.zeros((32, 32, 3), np.float32)
    normals[..., 0], normals[..., 2] = 0.6, 0.8  # facing right (+x)
    oriented = orient_exemplar(
        (32, 32), np.full((2, 2), 90.0, np.float32), np.ones((2, 2), np.float32), wrap=(True, True)
    )
    turned = oriented.atlas(normals, kind="normals")
    assert np.allclose(turned[..., :], [0.0, 0.6, 0.8], atol=1e-5)  # now facing up the screen
    encoded = np.round((normals + 1) * 127.5).astype(np.uint8)
    back = oriented.atlas(encoded, kind="normals").astype(np.float32) / 127.5 - 1
    assert np.allclose(back, [0.0, 0.6, 0.8], atol=0.02)


def test_synthesis_follows_a_turned_field_and_is_reproducible():
    exemplar = _stripes()
    assert _angle_error(_stripe_direction(exemplar), 90.0) < 3
    plain = synthesize(exemplar, (64, 96), seed=3)
    assert _angle_error(_stripe_direction(plain.image), 90.0) < 5
    for angle in (90.0, 45.0, -30.0):
        field = np.full((64, 96), angle, np.float32)
        result = synthesize(exemplar, canvas=Canvas((64, 96), flow=field), budget=Budget(seed=3))
        assert result.orientation is not None and result.exemplar_shape == result.orientation.atlas_shape
        assert _angle_error(_stripe_direction(result.image), 90.0 + angle) < 6, angle
    # two halves turned apart: each follows its own
    field = np.zeros((64, 96), np.float32)
    field[:, 48:] = 60.0
    first = synthesize(exemplar, canvas=Canvas((64, 96), tile=True, flow=field), budget=Budget(seed=5))
    assert _angle_error(_stripe_direction(first.image[:, 4:44]), 90.0) < 8
    assert _angle_error(_stripe_direction(first.image[:, 52:92]), 150.0) < 8
    second = synthesize(exemplar, canvas=Canvas((64, 96), tile=True, flow=field), budget=Budget(seed=5))
    assert np.array_equal(first.image, second.image) and np.array_equal(first.references, second.references)


def test_texture_by_numbers_keeps_its_labels_along_a_field():
    exemplar = _stripes(seed=2)
    ex_labels = np.where(np.arange(64)[:, None] < 32, 0, 255).astype(np.uint8) * np.ones((1, 64), np.uint8)
    target = np.zeros((64, 64), np.uint8)
    target[:, 32:] = 255
    field = np.full((64, 64), 90.0, np.float32)
    result = texture_by_numbers(exemplar, ex_labels, target, canvas=Canvas((64, 64), flow=field), budget=Budget(seed=1))
    atlas_labels = result.orientation.atlas(ex_labels, kind="labels")
    got = atlas_labels[result.references[..., 0], result.references[..., 1]]
    assert np.mean(got == target) > 0.97
    assert _angle_error(_stripe_direction(result.image), 180.0) < 8


@pytest.mark.parametrize(
    ("flow", "scale", "said"),
    [
        (np.zeros((8, 9)), None, "the flow field is 9x8; it must be the output's size, 8x8"),
        (np.full((8, 8), np.nan), None, "not a number at x=0, y=0"),
        (None, np.full((8, 8), 9.0), "between 0.25 and 4"),
        (np.full((8, 8), "a"), None, "must hold numbers"),
    ],
)
def test_bad_fields_are_refused_in_one_line(flow, scale, said):
    with pytest.raises(InvalidInputError, match=said):
        check_flow(flow, scale, (8, 8))


def test_cli_flow_fields_and_their_reference_map(tmp_path):
    from barkgen.io import read_image, write_png

    photo = tmp_path / "stripes.png"
    write_png(photo, _stripes(seed=4))
    field = np.zeros((48, 64), np.float32)
    field[:, 32:] = 45.0
    np.save(tmp_path / "flow.npy", field)
    out, ref = tmp_path / "out.png", tmp_path / "ref.png"
    done = run(
        "synth",
        str(photo),
        "-o",
        str(out),
        "--size",
        "64x48",
        "--flow",
        str(tmp_path / "flow.npy"),
        "--blend",
        "none",
        "--save-reference",
        str(ref),
        "-q",
    )
    assert done.returncode == 0, done.stderr
    again = tmp_path / "again.png"
    done = run("apply-reference", str(ref), str(photo), "-o", str(again))
    assert done.returncode == 0, done.stderr
    assert np.array_equal(read_image(again), read_image(out))
    # a field of the wrong size: one line, exit 2, nothing written
    np.save(tmp_path / "small.npy", field[:, :40])
    bad = tmp_path / "bad"
    done = run("generate", str(photo), "-o", str(bad), "--size", "64x48", "--flow", str(tmp_path / "small.npy"), "-q")
    assert (
        done.returncode == 2 and "the flow field is 40x48" in done.stderr and len(done.stderr.strip().splitlines()) == 1
    )
    assert not bad.exists() or not any(bad.iterdir())
    # a grey image is a field too: mid-grey 0, a quarter above it 90 degrees
    grey = np.full((48, 64), 32768 + 16384, np.uint16)
    write_png(tmp_path / "flow.png", grey)
    done = run(
        "synth",
        str(photo),
        "-o",
        str(tmp_path / "image.png"),
        "--size",
        "64x48",
        "--flow",
        str(tmp_path / "flow.png"),
        "-q",
    )
    assert done.returncode == 0, done.stderr
    assert _angle_error(_stripe_direction(read_image(tmp_path / "image.png")), 180.0) < 8


def test_linked_pixels_show_their_sources_in_their_own_frame():
    from barkgen.synth import OutputLinks

    exemplar = _stripes(seed=6)
    rows = np.arange(64)[:, None]
    target = (rows * 64 + np.arange(60, 64)[None, :]).ravel()  # the last four columns ...
    source = (rows * 64 + np.arange(0, 4)[None, :]).ravel()  # ... show the first four
    links = OutputLinks((64, 64), target, source)
    plain = synthesize(exemplar, canvas=Canvas((64, 64), links=links), budget=Budget(seed=2))
    flat = plain.references.reshape(-1, 2)
    assert np.array_equal(flat[target], flat[source])
    # along a field that turns the linked columns apart: the same exemplar point, each in its copy
    field = np.zeros((64, 64), np.float32)
    field[:, 32:] = 90.0
    turned = synthesize(exemplar, canvas=Canvas((64, 64), flow=field, links=links), budget=Budget(seed=2))
    coords = turned.orientation.exemplar_coordinates(turned.references).reshape(-1, 2)
    turns, _ = turned.orientation.turns(turned.references)
    assert np.allclose(turns.reshape(-1)[target], 90.0) and np.allclose(turns.reshape(-1)[source], 0.0)
    apart = np.abs(coords[target] - coords[source])
    apart = np.minimum(apart, 64 - apart)  # on the exemplar's torus
    assert np.median(apart.max(axis=1)) <= 1.0
