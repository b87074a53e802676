"""``generate`` beyond the photo's labels: a crack network grown from the photo's as the output
label map (``structure="cracks"``, sibbing2010) and a bi-layer texture (``model="bilayer"``,
guingo2017), each tileable and with its material set."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import BARK, crack_photo

from barkgen import Canvas
from barkgen.errors import InvalidInputError
from barkgen.io import read_image
from barkgen.pipeline import GenerateOptions, analyze_photo, generate


def wrap_step(image: np.ndarray) -> float:
    """How much more the image steps across its wrap than between neighbours inside (1: as
    much; a seam is far above)."""
    a = image.astype(np.float64).reshape(image.shape[0], image.shape[1], -1)
    inside = np.abs(np.diff(a, axis=0)).mean() + np.abs(np.diff(a, axis=1)).mean()
    across = np.abs(a[0] - a[-1]).mean() + np.abs(a[:, 0] - a[:, -1]).mean()
    return float(across / inside)


@pytest.fixture(scope="module")
def mud() -> np.ndarray:
    return crack_photo(256, 0)  # a drawn crack network (the team's dried mud photo is copyleft)


@pytest.fixture(scope="module")
def cracked(mud):
    return generate(mud, GenerateOptions(size=(160, 192), structure="cracks", tile=True, seed=4, material=True))


def test_cracks_grow_a_new_network_that_tiles_and_is_low(mud, cracked):
    """The output label map is the grown network's raster (cracks the darkest label), on the
    torus; texture-by-numbers fills it with the photo's cracks and bark, and the material's
    height is low in the cracks."""
    assert cracked.cracks is not None and cracked.cracks.periodic
    assert set(np.unique(cracked.labels_out)) == {0, 255} and set(np.unique(cracked.labels_in)) == {0, 255}
    crack = cracked.labels_out == 0
    assert 0.03 < crack.mean() < 0.5
    ry, rx = cracked.references[..., 0], cracked.references[..., 1]
    assert np.mean(cracked.labels_in[ry, rx] == cracked.labels_out) > 0.9  # filled by label
    lum = cracked.texture.mean(axis=2)
    assert lum[crack].mean() < lum[~crack].mean() - 10  # the photo's cracks are dark
    height = cracked.material.height
    assert height[crack].mean() < height[~crack].mean()
    assert wrap_step(cracked.texture) < 1.3 and wrap_step(height) < 1.3
    assert cracked.report["structure"] == "cracks" and cracked.report["model"] == "patches"


def test_cracks_are_reproducible_and_share_the_analysis(mud, cracked):
    options = GenerateOptions(size=(160, 192), structure="cracks", tile=True, seed=4, material=True)
    analysis = analyze_photo(mud, options)
    again = generate(mud, options, analysis=analysis)
    assert np.array_equal(again.texture, cracked.texture)
    other = generate(
        mud, GenerateOptions(size=(160, 192), structure="cracks", tile=True, seed=5, material=True), analysis=analysis
    )
    assert not np.array_equal(other.labels_out, cracked.labels_out)


def test_the_cracks_proximity_and_direction_steer_every_level(mud, cracked):
    """The crack label as a thin label (its proximity and direction matched at every pyramid
    level) fills the new network with cracks that run its way: the direction agreement rises
    (0.79-0.83 -> 0.85-0.87 on the drawn photo, seeds 0-3) and the crack share stays."""
    from barkgen import Budget
    from barkgen.evaluate import direction_agreement, label_share
    from barkgen.synth import texture_by_numbers

    labels = (cracked.labels_in, cracked.labels_out)
    gains = []
    for seed in (0, 1):
        agreement, share = [], []
        for thin in ((), (0,)):
            out = texture_by_numbers(
                mud, *labels, thin_labels=thin, canvas=Canvas((160, 192), tile=True), budget=Budget(seed=seed)
            )
            agreement.append(direction_agreement(*labels, out.references, 0, tile=True))
            share.append(label_share(*labels, out.references, 0))
        assert share[1] > share[0] - 0.01
        gains.append(agreement[1] - agreement[0])
    assert np.mean(gains) > 0.02 and min(gains) > 0
    with pytest.raises(InvalidInputError, match="thin label 9 is not a label"):
        texture_by_numbers(mud, *labels, thin_labels=(9,))
    along = Canvas((160, 192), flow=np.zeros((160, 192), np.float32))
    with pytest.raises(InvalidInputError, match="not matched along a flow field"):
        texture_by_numbers(mud, *labels, thin_labels=(0,), canvas=along)


@pytest.fixture(scope="module")
def lichen() -> np.ndarray:
    return read_image(BARK / "lichen_covered_01.jpg")[:160, :160]


def test_bilayer_is_structure_plus_noise_tiled_with_its_material(lichen):
    """guingo2017 eq. 6: the output is the synthesized structure layer plus new noise under the
    masks carried through the same reference map; both tile, and the material set is the
    structure layer's with the noise in its colour."""
    options = GenerateOptions(size=(128, 144), model="bilayer", k=2, tile=True, seed=3, material=True)
    analysis = analyze_photo(lichen, options)
    model = analysis.exemplar.bilayer
    result = generate(lichen, options, analysis=analysis)
    layers = result.layers
    ry, rx = result.references[..., 0], result.references[..., 1]
    assert np.array_equal(layers["masks"], model.masks[ry, rx])
    noise = layers["noise"]
    assert noise.shape == (128, 144, 3)
    assert 0.5 < float(noise.std()) / float(model.noise_layer.std()) < 2  # the photo's noise's strength
    total = layers["structure"].astype(np.float64) / 255 + noise
    assert np.abs(np.clip(total, 0, 1) * 255 - result.texture).max() <= 1
    assert wrap_step(result.texture) < 1.3 and wrap_step(noise) < 1.3
    assert wrap_step(result.material.height) < 1.3
    assert result.report["model"] == "bilayer"
    # the seed makes the noise: same bytes again, new noise for a new seed
    assert np.array_equal(generate(lichen, options, analysis=analysis).texture, result.texture)
    # the analysis streams the unbounded texture
    assert model.window(0, 0, 64, 32, seed=3).shape == (32, 64, 3)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"structure": "cracks", "model": "bilayer"}, "use one of cracks and bilayer"),
        ({"model": "bilayer", "k": 9}, "1 to 8 noises"),
        ({"structure": "veins"}, "structure must be one of labels, cracks"),
        ({"model": "wang"}, "model must be one of patches, bilayer"),
    ],
)
def test_variant_options_are_checked_in_one_line(kwargs, message):
    with pytest.raises(InvalidInputError, match=message):
        GenerateOptions(**kwargs)


def test_cracks_refuse_a_flow_field_and_a_photo_without_cracks(mud):
    options = GenerateOptions(size=(64, 64), structure="cracks")
    with pytest.raises(InvalidInputError, match="flow field"):
        generate(mud, options, canvas=Canvas((64, 64), flow=np.zeros((64, 64), np.float32)))
    flat = np.full((64, 64, 3), 128, np.uint8)
    with pytest.raises(InvalidInputError, match="no cracks"):
        generate(flat, options)
