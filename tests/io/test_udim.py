"""UDIM tiles (issue 69): the grid's numbers and layout (1001 at UV 0..1, v up), a set's maps
written once a tile with the set's JSON, MaterialX and Blender set-up reading them as one
image, and ``generate --udim``: tiles that continue into each other, round the torus with
``--tile``, as one canvas does."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import run

from barkgen.errors import InvalidInputError
from barkgen.evaluate import grid_step_ratio
from barkgen.io import decode_image, encode_material, parse_udim, read_image, udim_file_name, udim_grid, write_png
from barkgen.material import MaterialSet


def test_udim_grids_are_parsed_and_bounded():
    assert parse_udim("4x1") == (4, 1) and parse_udim(" 2X3 ") == (2, 3) and parse_udim((10, 99)) == (10, 99)
    assert parse_udim(None) is None
    for bad in ("4", "4x", "x1", "0x1", "11x1", "1x100", "4x1x1", "-1x2", (True, 1), (4.0, 1)):
        with pytest.raises(InvalidInputError, match="^--udim: ") as err:
            parse_udim(bad)
        assert "\n" not in str(err.value)


def test_tiles_are_numbered_as_uv_squares_with_v_up():
    """1001 is the output's bottom-left tile (UV 0..1 x 0..1), 1002 right of it, 1011 above it;
    the tiles laid back in place are the image."""
    image = np.arange(4 * 6).reshape(4, 6)
    grid = udim_grid(image.shape, (3, 2))
    assert grid.tile == (2, 2) and grid.numbers == [1001, 1002, 1003, 1011, 1012, 1013]
    tiles = grid.tiles(image)
    assert (tiles[1001] == image[2:, :2]).all() and (tiles[1013] == image[:2, 4:]).all()
    rows = [np.hstack([tiles[1001 + 10 * r + c] for c in range(3)]) for r in (1, 0)]
    assert (np.vstack(rows) == image).all()
    assert udim_file_name("bark_1K_Color.png", 1012) == "bark_1K_Color.1012.png"
    with pytest.raises(InvalidInputError, match="equal UDIM tiles"):
        udim_grid((4, 6), (4, 1))


def small_set(h: int = 16, w: int = 24) -> MaterialSet:
    rng = np.random.default_rng(1)
    normals = np.zeros((h, w, 3), np.float32)
    normals[..., 2] = 1
    return MaterialSet(
        color=rng.random((h, w, 3), dtype=np.float32),
        height=rng.random((h, w), dtype=np.float32),
        normals=normals,
        ao=np.ones((h, w), np.float32),
        roughness=rng.random((h, w), dtype=np.float32),
    )


@pytest.mark.parametrize("preset", ["ambientcg", "unreal"])
def test_a_sets_maps_are_written_once_a_tile(preset):
    """Each map's tiles hold exactly the pixels of the whole map's file where the grid puts
    them; NAME.json lists the grid and every tile; the Blender set-up reads NAME_X.<UDIM>.png."""
    material = small_set()
    whole = encode_material(material, "bark", preset)
    tiled = encode_material(material, "bark", preset, udim=(3, 2))
    maps = [f for f in whole if f.endswith(".png")]
    assert sorted(tiled) == sorted(
        [udim_file_name(f, n) for f in maps for n in (1001, 1002, 1003, 1011, 1012, 1013)]
        + ["bark.json", "bark_blender.py"]
    )
    for file in maps:
        image = decode_image(whole[file])
        assert (decode_image(tiled[udim_file_name(file, 1011)]) == image[:8, :8]).all()
        assert (decode_image(tiled[udim_file_name(file, 1003)]) == image[8:, 16:]).all()
    meta = json.loads(tiled["bark.json"])
    assert meta["udim"] == {
        "columns": 3,
        "rows": 2,
        "tile_width_px": 8,
        "tile_height_px": 8,
        "tiles": [1001, 1002, 1003, 1011, 1012, 1013],
    }
    assert (meta["width_px"], meta["height_px"]) == (24, 16) and meta["files"] == sorted(set(tiled) - {"bark.json"})
    script = tiled["bark_blender.py"].decode()
    compile(script, "bark_blender.py", "exec")
    assert "UDIM = [3, 2]" in script and ".<UDIM>.png" in script


def test_the_materialx_document_reads_the_tiles_through_the_udim_token():
    pytest.importorskip("MaterialX")
    files = encode_material(small_set(), "bark", "blender", udim=(2, 1))
    mtlx = files["bark.mtlx"].decode()
    assert "bark_Color.&lt;UDIM&gt;.png" in mtlx or "bark_Color.<UDIM>.png" in mtlx
    assert "bark_Color.png" not in mtlx


@pytest.fixture(scope="module")
def udim_runs(tmp_path_factory, synthetic_exemplar) -> tuple[Path, Path]:
    """``--udim 3x1 --size 48x40 --tile``, and the same canvas as one set (``--size 144x40``)."""
    folder = tmp_path_factory.mktemp("udim")
    photo = folder / "photo.png"
    write_png(photo, synthetic_exemplar)
    common = ("generate", str(photo), "--tile", "--k", "2", "-q")
    tiled = run(*common, "-o", str(folder / "tiled"), "--size", "48x40", "--udim", "3x1")
    whole = run(*common, "-o", str(folder / "whole"), "--size", "144x40", "--material")
    assert tiled.returncode == 0 and whole.returncode == 0, tiled.stderr + whole.stderr
    return folder / "tiled", folder / "whole"


def test_generate_writes_a_row_of_tiles_of_one_canvas(udim_runs):
    """``--udim 3x1 --size 48x40``: a 144 x 40 canvas, the set named after a tile's size, each
    map in three tiles that, side by side, are the pixels of the same run written as one set;
    so they continue into each other as one canvas does (round the torus too, ``--tile``), and
    the colour steps across their borders as within them."""
    tiled, whole = udim_runs
    meta = json.loads((tiled / "photo_seed0_48x40.json").read_text())
    assert meta["udim"]["tiles"] == [1001, 1002, 1003] and meta["tileable"] is True
    assert read_image(tiled / "texture.png").shape[:2] == (40, 144)
    for suffix in ("Color", "Displacement", "NormalGL", "Roughness", "AmbientOcclusion"):
        tiles = [read_image(tiled / f"photo_seed0_48x40_{suffix}.{n}.png") for n in (1001, 1002, 1003)]
        assert (np.hstack(tiles) == read_image(whole / f"photo_seed0_144x40_{suffix}.png")).all(), suffix
    color = np.hstack([read_image(tiled / f"photo_seed0_48x40_Color.{n}.png") for n in (1001, 1002, 1003)])
    assert grid_step_ratio(color, 48, tile=True) < 1.25


def test_udim_refuses_sizes_and_grids_that_do_not_fit(tmp_path, synthetic_exemplar):
    photo = tmp_path / "photo.png"
    write_png(photo, synthetic_exemplar)
    for args, message in (
        (["--udim", "2x1", "--sizes", "32,64"], "--udim writes the set at the output's size"),
        (["--udim", "12x1"], "--udim: 12x1 tiles"),
    ):
        r = run("generate", str(photo), "-o", str(tmp_path / "out"), "--size", "32x32", *args, "-q")
        assert r.returncode != 0 and message in r.stderr and "Traceback" not in r.stderr
        assert not (tmp_path / "out").exists()
