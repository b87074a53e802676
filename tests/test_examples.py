"""Every ``examples/*.py`` runs as a user would run it (``python examples/NN_name.py OUTDIR``, in a
subprocess, with a fresh output folder), exits 0 and writes what its docstring promises; each
check also looks at something real in the outputs (sizes, tileability, label areas, ...)."""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from importlib.util import find_spec
from pathlib import Path

import numpy as np
import pytest

from barkgen.io import read_bilayer_model, read_image, read_reference

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCRIPTS = sorted(EXAMPLES.glob("[0-9][0-9]_*.py"))


def grey(path: Path) -> np.ndarray:
    image = read_image(path)
    return image[:, :, 0] if image.shape[2] == 1 else image


def wrap_ratio(image: np.ndarray, axis: int) -> float:
    """Mean step across the wrap-around (last row/column to first) over the mean step between
    neighbours: about 1 when the image tiles, 3-4 for an untiled synthesis of the sample."""
    a = np.moveaxis(image.astype(np.float64), axis, 0)
    return float(np.abs(a[0] - a[-1]).mean() / np.abs(np.diff(a, axis=0)).mean())


def check_01(out: Path) -> None:
    texture, exemplar = read_image(out / "synthesized.png"), read_image(out / "exemplar.png")
    assert texture.shape == (160, 224, 3) and exemplar.shape == (128, 128, 3)
    refs, exemplar_shape = read_reference(out / "reference.png")
    assert exemplar_shape == (128, 128)
    # the texture is the exemplar resolved through its references; only the seams' colour
    # steps are blended, so it stays within a few grey levels of the exact copy
    copied = exemplar[refs[:, :, 0], refs[:, :, 1]].astype(np.float64)
    change = np.abs(copied - texture)
    assert change.mean() < 2.0 and np.percentile(change, 99) < 16
    assert not np.array_equal(copied, texture)


def check_02(out: Path) -> None:
    texture, height = read_image(out / "texture.png"), read_image(out / "texture_height.png")
    assert texture.shape == (128, 128, 3) and height.shape == (128, 128, 1)
    assert height.dtype == np.uint16 and height.min() == 0 and height.max() == 65535
    assert max(wrap_ratio(texture, 0), wrap_ratio(texture, 1)) < 2.0
    assert np.array_equal(read_image(out / "texture_2x2.png"), np.tile(texture, (2, 2, 1)))


def check_03(out: Path) -> None:
    texture, target = read_image(out / "texture.png"), grey(out / "target_labels.png")
    assert texture.shape == (160, 128, 3) and target.shape == (160, 128)
    dark, light = np.unique(grey(out / "exemplar_labels.png"))
    luminance = texture.mean(axis=2)
    # the painted fissures are dark in the texture
    assert luminance[target == dark].mean() < luminance[target == light].mean() - 10


def check_04(out: Path) -> None:
    labels = grey(out / "labels_color.png")
    assert labels.shape == (128, 128) and np.unique(labels).size == 3
    assert np.unique(grey(out / "labels_color_edges.png")).size == 4
    assert np.unique(grey(out / "labels_texton.png")).size == 3
    assert read_image(out / "preview.png").shape[0] == 128
    label_out = grey(out / "labels_out.png")
    assert label_out.shape == (192, 192) and set(np.unique(label_out)) <= set(np.unique(labels))
    for value in np.unique(labels):  # every label keeps its area
        assert abs(np.mean(label_out == value) - np.mean(labels == value)) < 0.05
    levels = sorted(out.glob("labels_out_level_*.png"))
    assert len(levels) >= 2 and np.array_equal(grey(out / "labels_out_level_0.png"), label_out)


def check_05(out: Path) -> None:
    textures = []
    for seed in (5, 6):
        folder = out / f"seed_{seed}"
        report = json.loads((folder / "report.json").read_text())
        assert report["seed"] == seed and report["tile"] is True and report["size"] == [128, 128]
        assert sorted(p.name for p in folder.iterdir()) == sorted(report["files"])
        textures.append(read_image(folder / "texture.png"))
        assert textures[-1].shape == (128, 128, 3)
        assert max(wrap_ratio(textures[-1], 0), wrap_ratio(textures[-1], 1)) < 2.0
    assert not np.array_equal(*textures)  # two seeds, two barks


def check_06(out: Path) -> None:
    suffixes = ("Color", "NormalGL", "NormalDX", "Displacement", "Roughness", "AmbientOcclusion")
    name = "sample_bark_seed7_128x128"  # asset, variant, size (barkgen.io.asset_names)
    maps = {s: read_image(out / "bark" / f"{name}_{s}.png") for s in suffixes}
    assert {m.shape[:2] for m in maps.values()} == {(128, 128)}
    assert maps["Displacement"].dtype == np.uint16
    # OpenGL and DirectX normals differ exactly in green
    gl, dx = maps["NormalGL"].astype(int), maps["NormalDX"].astype(int)
    assert np.array_equal(gl[..., [0, 2]], dx[..., [0, 2]]) and not np.array_equal(gl[..., 1], dx[..., 1])
    meta = json.loads((out / "bark" / f"{name}.json").read_text())
    assert meta["tileable"] is True and meta["seed"] == 7
    assert read_image(out / "trunk_preview.png").shape == (192, 192, 3)
    if find_spec("trimesh") is not None:
        assert (out / "trunk.glb").read_bytes()[:4] == b"glTF"


def check_07(out: Path) -> None:
    model = read_bilayer_model(out / "model.npz")
    assert model.k == 2
    left, right = read_image(out / "window_0_0.png"), read_image(out / "window_64_0.png")
    assert left.shape == right.shape == (128, 128, 3)
    assert np.array_equal(left[:, 64:], right[:, :64])  # windows agree where they overlap
    deformed = read_image(out / "deformed.png")
    assert deformed.shape == (128, 128, 3) and not np.array_equal(deformed, left)
    for name in ("analysis.png", "structure.png", "noise.png"):
        assert read_image(out / name).size


def check_08(out: Path) -> None:
    grown = json.loads((out / "grown.json").read_text())
    source = json.loads((out / "source.json").read_text())
    assert grown["size"] == [128, 160] and len(grown["branches"]) > 0 and len(source["branches"]) > 0
    rendered, fissures = read_image(out / "rendered.png"), grey(out / "rendered_fissures.png")
    assert rendered.shape[:2] == fissures.shape == (160, 128)
    assert 0 < np.mean(fissures == 255) < 0.5
    assert read_image(out / "source_overlay.png").shape[:2] == read_image(out / "source.png").shape[:2]


def check_09(out: Path) -> None:
    if find_spec("distributed") is None:
        return
    assert (out / "forest" / "manifest.sqlite").is_file()
    folders = sorted(p.name for p in (out / "forest" / "pine").iterdir())
    assert folders == ["10", "11", "12"]
    for seed in folders:
        folder = out / "forest" / "pine" / seed
        assert read_image(folder / "texture.png").shape == (96, 96, 3)
        assert json.loads((folder / "report.json").read_text())["seed"] == int(seed)


CHECKS = {f"{n:02d}": globals()[f"check_{n:02d}"] for n in range(1, 10)}


def test_every_example_is_checked_and_listed():
    assert [s.name[:2] for s in SCRIPTS] == sorted(CHECKS)
    listing = (EXAMPLES / "README.md").read_text()
    for script in SCRIPTS:
        assert script.name in listing
        doc = ast.get_docstring(ast.parse(script.read_text()))
        assert doc and f"python examples/{script.name} OUTDIR" in doc


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_example_runs_and_writes_its_outputs(script: Path, tmp_path: Path):
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    done = subprocess.run(
        [sys.executable, str(script), str(out)], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert out.is_dir() and any(out.iterdir())
    CHECKS[script.name[:2]](out)
