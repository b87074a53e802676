"""The command line: outputs, reference maps, and one clear error line (exit 2) on bad input,
with no output file left behind."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import run
from PIL import Image

from barkgen.io import read_image, read_reference, write_png


@pytest.fixture(scope="module")
def exemplar_png(tmp_path_factory, synthetic_exemplar) -> Path:
    p = tmp_path_factory.mktemp("ex") / "ex.png"
    write_png(p, synthetic_exemplar)
    return p


def test_synth_writes_output_extras_and_reference(tmp_path, exemplar_png, synthetic_exemplar):
    h, w = synthetic_exemplar.shape[:2]
    height = np.linspace(0, 65535, h * w).reshape(h, w).astype(np.uint16)
    write_png(tmp_path / "height.png", height)
    out = tmp_path / "out" / "bark.png"
    r = run(
        "synth",
        str(exemplar_png),
        "-o",
        str(out),
        "--size",
        "70x40",
        "--tile",
        "--seed",
        "3",
        "--extra",
        f"height={tmp_path / 'height.png'}",
        "--save-reference",
        str(tmp_path / "ref.png"),
        "--blend",
        "none",
        "--quiet",
    )
    assert r.returncode == 0, r.stderr
    assert r.stderr == "" and r.stdout == ""  # --quiet, and piped: no progress bar
    img = read_image(out)
    assert img.shape == (40, 70, 3)
    hmap = read_image(tmp_path / "out" / "bark_height.png")
    assert hmap.shape == (40, 70, 1) and hmap.dtype == np.uint16
    # the saved reference map re-applied to the height map copies it exactly; the extra map
    # written beside the texture went through the gradient domain (no cliffs; screened, so its
    # mean is the copy's)
    r2 = run(
        "apply-reference", str(tmp_path / "ref.png"), str(tmp_path / "height.png"), "-o", str(tmp_path / "height2.png")
    )
    assert r2.returncode == 0, r2.stderr
    refs, _ = read_reference(tmp_path / "ref.png")
    copied = read_image(tmp_path / "height2.png")[:, :, 0]
    assert np.array_equal(copied, height[refs[..., 0], refs[..., 1]])
    assert abs(hmap[:, :, 0].astype(float).mean() - copied.mean()) < 0.01 * 65535
    # ... and to the exemplar itself gives the texture (its seams not blended: --blend none)
    r3 = run("apply-reference", str(tmp_path / "ref.png"), str(exemplar_png), "-o", str(tmp_path / "c.png"))
    assert r3.returncode == 0 and np.array_equal(read_image(tmp_path / "c.png"), img)


def test_same_seed_same_bytes(tmp_path, exemplar_png):
    for name in ("a", "b"):
        assert (
            run(
                "synth", str(exemplar_png), "-o", str(tmp_path / f"{name}.png"), "--size", "64x48", "--seed", "9", "-q"
            ).returncode
            == 0
        )
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


def test_bundled_sample_is_the_default_exemplar(tmp_path):
    r = run("synth", "-o", str(tmp_path / "s.png"), "--size", "96x64", "-q")
    assert r.returncode == 0, r.stderr
    assert read_image(tmp_path / "s.png").shape == (64, 96, 3)


def _bad_inputs(tmp: Path, exemplar_png: Path) -> dict[str, list[str]]:
    (tmp / "empty.png").write_bytes(b"")
    (tmp / "text.png").write_text("not an image")
    data = exemplar_png.read_bytes()
    (tmp / "trunc.png").write_bytes(data[: len(data) // 2])
    Image.fromarray(np.zeros((10, 40, 3), np.uint8)).save(tmp / "tiny.png")
    Image.fromarray(np.zeros((7, 7), np.uint8)).save(tmp / "small_extra.png")
    ex = str(exemplar_png)
    return {
        "missing file": [str(tmp / "nope.png")],
        "not an image": [str(tmp / "text.png")],
        "truncated image": [str(tmp / "trunc.png")],
        "0-byte file": [str(tmp / "empty.png")],
        "exemplar < 16 px": [str(tmp / "tiny.png")],
        "size 0x0": [ex, "--size", "0x0"],
        "size -5x10": [ex, "--size", "-5x10"],
        "size abc": [ex, "--size", "abc"],
        "memory budget": [ex, "--size", "20000x20000", "--max-memory", "1G"],
        "extra size mismatch": [ex, "--extra", f"height={tmp / 'small_extra.png'}"],
        "bad extra syntax": [ex, "--extra", "height"],
        "not a png output": [ex, "-o", str(tmp / "out.jpg")],
    }


@pytest.mark.parametrize(
    "case",
    [
        "missing file",
        "not an image",
        "truncated image",
        "0-byte file",
        "exemplar < 16 px",
        "size 0x0",
        "size -5x10",
        "size abc",
        "memory budget",
        "extra size mismatch",
        "bad extra syntax",
        "not a png output",
    ],
)
def test_bad_input_one_line_exit_2_no_output(tmp_path, exemplar_png, case):
    args = _bad_inputs(tmp_path, exemplar_png)[case]
    outdir = tmp_path / "outdir"
    outdir.mkdir()
    if "-o" not in args:
        args = args + ["-o", str(outdir / "out.png")]
    r = run("synth", *args, "--save-reference", str(outdir / "ref.png"))
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("barkgen: error: "), r.stderr
    assert "Traceback" not in r.stderr
    assert list(outdir.iterdir()) == []  # nothing written, no temp files


def test_apply_reference_rejects_a_map_of_another_size(tmp_path, exemplar_png):
    assert (
        run(
            "synth",
            str(exemplar_png),
            "-o",
            str(tmp_path / "o.png"),
            "--size",
            "32x32",
            "--save-reference",
            str(tmp_path / "ref.png"),
            "-q",
        ).returncode
        == 0
    )
    write_png(tmp_path / "other.png", np.zeros((20, 20), np.uint8))
    r = run("apply-reference", str(tmp_path / "ref.png"), str(tmp_path / "other.png"), "-o", str(tmp_path / "x.png"))
    assert r.returncode == 2 and "exemplar" in r.stderr and not (tmp_path / "x.png").exists()


# --------------------------------------------------------------------------------------------
# barkgen tbn


@pytest.fixture(scope="module")
def tbn_files(tmp_path_factory, synthetic_exemplar):
    from barkgen.testing import shuffled_blocks

    d = tmp_path_factory.mktemp("tbn")
    ex = synthetic_exemplar[:40, :40]
    lum = ex.astype(np.float32).mean(axis=2)
    labels = np.where(lum > np.median(lum), 255, 0).astype(np.uint8)
    write_png(d / "ex.png", ex)
    write_png(d / "a.png", labels)
    write_png(d / "b.png", shuffled_blocks(labels, 48, block=8, seed=3))
    return d


def test_tbn_writes_output_reference_and_debug_images(tmp_path, tbn_files):
    d = tbn_files
    out = tmp_path / "o.png"
    r = run(
        "tbn",
        str(d / "ex.png"),
        "--labels",
        str(d / "a.png"),
        "--target",
        str(d / "b.png"),
        "-o",
        str(out),
        "--seed",
        "2",
        "--init",
        "random",
        "--save-reference",
        str(tmp_path / "ref.png"),
        "--debug-dir",
        str(tmp_path / "dbg"),
        "-q",
    )
    assert r.returncode == 0, r.stderr
    assert read_image(out).shape == (48, 48, 3)
    assert read_image(tmp_path / "ref.png").shape == (48, 48, 3)
    names = {p.stem for p in (tmp_path / "dbg").iterdir()}
    assert {"initialization", "level0_result", "level0_target_labels"} <= names
    again = tmp_path / "again.png"
    assert (
        run(
            "tbn",
            str(d / "ex.png"),
            "--labels",
            str(d / "a.png"),
            "--target",
            str(d / "b.png"),
            "-o",
            str(again),
            "--seed",
            "2",
            "--init",
            "random",
            "-q",
        ).returncode
        == 0
    )
    assert again.read_bytes() == out.read_bytes()
    # the dark label as a thin label: matched by its proximity and direction too, so other bytes
    thin = tmp_path / "thin.png"
    args = ["tbn", str(d / "ex.png"), "--labels", str(d / "a.png"), "--target", str(d / "b.png")]
    assert run(*args, "-o", str(thin), "--seed", "2", "--init", "random", "--thin-label", "0", "-q").returncode == 0
    assert read_image(thin).shape == (48, 48, 3) and thin.read_bytes() != out.read_bytes()


def _bad_tbn_inputs(d: Path, tmp: Path) -> dict[str, list[str]]:
    write_png(tmp / "a_small.png", np.zeros((30, 40), np.uint8))
    write_png(tmp / "b_new_label.png", np.full((48, 48), 77, np.uint8))
    rng = np.random.default_rng(0)
    write_png(tmp / "b_many.png", rng.integers(0, 255, (48, 48), dtype=np.uint8))
    write_png(tmp / "a_many.png", rng.integers(0, 255, (40, 40), dtype=np.uint8))
    (tmp / "text.png").write_text("not an image")
    ex, a, b = str(d / "ex.png"), str(d / "a.png"), str(d / "b.png")
    return {
        "label map size mismatch": [ex, "--labels", str(tmp / "a_small.png"), "--target", b],
        "target label absent": [ex, "--labels", a, "--target", str(tmp / "b_new_label.png")],
        "more than 64 labels": [ex, "--labels", str(tmp / "a_many.png"), "--target", str(tmp / "b_many.png")],
        "label file not an image": [ex, "--labels", str(tmp / "text.png"), "--target", b],
        "missing target": [ex, "--labels", a, "--target", str(tmp / "nope.png")],
        "bad init": [ex, "--labels", a, "--target", b, "--init", "clever"],
        "negative weight": [ex, "--labels", a, "--target", b, "--label-weight", "-1"],
        "thin label absent": [ex, "--labels", a, "--target", b, "--thin-label", "77"],
        "thin label not a value": [ex, "--labels", a, "--target", b, "--thin-label", "dark"],
    }


@pytest.mark.parametrize(
    "case",
    [
        "label map size mismatch",
        "target label absent",
        "more than 64 labels",
        "label file not an image",
        "missing target",
        "bad init",
        "negative weight",
        "thin label absent",
        "thin label not a value",
    ],
)
def test_tbn_bad_input_one_line_exit_2_no_output(tmp_path, tbn_files, case):
    args = _bad_tbn_inputs(tbn_files, tmp_path)[case]
    outdir = tmp_path / "outdir"
    outdir.mkdir()
    r = run(
        "tbn",
        *args,
        "-o",
        str(outdir / "out.png"),
        "--save-reference",
        str(outdir / "ref.png"),
        "--debug-dir",
        str(outdir / "dbg"),
    )
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("barkgen: error: "), r.stderr
    assert list(outdir.iterdir()) == []  # nothing written, not even the debug folder


# --------------------------------------------------------------------------------------------
# labels, textons, merge


@pytest.fixture(scope="module")
def photo_png(tmp_path_factory) -> Path:
    from conftest import bark_exemplar

    p = tmp_path_factory.mktemp("photo") / "oak.png"
    write_png(p, bark_exemplar("oak_furrowed_moss_01", 128))
    return p


def test_labels_writes_map_and_preview(tmp_path, photo_png):
    out, prev = tmp_path / "a.png", tmp_path / "prev.png"
    r = run("labels", str(photo_png), "-o", str(out), "--k", "3", "--preview", str(prev), "-q")
    assert r.returncode == 0, r.stderr
    lm = read_image(out)[..., 0]  # (read as one channel)
    assert lm.shape == (128, 128) and lm.dtype == np.uint8 and sorted(np.unique(lm)) == [0, 128, 255]
    assert read_image(prev).shape == (128, 260, 3)
    r = run(
        "labels",
        str(photo_png),
        "-o",
        str(tmp_path / "e.png"),
        "--k",
        "2",
        "--edges",
        "--method",
        "texton",
        "--seed",
        "3",
        "-q",
    )
    assert r.returncode == 0, r.stderr
    assert len(np.unique(read_image(tmp_path / "e.png"))) == 3


def test_textons_then_merge(tmp_path, photo_png):
    d = tmp_path / "tx"
    r = run("textons", str(photo_png), "-o", str(d), "--textons", "6", "-q")
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in d.iterdir()) == sorted(
        ["textons.png", "sheet.png"] + [f"texton_{t:02d}.png" for t in range(6)]
    )
    assert set(np.unique(read_image(d / "texton_03.png"))) <= {0, 255}
    r = run("merge", str(d / "textons.png"), "-o", str(tmp_path / "m.png"), "--groups", "0,1;2,3,4,5")
    assert r.returncode == 0, r.stderr
    assert sorted(np.unique(read_image(tmp_path / "m.png"))) == [0, 255]


@pytest.mark.parametrize("case", ["k 0", "k 17", "not an image", "tiny", "bad groups", "bad method"])
def test_labels_bad_input_one_line_exit_2_no_output(tmp_path, photo_png, case):
    (tmp_path / "text.png").write_text("not an image")
    write_png(tmp_path / "tiny.png", np.zeros((8, 8, 3), np.uint8))
    write_png(tmp_path / "tm.png", np.array([[0, 1], [2, 3]], np.uint8))
    outdir = tmp_path / "out"
    outdir.mkdir()
    out = str(outdir / "a.png")
    args = {
        "k 0": ["labels", str(photo_png), "-o", out, "--k", "0"],
        "k 17": ["labels", str(photo_png), "-o", out, "--k", "17"],
        "not an image": ["labels", str(tmp_path / "text.png"), "-o", out],
        "tiny": ["labels", str(tmp_path / "tiny.png"), "-o", out],
        "bad groups": ["merge", str(tmp_path / "tm.png"), "-o", out, "--groups", "0,1;x"],
        "bad method": ["labels", str(photo_png), "-o", out, "--method", "magic"],
    }[case]
    r = run(*args, "--preview", str(outdir / "p.png")) if args[0] == "labels" else run(*args)
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("barkgen: error: "), r.stderr
    assert list(outdir.iterdir()) == []


# --------------------------------------------------------------------------------------------
# the root and its command groups

#: the top-level commands and groups of ``barkgen --help``, in its order
HELP_COMMANDS = [
    "synth",
    "tbn",
    "labels",
    "textons",
    "merge",
    "shapes",
    "generate",
    "material",
    "preview",
    "export-glb",
    "apply-reference",
    "batch",
    "tree",
    "serve",
    "warm-up",
    "evaluate",
    "bilayer",
    "library",
    "branches",
    "cache",
]
COMMAND_MODULES = [
    "_common",
    "synth",
    "labels",
    "shapes",
    "generate",
    "tree",
    "material",
    "serve",
    "warmup",
    "bilayer",
    "library",
    "branches",
    "cache",
]


def test_help_lists_every_command_group_in_order():
    r = run("--help")
    assert r.returncode == 0, r.stderr
    listed = [line.split()[0] for line in r.stdout.split("Commands:")[1].splitlines() if line.strip()]
    assert listed == HELP_COMMANDS
    for group, subcommands in (
        ("bilayer", ["analyze", "tune", "synth"]),
        ("library", ["add", "list", "show", "rm"]),
        ("branches", ["extract", "grow", "render", "stats"]),
        ("cache", ["show", "clear"]),
    ):
        r = run(group, "--help")
        assert r.returncode == 0, r.stderr
        assert [line.split()[0] for line in r.stdout.split("Commands:")[1].splitlines() if line.strip()] == subcommands


@pytest.mark.parametrize("module", COMMAND_MODULES)
def test_each_command_module_imports_alone(module):
    """A group module needs neither the root nor the other groups."""
    code = f"import sys, barkgen.cli.{module}\nprint(sorted(m for m in sys.modules if m.startswith('barkgen.cli.')))"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    loaded = set(eval(r.stdout.strip().splitlines()[-1]))
    assert loaded <= {f"barkgen.cli.{module}", "barkgen.cli._common", "barkgen.cli._options"}, loaded


def test_a_refusal_comes_before_the_kernels_load(tmp_path):
    """The CLI's start-up and its refusals load no numba, no kernels and no solver (issue 67:
    under load, a refusal after those imports took 2-4 s): a bad input is refused before them."""
    code = (
        "import sys\nfrom barkgen.cli import main\n"
        "try:\n    main(['generate', sys.argv[1], '-o', sys.argv[2], '-q'])\nexcept SystemExit as exc:\n"
        "    print(exc.code)\n"
        "print(sorted(m for m in sys.modules if m == 'numba' or m.endswith('_kernels') or m == 'faiss'))"
    )
    missing = str(tmp_path / "missing.png")
    r = subprocess.run([sys.executable, "-c", code, missing, str(tmp_path / "out")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    status, loaded = r.stdout.strip().splitlines()[-2:]
    assert status == "2" and "no such file" in r.stderr
    assert loaded == "[]", loaded


def test_checks_left_to_the_api_are_one_line_exit_2(tmp_path):
    """Where the CLI leaves a check to the API (an extraction step's range, a label map's size,
    a height edit outside the photo), the API's error is the one line, exit 2, nothing written."""
    rng = np.random.default_rng(0)
    write_png(tmp_path / "p.png", (rng.random((64, 64, 3)) * 255).astype(np.uint8))
    write_png(tmp_path / "small.png", np.zeros((32, 32), np.uint8))
    (tmp_path / "edits.json").write_text('{"version": 1, "edits": [{"x": 100, "y": 20, "delta": 1.5, "radius": 4}]}')
    out = tmp_path / "out"
    out.mkdir()
    photo = str(tmp_path / "p.png")
    for args, message in (
        (["branches", "extract", photo, "--step", "100", "-o", str(out / "s.json")], "step"),
        (
            ["branches", "extract", photo, "--labels", str(tmp_path / "small.png"), "-o", str(out / "s.json")],
            "label map",
        ),
        (["material", photo, "--edits", str(tmp_path / "edits.json"), "-o", str(out / "m"), "-q"], "outside"),
    ):
        r = run(*args)
        assert r.returncode == 2, (args, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("barkgen: error: ") and message in lines[0], r.stderr
        assert list(out.iterdir()) == []


def test_warm_up_refuses_an_unknown_stage():
    """``barkgen warm-up --stages`` names its stages (that nothing compiles after it in any front
    end: tests/pipeline/test_warmup_compiles.py)."""
    r = run("warm-up", "--stages", "nope")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "unknown stage" in r.stderr


def test_every_command_checks_its_memory_before_any_work(tmp_path, exemplar_png):
    """shapes, material and the bi-layer analysis and synthesis estimate their memory from the
    sizes and refuse a job over --max-memory in one line, exit 2, before reading further or
    writing anything (they used to run unbounded)."""
    from barkgen.bilayer import analyze
    from barkgen.io import write_bilayer_model
    from barkgen.labels import color_regions

    photo = read_image(exemplar_png)
    write_png(tmp_path / "labels.png", color_regions(photo, 3, seed=0))
    write_bilayer_model(tmp_path / "model.npz", analyze(photo[:64, :64]))
    out = tmp_path / "out"
    out.mkdir()
    cases = {
        "label map 4096x4096": [
            "shapes",
            str(tmp_path / "labels.png"),
            "-o",
            str(out / "s.png"),
            "--size",
            "4096x4096",
        ],
        "the material set of a": ["material", str(exemplar_png), "-o", str(out / "set")],
        "the bi-layer analysis of a": ["bilayer", "analyze", str(exemplar_png), "-o", str(out / "m.npz")],
        "a 4096x4096 bi-layer window": [
            "bilayer",
            "synth",
            str(tmp_path / "model.npz"),
            "-o",
            str(out / "b.png"),
            "--size",
            "4096x4096",
        ],
    }
    for job, args in cases.items():
        r = run(*args, "--max-memory", "100M")
        assert r.returncode == 2, (job, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"barkgen: error: {job}"), (job, r.stderr)
        assert "more than the memory budget (100 MiB" in lines[0]
    assert list(out.iterdir()) == []
