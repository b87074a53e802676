"""A scanned set in, a bigger set out (issue 32): the output's maps are the scan's own, carried
through the reference map (exact inside the copied pieces, continuous across their borders,
normals unit vectors), not estimated; they tile where the colour tiles."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from conftest import BARK, BARK_MAPS, run

from barkgen import Canvas
from barkgen.io import read_image, read_scanned_set, write_png
from barkgen.material import scanned_material
from barkgen.pipeline import GenerateOptions, generate
from barkgen.synth import piece_borders

MAPS = BARK_MAPS


def scan_crop(tmp_path, name: str, size: int):
    """A folder holding a ``size`` crop of a scanned set of tests/data (photo + its maps)."""
    folder = tmp_path / name
    folder.mkdir()
    write_png(folder / f"{name}.png", read_image(BARK / f"{name}.jpg")[:size, :size])
    for kind in ("normal", "ao", "roughness"):
        write_png(folder / f"{name}_{kind}.png", read_image(MAPS / f"{name}_{kind}.jpg")[:size, :size])
    return folder


def deep_inside(references: np.ndarray, exemplar_shape, band: int = 8) -> np.ndarray:
    """Output pixels at least ``band`` px from any border between copied pieces (on the torus)."""
    inside = (~piece_borders(references, exemplar_shape, Canvas(references.shape[:2], tile=True))).astype(np.uint8)
    pad = band + 1
    distance = cv2.distanceTransform(np.pad(inside, pad, mode="wrap"), cv2.DIST_L2, 3)[pad:-pad, pad:-pad]
    return distance >= band


@pytest.fixture(scope="module")
def oak_run(tmp_path_factory):
    folder = scan_crop(tmp_path_factory.mktemp("scan"), "oak_furrowed_moss_01", 192)
    scan = read_scanned_set(folder)
    result = generate(scan.color, GenerateOptions(size=(256, 320), tile=True, material=True, seed=3), scan=scan)
    return scan, result


def test_the_outputs_maps_are_the_scans_own_inside_the_pieces(oak_run):
    scan, result = oak_run
    material, refs = result.material, result.references
    assert set(material.scanned) == {"normals", "ao", "roughness"}
    deep = deep_inside(refs, scan.shape)
    assert deep.mean() > 0.3  # pieces are large: most of the output is deep inside one
    copied = {kind: getattr(scan, kind)[refs[..., 0], refs[..., 1]] for kind in ("normals", "ao", "roughness")}
    for kind in ("ao", "roughness"):
        assert np.abs(getattr(material, kind) - copied[kind])[deep].max() < 1e-6, kind
    cosine = (material.normals.astype(np.float64) * copied["normals"]).sum(2)
    assert np.degrees(np.arccos(np.clip(cosine, -1, 1)))[deep].max() < 0.1
    length = np.linalg.norm(material.normals, axis=2)
    assert np.abs(length - 1).max() < 0.01


def test_the_scans_maps_tile_where_the_colour_tiles(oak_run):
    """Across the output's wrap edge a map steps no more than between neighbouring rows (and
    columns) inside it: the edge's mean step is within the interior's 99th percentile (a seam
    would stand above them all)."""
    _, result = oak_run
    material = result.material
    for values in (material.ao, material.roughness, material.normals[..., 0], material.height):
        for axis in (0, 1):
            inner = np.abs(np.diff(values, axis=axis)).mean(axis=1 - axis)
            edge = np.abs(np.take(values, 0, axis=axis) - np.take(values, -1, axis=axis)).mean()
            assert edge <= np.percentile(inner, 99), (axis, edge, np.percentile(inner, 99))


def test_the_height_is_the_scans_relief(oak_run):
    """Without a displacement map the height is the scan's normals integrated: its slopes
    point as the normals do."""
    scan, _ = oak_run
    material = scanned_material(scan)
    gy, gx = np.gradient(material.height.astype(np.float64))
    n = scan.normals.astype(np.float64)
    slope_x, slope_y = -n[..., 0] / n[..., 2], n[..., 1] / n[..., 2]
    assert np.corrcoef(gx.ravel(), slope_x.ravel())[0, 1] > 0.7
    assert np.corrcoef(gy.ravel(), slope_y.ravel())[0, 1] > 0.7


def test_cli_generate_takes_a_set_folder(tmp_path):
    folder = scan_crop(tmp_path, "pine_plated_01", 128)
    out = tmp_path / "out"
    r = run("generate", str(folder), "-o", str(out), "--size", "160x128", "--tile", "--seed", "1", "-q")
    assert r.returncode == 0, r.stderr
    # the set's files are named by the lead's asset names (issue 66): found by their map word
    meta = json.loads(next(p for p in out.glob("*.json") if p.name != "report.json").read_text())
    assert set(meta["scanned_maps"]) == {"normals", "ao", "roughness"}
    assert read_image(next(out.glob("*_NormalGL.png"))).shape == (128, 160, 3)
    # the set's own folder is not an output folder, and a set that is not one says why
    r = run("generate", str(folder), "-o", str(folder), "--size", "64x64", "-q")
    assert r.returncode == 2 and "scanned set's folder" in r.stderr and len(r.stderr.splitlines()) == 1
    for name in ("pine_plated_01_diff.png", "pine_plated_01_Color.png"):
        (folder / name).write_bytes((folder / "pine_plated_01.png").read_bytes())
    r = run("generate", str(folder), "-o", str(tmp_path / "out2"), "--size", "64x64", "-q")
    assert r.returncode == 2 and "two color maps" in r.stderr and len(r.stderr.splitlines()) == 1
    assert not (tmp_path / "out2").exists()
