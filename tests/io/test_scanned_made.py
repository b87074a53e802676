"""Scanned sets of every naming style in, a tileable set out (issue 66): the team's scans of
tests/data renamed as each library names them (:mod:`test_scanned_names`), maps of three
sizes, a specular map, a gloss map, a DirectX normal map told from the height, and a height
that does not tile beside a colour that does. Each set is made through the pipeline at the
colour's size; no output map has a straight line across the whole tile (the issue's 440 px line
of a height that does not wrap, carried into the AO), measured by the project's own
:func:`barkgen.evaluate.longest_line`."""

from __future__ import annotations

import numpy as np
import pytest
from test_scanned_names import STYLES, dx, source_maps, style_set, write_set

from barkgen.evaluate import longest_line
from barkgen.io import read_scanned_set
from barkgen.material import scanned_material
from barkgen.pipeline import GenerateOptions, generate

MAPS = ("height", "normals", "ao", "roughness")


def case_set(folder, case: str):
    """The folder of one case: a naming style (:data:`STYLES`) or one of the cases below."""
    if case in STYLES:
        return style_set(folder, case, 128)
    m = source_maps(128)
    if case == "three sizes":  # colour 256, normal and roughness 1/4, height and AO 1/8
        big, quarter, eighth = source_maps(256), source_maps(64), source_maps(32)
        files = {
            "o_Color.png": big["color"],
            "o_NormalGL.png": quarter["normal"],
            "o_Roughness.png": quarter["roughness"],
            "o_Height.png": eighth["height"],
            "o_AO.png": eighth["ao"],
        }
    elif case == "specular":
        files = {"o_Color.png": m["color"], "o_NormalGL.png": m["normal"], "o_Specular.png": m["specular"]}
    elif case == "gloss":
        files = {"o_Color.png": m["color"], "o_NormalGL.png": m["normal"], "o_Gloss.png": m["gloss"]}
    elif case == "dx normal":  # named only Normal; its green told DirectX by the height
        files = {"o_Color.png": m["color"], "o_Normal.png": dx(m["normal"]), "o_Height.png": m["height"]}
    else:  # "height not tiling": the colour tiles, the height climbs 40 % down the rows (a cliff last row -> first)
        ramp = m["height"] / 65535 * 0.6 + 0.4 * np.linspace(0, 1, 128)[:, None, None]
        files = {
            "o_Color.png": m["color"],
            "o_NormalGL.png": m["normal"],
            "o_Height.png": np.round(ramp * 65535).astype(np.uint16),
        }
    return write_set(folder, files)


CASES = sorted(STYLES) + ["three sizes", "specular", "gloss", "dx normal", "height not tiling"]


@pytest.mark.parametrize("case", CASES)
def test_each_scanned_set_makes_a_set_with_no_line_across_the_tile(tmp_path, case):
    scan = read_scanned_set(case_set(tmp_path / "set", case))
    result = generate(scan.color, GenerateOptions(size=scan.shape, tile=True, material=True, seed=0), scan=scan)
    material = result.material
    assert result.report["exemplar_wrap"] == [True, True]  # the scans' colours tile
    assert "normals" in material.scanned
    if case == "dx normal":
        assert material.scan_info["normal_convention"] == "dx"
    if case in ("specular", "gloss"):
        assert material.scan_info["roughness_from"] == case
    size = min(material.shape)
    for kind in MAPS:
        out = longest_line(getattr(material, kind), tile=True)
        assert out < size, (kind, out)


def test_a_height_that_does_not_tile_carries_no_line_into_the_height_or_ao(tmp_path):
    """The issue's defect: the colour tiles, the height does not. Judged per map, the height
    is carried with its last step where a piece runs on across the colour's edge; judged from
    the colour (as before) its cliff from last row to first runs through the output."""
    import dataclasses

    from barkgen import Canvas
    from barkgen.material import transfer_material

    scan = read_scanned_set(case_set(tmp_path / "set", "height not tiling"))
    assert scan.wraps["height"] == (False, True)
    found = {}
    for seed in (0, 1):
        result = generate(scan.color, GenerateOptions(size=scan.shape, tile=True, material=True, seed=seed), scan=scan)
        canvas = Canvas(scan.shape, tile=True, exemplar_wrap=(True, True))
        source = scanned_material(scan, wrap=(True, True))
        assert source.map_wraps["height"] == (False, True) and source.scan_info["not_wrapped"]["height"] == "y"
        as_colour = transfer_material(dataclasses.replace(source, map_wraps={}), result.references, canvas)
        for kind in ("height", "ao"):
            found.setdefault(kind, []).append(
                (
                    longest_line(getattr(result.material, kind), tile=True),
                    longest_line(getattr(as_colour, kind), tile=True),
                )
            )
    own = longest_line(source.height)  # the height's own lines, its edge not counted
    for kind, runs in found.items():
        assert max(per_map for per_map, _ in runs) < 1.5 * own < max(colour for _, colour in runs), (kind, runs, own)
