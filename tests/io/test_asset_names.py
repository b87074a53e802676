"""The names a material set carries into an artist's library (barkgen.io.asset_names)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from barkgen.io import (
    asset_slug,
    base_name,
    encode_material,
    library_file_name,
    material_set_name,
    material_set_names,
    photo_asset_name,
    set_asset_name,
    size_tag,
    variant_name,
)
from barkgen.material import MaterialSet


@pytest.mark.parametrize(
    ("shape", "tag"),
    [
        ((1024, 1024), "1K"),
        ((512, 1024), "1K"),
        ((2048, 2048), "2K"),
        ((4096, 8192), "8K"),
        ((768, 768), "768x768"),
        ((512, 512), "512x512"),
        ((1536, 3072), "3072x1536"),
        ((1000, 1000), "1000x1000"),
    ],
)
def test_the_size_tag_is_ambientcgs_for_powers_of_two_and_exact_otherwise(shape, tag):
    assert size_tag(shape[1], shape[0]) == tag
    assert material_set_name("oak_seed7", shape) == f"oak_seed7_{tag}"


def test_an_asset_name_is_the_photos_or_the_sets_own_file_safe():
    assert photo_asset_name("/photos/oak_furrowed_moss_01.jpg") == "oak_furrowed_moss_01"
    assert photo_asset_name("Oak bark (moss) #1.png") == "Oak-bark-moss-1"
    assert photo_asset_name("Rock_1K.png") == "Rock"  # its resolution tag is the set's, not the asset's
    assert set_asset_name("Bark001_2K-PNG") == "Bark001"
    assert set_asset_name("bark_willow_02") == "bark_willow_02"
    assert set_asset_name("bark_001") == "bark_001"  # a number is no size tag
    assert asset_slug("…") == "bark" and asset_slug("\x00\n") == "bark"
    assert len(asset_slug("x" * 300)) == 40


def test_variants_of_one_photo_never_share_a_name():
    edits_a = {"version": 1, "edits": [{"x": 1, "y": 2, "delta": 0.5}]}
    edits_b = {"version": 1, "edits": [{"x": 1, "y": 2, "delta": 0.6}]}
    names = {base_name("oak", variant_name(seed, edits)) for seed in (0, 1, 7) for edits in (None, edits_a, edits_b)}
    assert len(names) == 9
    assert variant_name(7) == "seed7" and variant_name(7, edits_a).startswith("seed7-edit")
    assert variant_name(7, edits_a) == variant_name(7, json.loads(json.dumps(edits_a)))  # stable
    assert variant_name() is None and base_name("oak") == "oak"


def test_sizes_of_a_run_are_named_apart():
    assert material_set_names("oak_seed7", (512, 2048), [1024, 2048]) == ["oak_seed7_1K", "oak_seed7_2K"]
    assert material_set_names("oak_seed7", (600, 800)) == ["oak_seed7_800x600"]


def test_a_runs_own_files_carry_the_sets_name_in_a_library():
    assert library_file_name("oak_seed7_1K", "texture.png") == "oak_seed7_1K_texture.png"
    assert library_file_name("oak_seed7_1K", "trunk.glb") == "oak_seed7_1K_trunk.glb"
    assert library_file_name("oak_seed7_1K", "oak_seed7_1K_Color.png") == "oak_seed7_1K_Color.png"
    assert library_file_name("oak_seed7_1K", "oak_seed7_1K.json") == "oak_seed7_1K.json"


def test_the_sets_record_states_its_size_preset_and_licence():
    rng = np.random.default_rng(0)
    height = rng.random((32, 64)).astype(np.float32)
    normals = np.zeros((32, 64, 3), np.float32)
    normals[..., 2] = 1
    material = MaterialSet(
        color=rng.random((32, 64, 3)).astype(np.float32),
        height=height,
        normals=normals,
        ao=np.ones((32, 64), np.float32),
        roughness=np.full((32, 64), 0.7, np.float32),
    )
    material.pixel_size_m = 0.001
    name = material_set_name("oak_seed7", material.shape)
    files = encode_material(material, name, asset="oak", variant="seed7", source_licence="CC0-1.0")
    meta = json.loads(files[f"{name}.json"])
    assert name == "oak_seed7_64x32"
    assert (meta["width_px"], meta["height_px"]) == (64, 32)
    assert meta["width_m"] == pytest.approx(0.064) and meta["height_m"] == pytest.approx(0.032)
    assert meta["preset"] == "ambientcg" and meta["source_licence"] == "CC0-1.0"
    assert (meta["asset"], meta["variant"]) == ("oak", "seed7")
    assert all(f.startswith(f"{name}_") or f.startswith(f"{name}.") for f in files)
