"""The one-click pipeline (``barkgen.pipeline.generate``, ``barkgen generate``, ``barkgen shapes``):
files, report, determinism, quality against plain synthesis, editing levels, bad input."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from conftest import run

from barkgen.errors import InvalidInputError
from barkgen.io import read_image, write_png
from barkgen.pipeline import GenerateOptions, generate, preview_sheet

OUTPUTS = {"texture.png", "labels_in.png", "labels_out.png", "reference.png", "report.json", "preview.png"}


@pytest.fixture(scope="module")
def fir128():
    from conftest import bark_exemplar

    return bark_exemplar("fir_scaly_01", 128)


@pytest.fixture(scope="module")
def fir_png(tmp_path_factory, fir128) -> Path:
    p = tmp_path_factory.mktemp("photo") / "fir.png"
    write_png(p, fir128)
    return p


def test_generate_api_outputs_and_report(fir128):
    height = (fir128.astype(np.uint16).sum(axis=2) * 80).astype(np.uint16)  # the photo's shapes
    result = generate(fir128, GenerateOptions(size=(96, 160), k=3, seed=2), extra={"height": height})
    assert result.texture.shape == (96, 160, 3) and result.texture.dtype == np.uint8
    assert result.labels_in.shape == (128, 128) and result.labels_out.shape == (96, 160)
    assert set(np.unique(result.labels_out)) <= set(np.unique(result.labels_in))
    assert result.extras["height"].shape == (96, 160, 1)
    # the texture is the photo's pixels at the references, its seams blended (a few px either
    # side of the borders between pieces); the height map goes through them in the gradient
    # domain
    from conftest import assert_continuous_copy

    from barkgen.evaluate import border_distance

    ry, rx = result.references[..., 0], result.references[..., 1]
    far = border_distance(result.references) >= 8
    diff = np.abs(result.texture.astype(int) - fir128[ry, rx].astype(int)).max(axis=-1)
    assert far.any() and np.mean(diff[far] <= 1) > 0.9 and result.report["blend"] == "gradient"
    assert_continuous_copy(result.extras["height"][..., 0], height, result.references, tolerance=0.35)
    # ... whose labels are the output label map's, nearly everywhere
    assert np.mean(result.labels_in[ry, rx] == result.labels_out) > 0.95
    report = result.report
    assert report["size"] == [160, 96] and report["seed"] == 2 and report["k"] == 3
    assert report["strategy"] == "joint" and report["extras"] == ["height"]
    # the stages, and the analysis' own steps (the light out and the label map, the two solvers')
    assert set(report["timings_s"]) == {
        "analysis",
        "analysis_labels",
        "analysis_label_map",
        "analysis_texture",
        "labels_out",
        "texture",
        "total",
    }
    fin, fout = report["label_fractions_in"], report["label_fractions_out"]
    assert set(fin) == set(fout) and abs(sum(fout.values()) - 1) < 1e-3
    sheet = preview_sheet(fir128, result)
    assert sheet.ndim == 3 and sheet.shape[1] > 4 * 300
    # a large output's tiles are made from a pixel in ``step`` (issue 69: never coloured whole),
    # a sheet of the same size whose output tiles are the small one's
    large = dataclasses.replace(
        result,
        labels_out=np.repeat(np.repeat(result.labels_out, 40, axis=0), 40, axis=1),
        texture=np.repeat(np.repeat(result.texture, 40, axis=0), 40, axis=1),
    )
    assert large.texture.shape[0] >= 4 * 320 * 2
    big_sheet = preview_sheet(fir128, large)
    assert big_sheet.shape == sheet.shape
    assert np.abs(big_sheet.astype(int) - sheet.astype(int)).mean() < 8


def test_generate_is_deterministic(fir128):
    a = generate(fir128, GenerateOptions(size=(80, 80), seed=5))
    b = generate(fir128, GenerateOptions(size=(80, 80), seed=5))
    c = generate(fir128, GenerateOptions(size=(80, 80), seed=6))
    assert np.array_equal(a.texture, b.texture) and np.array_equal(a.labels_out, b.labels_out)
    assert not np.array_equal(a.texture, c.texture)


def test_shared_photo_analysis_gives_the_same_bytes_and_skips_the_analysis(fir128, monkeypatch):
    import barkgen.synth._analysis as synth_analysis
    from barkgen.pipeline import analyze_photo

    options = GenerateOptions(size=(96, 80), k=3, tile=True, material=True)
    analysis = analyze_photo(fir128, options)
    assert len(analysis.cache) == 2  # the label-map engine's and texture-by-numbers' analyses
    assert analysis.material is not None and analysis.seconds > 0
    fresh = [generate(fir128, GenerateOptions(size=(96, 80), k=3, tile=True, material=True, seed=s)) for s in (1, 2)]
    calls = []
    monkeypatch.setattr(
        synth_analysis, "analyse_exemplar", lambda *a, **k: calls.append(1) or pytest.fail("analysed again")
    )
    for seed, ref in zip((1, 2), fresh):
        shared = generate(
            fir128, GenerateOptions(size=(96, 80), k=3, tile=True, material=True, seed=seed), analysis=analysis
        )
        assert np.array_equal(shared.texture, ref.texture)
        assert np.array_equal(shared.labels_out, ref.labels_out)
        assert np.array_equal(shared.material.height, ref.material.height)
        assert shared.report["timings_s"]["analysis"] == round(analysis.seconds, 3)
    assert not calls
    assert not np.array_equal(fresh[0].texture, fresh[1].texture)
    with pytest.raises(InvalidInputError, match="other options"):
        generate(fir128, GenerateOptions(size=(96, 80), k=4, tile=True, material=True), analysis=analysis)
    with pytest.raises(InvalidInputError, match="not with an analysis"):
        generate(fir128, options, analysis=analysis, labels_in=analysis.labels_in)


@pytest.mark.parametrize("material", [False, True])
def test_progress_moves_forward_by_stage_shares_to_the_end(fir128, material):
    """Progress is in 1000ths of the whole run, never goes back, ends the analysis at its share
    of the run's time (two thirds on the quickstart, not the half it was given) and the run at
    1000; the shares of the stages tile 0..1, and each fraction names the stage then running."""
    from barkgen.pipeline import analyze_photo, stage_span

    stages = ["analysis", "label_map", "texture"] + (["material"] if material else [])
    spans = [stage_span(name, material) for name in stages]
    assert spans[0][0] == 0.0 and spans[-1][1] == pytest.approx(1.0)
    assert all(a[1] == pytest.approx(b[0]) for a, b in zip(spans, spans[1:]))
    assert spans[0][1] > 0.6
    seen, analysis_seen = [], []
    options = GenerateOptions(size=(96, 96), seed=1, material=material)
    analyze_photo(fir128, options, progress=lambda d, t: analysis_seen.append(d / t))
    assert analysis_seen == sorted(analysis_seen) and analysis_seen[-1] == 1.0
    assert len(analysis_seen) == (4 if material else 3)
    generate(fir128, options, progress=lambda d, t: seen.append(d / t))
    assert seen == sorted(seen) and seen[-1] == 1.0
    end_of_analysis = max(v for v in seen if v <= spans[0][1] + 1e-3)  # in 1000ths, rounded
    assert end_of_analysis == pytest.approx(spans[0][1], abs=1e-3)
    # the progress bar's text: each stage named in the order they run, the analysis by its steps
    from barkgen.pipeline import stage_at

    names = list(dict.fromkeys(stage_at(v, material) for v in seen))
    expected = ["analysing the photo: its label shapes", "analysing the photo: its texture"]
    expected += ["analysing the photo: its relief"] if material else []
    expected += ["growing the label map", "texture-by-numbers"]
    expected += ["making the material set"] if material else []
    assert names == expected
    assert stage_at(0.0, material) == "analysing the photo: its label map"


def test_memory_is_checked_before_any_work(fir128, monkeypatch):
    """generate and analyze_photo refuse a run over the budget before the photo's analysis
    (which used to run first, the check coming only at the texture stage); a 100-megapixel
    photo is refused up front."""
    import barkgen.labels
    from barkgen.errors import MemoryBudgetError
    from barkgen.pipeline import analyze_photo
    from barkgen.pipeline.core import check_generate_memory

    def no_work(*args, **kwargs):
        raise AssertionError("the analysis started")

    monkeypatch.setattr(barkgen.labels, "color_regions", no_work)
    tight = GenerateOptions(size=(256, 256), material=True, max_memory=200 * 2**20)
    for make in (generate, analyze_photo):
        with pytest.raises(MemoryBudgetError, match="needs about .* [MG]iB, more than the memory budget"):
            make(fir128, tight)
    small = check_generate_memory(fir128, GenerateOptions(size=(256, 256)))
    assert check_generate_memory(fir128, GenerateOptions(size=(256, 256), material=True)) > small
    # a 100-megapixel photo is refused up front, whatever the machine has free
    from barkgen.errors import ImageTooLargeError

    huge = np.broadcast_to(np.zeros(3, np.uint8), (10_000, 10_000, 3))
    with pytest.raises(ImageTooLargeError, match="10000x10000 px .100 megapixels"):
        check_generate_memory(huge, GenerateOptions(size=(1024, 1024), max_memory=2**50))
    with pytest.raises(MemoryBudgetError, match="7000x7000 photo"):
        check_generate_memory(huge[:7000, :7000], GenerateOptions(size=(1024, 1024), max_memory=2**33))


def test_analysis_cache_is_keyed_by_content():
    from barkgen.synth import AnalysisCache, SynthesisConfig

    rng = np.random.default_rng(0)
    feats = rng.random((40, 48, 3), dtype=np.float32)
    cache, config = AnalysisCache(), SynthesisConfig()
    first = cache.analyse(feats, 2, config)
    assert cache.analyse(feats.copy(), 2, config) is first and len(cache) == 1
    changed = feats.copy()
    changed[5, 5, 0] += 1.0
    assert cache.analyse(changed, 2, config) is not first
    assert cache.analyse(feats, 3, config) is not first
    assert cache.analyse(feats, 2, SynthesisConfig(k=4)) is not first
    assert len(cache) == 4 and cache.nbytes > feats.nbytes


@pytest.mark.parametrize("name", ["pine_plated_01", "birch_smooth_lenticels_01"])
def test_generate_quality_against_plain_synthesis(name):
    """Measured quality (small version of benchmarks/bench_generate.py): the result follows its
    label map and is nearly as coherent and as sharp as plain synthesis of the same photo."""
    from conftest import bark_exemplar, label_fidelity

    from barkgen import evaluate
    from barkgen.synth import synthesize

    photo = bark_exemplar(name, 256)
    result = generate(photo, GenerateOptions(size=(384, 384)))
    plain = synthesize(photo, (384, 384), seed=0).image
    fidelity = label_fidelity(photo, result.labels_in, result.texture, result.labels_out)
    # measured (pine / birch): ratio 0.97 / 0.98, balanced 0.93 / 0.94, coherence 0.98x / 0.74x
    # the plain synthesis's, sharpness 0.99 / 0.93
    assert fidelity["ratio"] >= 0.85
    assert fidelity["balanced"] >= 0.75
    assert evaluate.coherence(result.texture, photo) <= 1.5 * evaluate.coherence(plain, photo)
    assert 0.85 <= evaluate.sharpness_ratio(result.texture, photo) <= 1.15


def test_generate_options_are_validated():
    with pytest.raises(InvalidInputError, match="k"):
        GenerateOptions(k=0)
    with pytest.raises(InvalidInputError, match="method"):
        GenerateOptions(method="fft")
    with pytest.raises(InvalidInputError, match="strategy"):
        GenerateOptions(strategy="magic")
    with pytest.raises(InvalidInputError, match="seed"):
        GenerateOptions(seed=-1)


# --------------------------------------------------------------------------------------------
# command line


def test_generate_cli_writes_the_folder_then_resumes_from_an_edit(tmp_path, fir_png):
    out, levels = tmp_path / "out", tmp_path / "levels"
    r = run(
        "generate",
        str(fir_png),
        "-o",
        str(out),
        "--size",
        "160x128",
        "--k",
        "3",
        "--tile",
        "--seed",
        "1",
        "--save-levels",
        str(levels),
        "-q",
    )
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""
    assert {p.name for p in out.iterdir()} == OUTPUTS
    report = json.loads((out / "report.json").read_text())
    assert report["tile"] is True and report["size"] == [160, 128]
    assert report["photo"] == str(fir_png) and sorted(report["files"]) == sorted(OUTPUTS)
    assert read_image(out / "texture.png").shape == (128, 160, 3)
    assert read_image(out / "reference.png").dtype == np.uint16
    names = sorted(p.name for p in levels.iterdir())
    assert names[0] == "level_0.png" and len(names) >= 3
    assert np.array_equal(read_image(levels / "level_0.png"), read_image(out / "labels_out.png"))

    # paint the top half of level 2 with the lightest label and continue from it
    edited = read_image(levels / "level_2.png")[:, :, 0].copy()
    light = edited.max()
    edited[: edited.shape[0] // 2] = light
    write_png(tmp_path / "level_2.png", edited)
    out2 = tmp_path / "out2"
    r = run(
        "generate",
        str(fir_png),
        "-o",
        str(out2),
        "--size",
        "160x128",
        "--k",
        "3",
        "--tile",
        "--seed",
        "1",
        "--resume",
        str(tmp_path / "level_2.png"),
        "-q",
    )
    assert r.returncode == 0, r.stderr
    assert json.loads((out2 / "report.json").read_text())["resumed_from_level"] == 2
    before = read_image(out / "labels_out.png")[:, :, 0]
    after = read_image(out2 / "labels_out.png")[:, :, 0]
    # the painted half is much lighter than before (the exemplar has no light region that
    # large, so barkgen breaks it up with exemplar-like shapes), the other half much the same
    assert np.mean(after[8:56] == light) > np.mean(before[8:56] == light) + 0.15
    assert abs(np.mean(after[72:120] == light) - np.mean(before[72:120] == light)) < 0.15


def test_shapes_cli_layered_with_order_and_levels(tmp_path, fir128):
    from barkgen.labels import color_regions

    write_png(tmp_path / "a.png", color_regions(fir128, 3, seed=0))
    r = run(
        "shapes",
        str(tmp_path / "a.png"),
        "-o",
        str(tmp_path / "b.png"),
        "--size",
        "96x64",
        "--strategy",
        "layered",
        "--layer-order",
        "255,0,128",
        "--rotations",
        "all",
        "--save-levels",
        str(tmp_path / "lv"),
        "-q",
    )
    assert r.returncode == 0, r.stderr
    b = read_image(tmp_path / "b.png")
    assert b.shape == (64, 96, 1) and set(np.unique(b)) <= {0, 128, 255}
    assert (tmp_path / "lv" / "level_1.png").exists()


def test_shapes_cli_joint_strategy_with_the_photo(tmp_path, fir128, fir_png):
    from barkgen.labels import color_regions

    labels = color_regions(fir128, 3, seed=0)
    write_png(tmp_path / "a.png", labels)
    r = run(
        "shapes",
        str(tmp_path / "a.png"),
        "-o",
        str(tmp_path / "b.png"),
        "--size",
        "96x64",
        "--strategy",
        "joint",
        "--photo",
        str(fir_png),
        "-q",
    )
    assert r.returncode == 0, r.stderr
    b = read_image(tmp_path / "b.png")
    assert b.shape == (64, 96, 1) and set(np.unique(b)) <= set(np.unique(labels))


def _bad_generate(tmp: Path, photo: Path) -> dict[str, list[str]]:
    write_png(tmp / "wrong_size.png", np.zeros((50, 50), np.uint8))
    write_png(tmp / "level_1.png", np.zeros((30, 30), np.uint8))  # level 1 of 64x64 is 32x32
    write_png(tmp / "unknown.png", np.full((32, 32), 77, np.uint8))
    (tmp / "not_an_image.png").write_text("hello")
    two = np.zeros((64, 64), np.uint8)
    two[:, 32:] = 255
    write_png(tmp / "labels64.png", two)
    base = [str(photo), "-o", str(tmp / "out"), "--size", "64x64"]
    shapes = ["shapes", str(tmp / "labels64.png"), "-o", str(tmp / "out" / "b.png"), "--size", "64x64"]
    return {
        "edited level of no level's size": ["generate", *base, "--resume", str(tmp / "wrong_size.png")],
        "edited level of the wrong level's size": ["generate", *base, "--resume", str(tmp / "level_1.png")],
        "edited level with unknown labels": ["generate", *base, "--resume", str(tmp / "unknown.png")],
        "edited level not an image": ["generate", *base, "--resume", str(tmp / "not_an_image.png")],
        "bad size": ["generate", str(photo), "-o", str(tmp / "out"), "--size", "0x64"],
        "bad k": ["generate", *base, "--k", "0"],
        "bad strategy": ["generate", *base, "--strategy", "magic"],
        "extra name taken": ["generate", *base, "--extra", f"texture={photo}"],
        "missing photo": ["generate", str(tmp / "nope.jpg"), "-o", str(tmp / "out"), "--size", "64x64"],
        "output is a file": ["generate", str(photo), "-o", str(tmp / "not_an_image.png"), "--size", "64x64"],
        "shapes: bad layer order": ["shapes", str(photo), "-o", str(tmp / "out" / "b.png"), "--layer-order", "a,b"],
        "shapes: joint without its photo": [*shapes, "--strategy", "joint"],
        "shapes: photo of another size": [*shapes, "--strategy", "joint", "--photo", str(photo)],
        "shapes: photo without the joint strategy": [*shapes, "--photo", str(photo)],
    }


BAD_CASES = [
    "edited level of no level's size",
    "edited level of the wrong level's size",
    "edited level with unknown labels",
    "edited level not an image",
    "bad size",
    "bad k",
    "bad strategy",
    "extra name taken",
    "missing photo",
    "output is a file",
    "shapes: bad layer order",
    "shapes: joint without its photo",
    "shapes: photo of another size",
    "shapes: photo without the joint strategy",
]


@pytest.mark.parametrize("case", BAD_CASES)
def test_generate_bad_input_one_line_exit_2_nothing_written(tmp_path, fir_png, case):
    args = _bad_generate(tmp_path, fir_png)[case]
    r = run(*args)
    assert r.returncode == 2, (case, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("barkgen: error: "), r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "out").exists()


def test_the_names_a_run_writes_are_checked_once_for_every_front_end():
    from barkgen.pipeline import check_generate_names

    check_generate_names("bark", extras=["height", "normal"])
    for bad in ({"material_name": "texture"}, {"material_name": "bad name"}, {"extras": ["preview"]}):
        with pytest.raises(InvalidInputError):
            check_generate_names(**bad)


def test_default_memory_budget_is_what_the_machine_has_free(fir128, monkeypatch):
    """Without max_memory, a job is checked against the memory free when it starts (psutil's
    available), not a fixed 8 GiB: on a machine with 64 MiB free the quickstart is refused."""
    import barkgen._shared.memory as memory
    from barkgen.errors import InvalidInputError, MemoryBudgetError
    from barkgen.material import MaterialOptions, make_material
    from barkgen.synth import synthesize

    assert memory.available_memory() > 0
    monkeypatch.setattr(memory, "available_memory", lambda: 64 * 2**20)
    for job in (
        lambda: generate(fir128, GenerateOptions(size=(1024, 1024), material=True)),
        lambda: make_material(fir128, MaterialOptions()),
        lambda: synthesize(fir128, (1024, 1024)),
    ):
        with pytest.raises(MemoryBudgetError, match="more than the memory free on this machine"):
            job()
    with pytest.raises(InvalidInputError, match="max_memory must be a positive"):
        GenerateOptions(max_memory=0)
