"""Texture-by-numbers: label handling, initialisations, behaviour and measured quality."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from barkgen.errors import InvalidInputError
from barkgen.synth import SynthesisConfig, synthesize, texture_by_numbers
from barkgen.synth.guides.channels import boundary_distance, encode_label_maps, label_pyramid
from barkgen.synth.guides.initialization import random_initialization, smart_initialization
from barkgen.synth import TBN_CONFIG


def luminance_labels(image: np.ndarray, n: int = 2) -> np.ndarray:
    """Grey label map by luminance quantiles (a stand-in for the k-means label maps)."""
    lum = image.astype(np.float32).mean(axis=2)
    edges = np.quantile(lum, np.linspace(0, 1, n + 1)[1:-1])
    return (np.digitize(lum, edges) * (255 // (n - 1))).astype(np.uint8)


@pytest.fixture(scope="module")
def case(synthetic_exemplar):
    from barkgen.testing import shuffled_blocks

    ex = synthetic_exemplar[:40, :40]
    a = luminance_labels(ex)
    b = shuffled_blocks(a, 64, block=8, seed=2)
    return ex, a, b


def source_labels(result, a):
    return a[result.references[..., 0], result.references[..., 1]]


# --------------------------------------------------------------------------------------------
# label maps


def test_encode_label_maps_shares_one_palette():
    a = np.array([[10, 20], [30, 20]], np.uint8)
    b = np.array([[30, 30, 10]], np.uint8)
    lm = encode_label_maps(a, b, (2, 2))
    assert lm.n_labels == 3
    assert np.array_equal(lm.palette[lm.exemplar][..., 0], a)
    assert np.array_equal(lm.palette[lm.target][..., 0], b)


def test_colour_label_maps_and_grey_saved_as_rgb_are_accepted():
    a = np.zeros((4, 4, 3), np.uint8)
    a[:2] = (255, 0, 0)
    b = np.zeros((3, 5, 3), np.uint8)
    b[1] = (255, 0, 0)
    lm = encode_label_maps(a, b)
    assert lm.n_labels == 2 and lm.target.sum() == 5
    grey_rgb = np.repeat(np.array([[0, 9]], np.uint8)[..., None], 3, axis=2)
    assert encode_label_maps(np.array([[0, 9]], np.uint8), grey_rgb).n_labels == 2


@pytest.mark.parametrize("a, b, message", [
    (np.zeros((4, 4), np.uint8), np.full((4, 4), 7, np.uint8), "does not have"),
    (np.arange(100, dtype=np.uint8).reshape(10, 10), np.zeros((4, 4), np.uint8), "at most 64"),
    (np.zeros((4, 4), np.uint8), np.zeros((4, 4, 3), np.uint8) + [1, 2, 3], "grey"),
    (np.zeros((5, 4), np.uint8), np.zeros((4, 4), np.uint8), "must match"),
])
def test_bad_label_maps_are_refused(a, b, message):
    with pytest.raises(InvalidInputError, match=message):
        encode_label_maps(a, b, a.shape[:2] if a.shape[0] != 5 else (4, 4))


def test_label_pyramid_keeps_the_majority():
    codes = np.zeros((16, 16), np.int32)
    codes[:, 10:] = 1
    levels = label_pyramid(codes, 2, 3)
    assert [lv.shape for lv in levels] == [(16, 16), (8, 8), (4, 4)]
    assert (levels[1][:, :4] == 0).all() and (levels[1][:, 6:] == 1).all()
    assert (levels[2][:, 0] == 0).all() and (levels[2][:, 3] == 1).all()


def test_boundary_distance_is_close_to_euclidean():
    codes = np.zeros((40, 40), np.int32)
    codes[15:25, 15:25] = 1
    got = boundary_distance(codes)
    ys, xs = np.nonzero(got == 0)
    assert {(y, x) for y, x in zip(ys, xs)} >= {(15, 15), (24, 24), (14, 20)}
    yy, xx = np.mgrid[0:40, 0:40]
    exact = np.min(np.hypot(yy[..., None] - ys, xx[..., None] - xs), axis=-1)
    assert np.abs(got - exact).max() < 0.1 * exact.max() + 1.0
    assert boundary_distance(codes, clip=3.0).max() == 3.0


# --------------------------------------------------------------------------------------------
# initialisations


def test_random_initialization_respects_labels(case):
    _, a, b = case
    lm = encode_label_maps(a, b)
    refs = random_initialization(lm.exemplar, lm.target, np.random.default_rng(0))
    assert np.array_equal(lm.exemplar.ravel()[refs], lm.target)


def test_smart_initialization_copies_coherent_regions_with_the_right_labels(case):
    _, a, b = case
    lm = encode_label_maps(a, b)
    refs = smart_initialization(lm.exemplar, lm.target, np.random.default_rng(0))
    assert refs.min() >= 0
    assert (lm.exemplar.ravel()[refs] == lm.target).mean() > 0.9
    # coherent: most horizontal neighbours continue the same exemplar piece
    w = lm.exemplar.shape[1]
    continued = (refs[:, 1:] == refs[:, :-1] + 1) & (refs[:, 1:] % w != 0)
    assert continued.mean() > 0.5
    rand = random_initialization(lm.exemplar, lm.target, np.random.default_rng(0))
    assert continued.mean() > 5 * ((rand[:, 1:] == rand[:, :-1] + 1).mean())


# --------------------------------------------------------------------------------------------
# texture_by_numbers


def test_output_follows_the_target_labels(case):
    ex, a, b = case
    res = texture_by_numbers(ex, a, b, seed=1)
    assert res.image.shape == b.shape + (3,) and res.image.dtype == ex.dtype
    assert (source_labels(res, a) == b).mean() > 0.9
    # without the seam blending, the image is exemplar pixels resolved through the references
    # (nothing blurred); the blending changes the colour only, never the references
    exact = texture_by_numbers(ex, a, b, seed=1, config=dataclasses.replace(TBN_CONFIG, blend="none"))
    assert np.array_equal(exact.references, res.references)
    assert np.array_equal(exact.image, ex[res.references[..., 0], res.references[..., 1]])
    unguided = synthesize(ex, b.shape, seed=1)
    assert (source_labels(res, a) == b).mean() > (source_labels(unguided, a) == b).mean() + 0.2


@pytest.mark.parametrize("init", ["smart", "random"])
def test_same_seed_same_result_any_thread_count(case, init):
    ex, a, b = case
    one = texture_by_numbers(ex, a, b, seed=4, init=init, config=SynthesisConfig(threads=1))
    two = texture_by_numbers(ex, a, b, seed=4, init=init, config=SynthesisConfig(threads=2))
    assert np.array_equal(one.image, two.image)
    other = texture_by_numbers(ex, a, b, seed=5, init=init)
    assert not np.array_equal(one.image, other.image)


def test_extras_grey_exemplars_and_tiles(case):
    ex, a, b = case
    height = (ex.astype(np.uint16).sum(axis=2) * 80).astype(np.uint16)  # the exemplar's shapes
    res = texture_by_numbers(ex, a, b, extra={"height": height}, tile=True, seed=0)
    from conftest import assert_continuous_copy

    assert res.extras["height"].dtype == np.uint16
    assert_continuous_copy(res.extras["height"][..., 0], height, res.references, tolerance=0.35)
    grey = texture_by_numbers(ex[:, :, 0], a, b[:40, :50], seed=0)
    assert grey.image.shape == (40, 50)


def test_debug_receives_levels_initialization_and_results(case):
    ex, a, b = case
    seen = {}
    texture_by_numbers(ex, a, b, debug=lambda name, img: seen.setdefault(name, img))
    assert {"initialization", "level0_result", "level0_exemplar_labels",
            "level0_target_labels", "feature_distance"} <= set(seen)
    assert all(img.dtype == np.uint8 for img in seen.values())


@pytest.mark.parametrize("kwargs, message", [
    ({"init": "clever"}, "init must be"),
    ({"label_weight": -1.0}, "label_weight"),
    ({"feature_weight": float("nan")}, "feature_weight"),
    ({"init": np.zeros((64, 64), np.int32)}, "reference map must be"),
    ({"init": np.full((64, 64, 2), 40, np.int32)}, "outside the exemplar"),
    ({"init_level": -1}, "init_level"),
])
def test_bad_parameters_are_refused(case, kwargs, message):
    ex, a, b = case
    with pytest.raises(InvalidInputError, match=message):
        texture_by_numbers(ex, a, b, **kwargs)


def test_start_from_a_reference_map(case):
    """A reference map as ``init`` (e.g. of a synthesized label map) is taken up at a finer
    level: the result is as label-exact as from the smart start and keeps much of the given
    references."""
    ex, a, b = case
    # the answer is known: the target is made of the exemplar label map's blocks; a reference
    # map of exemplar pixels with the target's labels, block-coherent
    from barkgen.testing import shuffled_blocks

    yy, xx = np.mgrid[0:40, 0:40]
    coords = np.stack([yy, xx], -1)
    refs = np.stack([shuffled_blocks(coords[..., i], 64, block=8, seed=2) for i in range(2)], -1)
    assert np.array_equal(a[refs[..., 0], refs[..., 1]], b)
    result = texture_by_numbers(ex, a, b, init=refs.astype(np.int32), seed=0)
    smart = texture_by_numbers(ex, a, b, seed=0)
    assert np.mean(source_labels(result, a) == b) >= np.mean(source_labels(smart, a) == b) - 0.005
    kept = np.mean(np.all(result.references == refs, axis=-1))
    assert kept > 1.5 * np.mean(np.all(smart.references == refs, axis=-1)) and kept > 0.1
    # taken up at the finest level of a deeper pyramid, the references are refined, not
    # rebuilt from two levels up: more of them survive
    import dataclasses

    from barkgen.synth import TBN_CONFIG

    deep = dataclasses.replace(TBN_CONFIG, coarsest_exemplar=8)
    kept_at = {level: np.mean(np.all(texture_by_numbers(
        ex, a, b, init=refs.astype(np.int32), init_level=level, seed=0, config=deep).references == refs,
        axis=-1)) for level in (0, 2)}
    assert kept_at[0] > kept_at[2] + 0.1, kept_at


def test_label_map_of_another_size_is_refused(case):
    ex, a, b = case
    with pytest.raises(InvalidInputError, match="must match"):
        texture_by_numbers(ex, a[:30], b)


# --------------------------------------------------------------------------------------------
# measured quality on a real bark photo (the acceptance set of benchmarks/bench_tbn.py)


@pytest.fixture(scope="module")
def bark_case(texeval):
    from conftest import bark_exemplar
    from barkgen.testing import kmeans_label_map, shuffled_blocks

    ex = bark_exemplar("vertical_fractures_01", 256)
    a = kmeans_label_map(ex, 2)
    b = shuffled_blocks(a, 512, seed=1)
    return ex, a, b, texeval.TexEval(ex, labels_in=a)


def test_label_fidelity_and_sharpness_on_bark(bark_case):
    ex, a, b, ev = bark_case
    smart = ev.evaluate(texture_by_numbers(ex, a, b, seed=0).image, labels_out=b)
    assert smart["label_fidelity_ratio"] >= 0.9
    assert smart["label_fidelity_balanced"] >= 0.85
    # the seams' colour steps blended away cost some sharpness on this label map of small
    # blocks (dense seams): 0.918 -> 0.870, while coherence improves 2.06 -> 1.96
    assert 0.85 <= smart["sharpness_ratio"] <= 1.1
    unguided = ev.evaluate(synthesize(ex, 512, seed=0).image, labels_out=b)
    assert unguided["label_fidelity_ratio"] < smart["label_fidelity_ratio"] - 0.15
    # coherence: the known answer (the exemplar's own blocks, flipped) scores far worse than the
    # unguided synthesis; ours is measured at about 2.7x it on this photo (see the issue note)
    assert smart["coherence"] <= 3.5 * unguided["coherence"]
