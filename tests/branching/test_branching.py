"""Branching structures (sibbing2010 §4): structure files, the statistical model, growth with
merges, guidance, and the `barkgen branches` commands' bad-input handling."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import BARK, crack_photo, crack_photo_file

from barkgen.branching import Branch, GrowOptions, Structure, grow_structure
from barkgen.branching.extract import extract_structure
from barkgen.branching.model import fit_model
from barkgen.branching.stats import compare_structures, comparison_plot, self_intersections
from barkgen.errors import InvalidInputError
from barkgen.io import read_image, write_png
from barkgen.io.branches import encode_structure, read_structure


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "barkgen", *args], capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def mud_source() -> Structure:
    # a drawn crack network of 512 px (the team's dried mud photo is copyleft)
    return extract_structure(crack_photo(512, 1, cell=32))


@pytest.fixture(scope="module")
def mud_grown(mud_source) -> Structure:
    return grow_structure(fit_model(mud_source), (512, 512), seed=3)


def test_structure_file_round_trip(tmp_path, mud_source):
    path = tmp_path / "src.json"
    path.write_bytes(encode_structure(mud_source))
    back = read_structure(path)
    assert back.size == mud_source.size and back.step == mud_source.step
    assert len(back.branches) == len(mud_source.branches)
    for a, b in zip(back.branches, mud_source.branches):
        assert (a.parent, a.parent_vertex, a.joins, a.join_vertex) == (
            b.parent,
            b.parent_vertex,
            b.joins,
            b.join_vertex,
        )
        np.testing.assert_allclose(a.points, b.points, atol=1e-3)
    data = json.loads(path.read_text())
    assert data["version"] == 1 and data["size"] == [512, 512]


@pytest.mark.parametrize(
    "text, message",
    [
        ("{", "malformed JSON"),
        ("", "empty"),
        ('{"version": 1, "step": 2, "size": [64, 64], "branches": []}', "empty (no branches)"),
        ('{"version": 2, "step": 2, "size": [64, 64], "branches": []}', "version must be 1"),
        (
            '{"version": 1, "step": 2, "size": [64, 64], "branches": [{"parent": 3, "parent_vertex": 0, '
            '"points": [[1, 1, 1], [5, 5, 1]]}]}',
            "parent 3 is not another branch",
        ),
        (
            '{"version": 1, "step": 2, "size": [64, 64], "branches": [{"parent": null, "parent_vertex": null, '
            '"points": [[1, 1, 1]]}]}',
            "at least two",
        ),
    ],
)
def test_bad_structure_files_are_one_clear_line(tmp_path, text, message):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(InvalidInputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        read_structure(path)


def test_grown_structure_matches_the_source_statistics(mud_source, mud_grown):
    """sibbing2010 Fig. 7 as numbers: angle and thickness histograms (B = 16) within L1 0.3, no
    crossings except recorded merges, junctions per area within 30 % for this merging network,
    and about the source's skeleton length per pixel."""
    mud_grown.validate()
    cmp = compare_structures(mud_source, mud_grown)
    assert cmp.angle_l1 <= 0.3 and cmp.thickness_l1 <= 0.3, cmp.as_dict()
    assert self_intersections(mud_grown) == 0
    assert (
        sum(b.joins is not None for b in mud_grown.branches)
        > 0.2 * sum(b.joins is not None for b in mud_source.branches) * 1.0
    )  # 512² output, same area as source
    ratio = cmp.target_junction_density / cmp.source_junction_density
    assert 0.7 <= ratio <= 1.3, cmp.as_dict()
    assert cmp.target_length_density == pytest.approx(cmp.source_length_density, rel=0.15)
    plot = comparison_plot(cmp)
    assert plot.shape == (360, 960, 3) and plot.std() > 10


@pytest.mark.parametrize("photo, seed", [("pine_plated_01.jpg", 5), ("oak_furrowed_moss_01.jpg", 1)])
def test_thick_fissures_do_not_cross_other_branches(photo, seed):
    """Seeds that grew a crossing while the growing branch's own fresh vertices were in the
    contact map: a thick fissure's body (half-width ~6 px) hid the thin branch it crossed, a
    child ran back along its parent past the junction."""
    source = extract_structure(read_image(BARK / photo))
    grown = grow_structure(fit_model(source), (1024, 1024), seed=seed)
    assert self_intersections(grown) == 0


def test_the_model_beats_a_random_walk(mud_source, mud_grown):
    """A walk with Gaussian turns of the source's spread and a constant thickness: the Markov
    model with histogram matching must be closer to the source's histograms."""
    rng = np.random.default_rng(0)
    from barkgen.branching.stats import structure_values

    angles, thickness = structure_values(mud_source)
    branches = []
    for _ in range(200):
        th = rng.uniform(-np.pi, np.pi)
        xy = [rng.uniform(0, 511, 2)]
        for _ in range(20):
            th += rng.normal(0, angles.std())
            xy.append(xy[-1] + mud_source.step * np.array([np.cos(th), np.sin(th)]))
        pts = np.column_stack([np.asarray(xy), np.full(len(xy), thickness.mean())])
        branches.append(Branch(pts))
    walk = Structure(mud_source.step, (512, 512), branches)
    cmp_model = compare_structures(mud_source, mud_grown)
    cmp_walk = compare_structures(mud_source, walk)
    assert cmp_model.angle_l1 < cmp_walk.angle_l1
    assert cmp_model.thickness_l1 < cmp_walk.thickness_l1


def test_growth_scores_furcations_with_the_fitted_classifier(mud_source):
    """The growth kernels' furcation margins, with chosen furcations, equal the classifier's
    margin on the features it was trained on (§4.3), and the greedy choice blocks neighbours."""
    from barkgen.branching import _grow_kernels as K
    from barkgen.branching.model import _vertex_features, vertex_angles

    model = fit_model(mud_source)
    k = model.options.k
    branch = max(mud_source.branches, key=lambda b: len(b.points))
    p = np.ascontiguousarray(branch.points)
    n = len(p)
    allowed = np.ones(n, bool)
    base, expected = K.furcation_margins(
        p, k, model.feat_mean, model.feat_scale, model.svm_w, model.svm_b, *model.platt, allowed
    )
    a, c = model.platt

    def margin(marks):
        feats = _vertex_features(vertex_angles(p), p[:, 2], k, marks)
        return ((feats - model.feat_mean) / model.feat_scale) @ model.svm_w + model.svm_b

    no_marks = margin(np.zeros(n, bool))
    np.testing.assert_allclose(expected, (1 / (1 + np.exp(-(a * no_marks + c)))).sum(), rtol=1e-9)
    chosen = K.pick_furcations(
        base, allowed.copy(), 3, 4, model.feat_mean[-2:], model.feat_scale[-2:], model.svm_w[-2:]
    )
    assert len(chosen) == 3 and np.all(np.diff(np.sort(chosen)) > 4)
    # each choice is the vertex of highest margin given the earlier ones (the n-/n+ terms
    # count from them), away from their blocked neighbourhoods
    for i in range(3):
        blocked = np.zeros(n, bool)
        for v in chosen[:i]:
            blocked[max(v - 4, 0) : v + 5] = True
        scores = margin(np.isin(np.arange(n), chosen[:i]))
        assert chosen[i] == int(np.argmax(np.where(blocked, -np.inf, scores)))


def test_growth_is_reproducible_from_the_seed(mud_source):
    model = fit_model(mud_source)
    a = encode_structure(grow_structure(model, (256, 192), seed=5))
    b = encode_structure(grow_structure(model, (256, 192), seed=5))
    c = encode_structure(grow_structure(model, (256, 192), seed=6))
    assert a == b and a != c
    assert json.loads(a)["size"] == [256, 192]


def test_a_guide_map_draws_the_branches_into_its_valley(mud_source):
    """sibbing2010 §4.5: G = 1 except a smooth dark valley; the branches follow it."""
    w, h = 384, 256
    x = np.arange(w)[None, :].repeat(h, 0)
    guide = 1.0 - np.exp(-((x - w / 2) ** 2) / (2 * 24.0**2))
    valley = np.abs(x - w / 2) < 48
    model = fit_model(mud_source)
    grown = grow_structure(
        model,
        (w, h),
        seed=1,
        guide=guide.astype(np.float32),
        options=GrowOptions(total_length=model.length_density * w * h * 0.3),
    )
    pts = np.concatenate([b.xy for b in grown.branches])
    inside = valley[np.clip(pts[:, 1].round().astype(int), 0, h - 1), np.clip(pts[:, 0].round().astype(int), 0, w - 1)]
    assert inside.mean() > 2 * valley.mean(), inside.mean()
    with pytest.raises(InvalidInputError, match="same size"):
        grow_structure(model, (w, h), guide=guide[:, :-1])


def test_growth_estimates_its_memory_before_any_work(mud_source):
    from barkgen.branching import estimate_grow_memory
    from barkgen.errors import MemoryBudgetError

    with pytest.raises(MemoryBudgetError, match="2048x2048"):
        grow_structure(fit_model(mud_source), (2048, 2048), options=GrowOptions(max_memory=50 * 2**20))
    assert estimate_grow_memory((2048, 2048), guide=True) > estimate_grow_memory((2048, 2048))
    assert estimate_grow_memory((16384, 16384)) / 2**30 > 5  # measured 5.3 GiB peak


def test_growth_stops_at_the_requested_length(mud_source):
    grown = grow_structure(fit_model(mud_source), (512, 512), seed=0, options=GrowOptions(total_length=800))
    assert 800 <= grown.total_length() < 800 + 400


def test_branches_cli_bad_input_is_one_line_and_writes_nothing(tmp_path, mud_source):
    src = tmp_path / "src.json"
    src.write_bytes(encode_structure(mud_source))
    bad = tmp_path / "bad.json"
    bad.write_text('{"version": 1, "step": 2, "size": [64, 64], "branches": [')
    empty = tmp_path / "empty.json"
    empty.write_text('{"version": 1, "step": 2, "size": [64, 64], "branches": []}')
    flat = tmp_path / "flat.png"
    write_png(flat, np.full((128, 128, 3), 128, np.uint8))
    small_guide = tmp_path / "guide.png"
    write_png(small_guide, np.zeros((64, 64), np.uint8))
    out = tmp_path / "out.json"
    cases = [
        (("branches", "grow", str(bad), "-o", str(out), "--quiet"), "malformed JSON"),
        (("branches", "grow", str(empty), "-o", str(out), "--quiet"), "empty"),
        (
            ("branches", "grow", str(src), "-o", str(out), "--size", "128x128", "--guide", str(small_guide), "--quiet"),
            "same size",
        ),
        (("branches", "grow", str(src), "-o", str(out), "--size", "0x128"), "positive"),
        (("branches", "extract", str(flat), "-o", str(out), "--quiet"), "no cracks"),
        (("branches", "stats", str(src), str(bad)), "malformed JSON"),
        (("branches", "grow", str(tmp_path / "missing.json"), "-o", str(out)), "no such file"),
        # growth's maps are 20 bytes a pixel: 16384^2 is 5.2 GiB, refused before any work (with
        # the output bound raised past its default of 8192^2, which refuses it first)
        (
            (
                "--max-pixels",
                "300000000",
                "branches",
                "grow",
                str(src),
                "-o",
                str(out),
                "--size",
                "16384x16384",
                "--max-memory",
                "2G",
            ),
            "5.2 GiB",
        ),
        (("branches", "grow", str(src), "-o", str(out), "--size", "16384x16384"), "--max-pixels"),
    ]
    for args, message in cases:
        r = run(*args)
        assert r.returncode == 2, (args, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and message in lines[0], (args, r.stderr)
        assert "Traceback" not in r.stderr
        assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["src.json", "bad.json", "empty.json", "flat.png", "guide.png"]
    )


def test_branches_cli_extract_grow_stats(tmp_path):
    image = crack_photo_file(512, 2, grey=True)  # a grey crack network (as mud_crackle was)
    src, dst, preview = tmp_path / "src.json", tmp_path / "dst.json", tmp_path / "preview.png"
    fissures = tmp_path / "fissures.png"
    r = run(
        "branches",
        "extract",
        str(image),
        "-o",
        str(src),
        "--preview",
        str(preview),
        "--labels-out",
        str(fissures),
        "--quiet",
    )
    assert r.returncode == 0, r.stderr
    assert read_image(preview).shape == (512, 512, 3)
    labels = read_image(fissures)
    assert labels.shape[:2] == (512, 512) and set(np.unique(labels)) == {0, 255}
    assert 0.02 < (labels > 0).mean() < 0.3
    r = run("branches", "grow", str(src), "-o", str(dst), "--size", "320x256", "--seed", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    assert read_structure(dst).size == (320, 256)
    r = run("branches", "stats", str(src), str(dst))
    assert r.returncode == 0, r.stderr
    assert "L1 angle" in r.stdout and "thickness" in r.stdout
    assert read_image(tmp_path / "dst_stats.png").shape == (360, 960, 3)


def test_growth_on_the_torus_tiles_and_keeps_the_statistics(mud_source):
    """``tile``: branches run on across the edges and meet branches on the other side. The
    raster of the periodic structure steps across its wrap no more than inside, the statistics
    hold as in the plane, no branch crosses another on the torus, and the JSON keeps it."""
    from barkgen.branching import rasterize

    grown = grow_structure(fit_model(mud_source), (384, 256), seed=2, tile=True)
    assert grown.periodic
    xy = np.concatenate([b.xy for b in grown.branches])
    assert (xy < 0).any() or (xy[:, 0] >= 384).any() or (xy[:, 1] >= 256).any()  # some run across
    mask = rasterize(grown).astype(np.int8)
    inside_x = np.abs(np.diff(mask, axis=1)).mean()
    inside_y = np.abs(np.diff(mask, axis=0)).mean()
    assert np.abs(mask[:, 0] - mask[:, -1]).mean() <= 1.5 * inside_x
    assert np.abs(mask[0] - mask[-1]).mean() <= 1.5 * inside_y
    cmp = compare_structures(mud_source, grown)
    assert cmp.angle_l1 <= 0.3 and cmp.thickness_l1 <= 0.3, cmp.as_dict()
    assert self_intersections(grown) == 0
    assert read_back(grown).periodic


def read_back(structure: Structure) -> Structure:
    return Structure.from_dict(json.loads(encode_structure(structure)))


def test_a_crossing_across_the_torus_edge_is_counted():
    """Two branches that cross only where one runs on across the right edge."""
    across = Branch(np.array([[90.0, 50.0, 1.0], [110.0, 50.0, 1.0]]))  # x 90..110 on a 100-px torus
    upright = Branch(np.array([[5.0, 40.0, 1.0], [5.0, 60.0, 1.0]]))
    assert self_intersections(Structure(2.0, (100, 100), [across, upright], periodic=True)) == 1
    assert self_intersections(Structure(2.0, (100, 100), [across, upright])) == 0
