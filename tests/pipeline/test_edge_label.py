"""The edge label (laitoch2018 §3.5.5): added to the photo's and the new bark's label maps once
both are made, sharing their grey values, across the edges of maps that wrap; in ``generate``,
``barkgen generate --edges`` and ``barkgen tbn --edges``."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run

from barkgen import Canvas
from barkgen.errors import InvalidInputError
from barkgen.io import read_image, write_png
from barkgen.labels import add_edge_label
from barkgen.pipeline import GenerateOptions, generate


def test_the_band_runs_across_the_border_of_a_map_that_wraps():
    stripes = np.zeros((16, 16), np.uint8)
    stripes[:, 8:] = 255  # edges at x = 8 and, across the border, at x = 0 / 15
    flat = add_edge_label(stripes, 2)
    torus = add_edge_label(stripes, 2, wrap=True)
    assert (flat[:, [7, 8]] == 255).all() and (torus[:, [7, 8]] == 255).all()
    assert (flat[:, [0, 15]] != 255).all() and (torus[:, [0, 15]] == 255).all()
    # along the rows only: the columns' border is not an edge
    assert (add_edge_label(stripes, 2, wrap=(True, False))[:, [0, 15]] != 255).all()


def test_an_output_map_shares_the_photos_grey_values():
    photo_map = np.repeat(np.array([0, 128, 255], np.uint8), 8)[None, :].repeat(8, axis=0)
    output = np.full((8, 8), 255, np.uint8)
    output[:, :4] = 0  # label 128 is missing from the output
    alone = add_edge_label(output)  # numbered against its own two labels: 0, 128, 255
    shared = add_edge_label(output, values=np.unique(photo_map))
    assert sorted(np.unique(alone).tolist()) == [0, 128, 255]
    edged_photo = add_edge_label(photo_map)
    assert set(np.unique(shared)) <= set(np.unique(edged_photo))
    assert shared[0, 7] == edged_photo[0, 23] and shared[0, 0] == edged_photo[0, 0]  # the same labels
    assert shared[0, 3] == np.max(edged_photo)  # the edge label is the photo's edge label
    with pytest.raises(InvalidInputError, match="not the photo's"):
        add_edge_label(np.full((4, 4), 7, np.uint8), values=np.unique(photo_map))


def test_generate_matches_both_maps_with_their_edge_label(sample256):
    photo = sample256[:128, :128]
    options = GenerateOptions(size=(128, 128), k=3, seed=1, tile=True, edges=3)
    result = generate(photo, options)
    plain = generate(photo, GenerateOptions(size=(128, 128), k=3, seed=1, tile=True))
    values_in, values_out = np.unique(result.labels_in), np.unique(result.labels_out)
    assert len(values_in) == 4 and set(values_out) <= set(values_in)  # k labels and the edge's
    edge = values_in.max()
    band_out = result.labels_out == edge
    assert 0.05 < band_out.mean() < 0.6
    # the output's band runs along its region edges (of its label map's finest level), across
    # its tiling border too, numbered against the photo's labels
    unedged = result.label_levels[0]
    assert np.array_equal(band_out, add_edge_label(unedged, 3, wrap=True, values=np.unique(plain.labels_in)) == edge)
    # texture-by-numbers follows it: the edge band is filled from the photo's edge band
    refs = result.references
    copied = result.labels_in[refs[..., 0], refs[..., 1]]
    assert (copied[band_out] == edge).mean() > 0.6
    # and the option is the analysis': a run without edges does not share it
    with pytest.raises(InvalidInputError, match="edges must be"):
        GenerateOptions(edges=-1)


def test_edges_and_a_flow_field_are_refused_in_one_line(sample256):
    field = np.zeros((64, 64), np.float32)
    with pytest.raises(InvalidInputError, match="edge label does not follow a flow field"):
        generate(sample256[:96, :96], GenerateOptions(size=(64, 64), edges=3), canvas=Canvas((64, 64), flow=field))


def test_the_commands_take_edges(tmp_path, sample256):
    photo = tmp_path / "photo.png"
    write_png(photo, sample256[:96, :96])
    out = tmp_path / "out"
    done = run("generate", str(photo), "-o", str(out), "--size", "64x64", "--k", "2", "--edges", "2", "-q")
    assert done.returncode == 0, done.stderr
    assert len(np.unique(read_image(out / "labels_in.png"))) == 3
    # tbn: the exemplar's labels and a target with one of them, both edged alike
    labels = np.zeros((96, 96), np.uint8)
    labels[:, 48:] = 255
    target = np.zeros((64, 64), np.uint8)
    target[16:48, 16:48] = 255
    write_png(tmp_path / "labels.png", labels)
    write_png(tmp_path / "target.png", target)
    args = ["tbn", str(photo), "--labels", str(tmp_path / "labels.png"), "--target", str(tmp_path / "target.png")]
    done = run(*args, "-o", str(tmp_path / "tbn.png"), "--edges", "4", "-q")
    assert done.returncode == 0, done.stderr
    assert read_image(tmp_path / "tbn.png").shape[:2] == (64, 64)
    bad = run(*args, "-o", str(tmp_path / "tbn2.png"), "--edges", "-1", "-q")
    assert bad.returncode != 0 and "Traceback" not in bad.stderr
