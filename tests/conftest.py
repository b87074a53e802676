"""Shared fixtures: the real bark photos and scans shipped in tests/data (see its SOURCES.md),
a crack-network photo drawn here, and helpers the tests share."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
#: the permissively licensed photos and scans the tests need (tests/data/SOURCES.md)
DATA = REPO / "tests" / "data"
BARK = DATA / "bark"
BARK_MAPS = DATA / "bark_maps"


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``barkgen ARGS`` in a subprocess (this interpreter), its output captured."""
    return subprocess.run(
        [sys.executable, "-m", "barkgen", *args], capture_output=True, text=True, cwd=cwd, timeout=600
    )


def run_here(*args: str) -> subprocess.CompletedProcess:
    """``barkgen ARGS`` in this process (:func:`barkgen.cli.main`, what the console script runs),
    so that a test can patch what a refusal must never reach; returns what :func:`run` returns."""
    import contextlib
    import io
    import signal

    from barkgen.cli import main

    err = io.StringIO()
    status: object = 0
    sigterm = signal.getsignal(signal.SIGTERM)  # (main sets its own)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            main(list(args))
    except SystemExit as exc:
        status = exc.code
    finally:
        signal.signal(signal.SIGTERM, sigterm)
    return subprocess.CompletedProcess(list(args), status, "", err.getvalue())


def pytest_configure(config) -> None:
    """Tests (and the CLIs they start) never touch the user's own exemplar library or analysis
    cache."""
    import tempfile

    os.environ["BARKGEN_LIBRARY"] = str(Path(tempfile.mkdtemp(prefix="barkgen-test-library-")) / "lib")
    os.environ["BARKGEN_CACHE_DIR"] = _CACHE_DIR[0] = tempfile.mkdtemp(prefix="barkgen-test-cache-")
    os.environ["BARKGEN_CACHE_MAX"] = "512M"


#: the session's analysis cache folder (removed when the session ends: its entries are large)
_CACHE_DIR: list[str] = [""]


def pytest_unconfigure(config) -> None:
    if _CACHE_DIR[0]:
        shutil.rmtree(_CACHE_DIR[0], ignore_errors=True)


def bark_exemplar(name: str, size: int) -> np.ndarray:
    """Centre crop of a real bark photo of tests/data/bark, short side resized to ``size``."""
    from barkgen.io import read_centre_crop

    return read_centre_crop(next(BARK.glob(name + ".*")), size)


def shuffled_blocks(shape: tuple[int, int], exemplar_side: int, block: int, seed: int = 0) -> np.ndarray:
    """A tiled ``(H, W, 2)`` reference map of square ``block`` px pieces of an exemplar at random
    places, rolled so that pieces run across the torus' edges and across window borders: a
    reference map whose right answer is known, for the passes that resolve maps from one."""
    rng = np.random.default_rng(seed)
    height, width = shape
    offsets = rng.integers(0, exemplar_side - block, size=(height // block, width // block, 2))
    by, bx = np.arange(height) // block, np.arange(width) // block
    ry = offsets[by[:, None], bx[None, :], 0] + (np.arange(height) % block)[:, None]
    rx = offsets[by[:, None], bx[None, :], 1] + (np.arange(width) % block)[None, :]
    refs = np.stack([ry, rx], axis=-1).astype(np.int32)
    return np.roll(refs, (block // 2 + 5, block // 2 - 7), axis=(0, 1))


@pytest.fixture(scope="session")
def pine64() -> np.ndarray:
    return bark_exemplar("pine_plated_01", 64)


def crack_photo(size: int = 256, seed: int = 0, *, cell: int = 40, grey: bool = False) -> np.ndarray:
    """A photo-like crack network drawn here (no licence to carry): plates of a Voronoi
    tessellation of a jittered grid (about ``cell`` px each, on the torus) with slightly different
    tones, parted by dark cracks that wobble (the plane warped by smooth noise), branch at T and
    Y junctions and vary in half-width (0.6-3.5 px), with pixel noise and a slight blur. The
    same ``(size, seed, cell)`` gives the same bytes."""
    from scipy import ndimage
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    n = max(4, round(size / cell))
    gy, gx = np.mgrid[0:n, 0:n]
    centres = (np.stack([gy, gx], -1).reshape(-1, 2) + 0.5 + rng.uniform(-0.38, 0.38, (n * n, 2))) * (size / n)

    def smooth_noise(sigma: float) -> np.ndarray:
        noise = ndimage.gaussian_filter(rng.normal(0, 1, (size, size)), sigma, mode="wrap")
        return noise / noise.std()

    y, x = np.mgrid[0:size, 0:size].astype(np.float64)
    warped = np.stack([y + 3.0 * smooth_noise(9), x + 3.0 * smooth_noise(9)], -1) % size
    distance, cell_of = cKDTree(centres, boxsize=size).query(warped.reshape(-1, 2), k=2)
    to_border = ((distance[:, 1] - distance[:, 0]) / 2).reshape(size, size)
    half_width = np.clip(1.8 + smooth_noise(14), 0.6, 3.5)
    crack = np.clip(half_width + 0.5 - to_border, 0, 1)
    plate = 175 + rng.normal(0, 10, n * n)[cell_of[:, 0].reshape(size, size)] + 6 * smooth_noise(6)
    image = (plate + rng.normal(0, 5, (size, size))) * (1 - crack) + (55 + rng.normal(0, 5, (size, size))) * crack
    image = ndimage.gaussian_filter(image, 0.6, mode="wrap")
    if grey:
        return np.clip(image, 0, 255).astype(np.uint8)
    return np.clip(image[..., None] * np.array([1.0, 0.88, 0.72]), 0, 255).astype(np.uint8)


_CRACK_FILES: dict[tuple, Path] = {}


def crack_photo_file(size: int = 256, seed: int = 0, *, cell: int = 40, grey: bool = False) -> Path:
    """:func:`crack_photo` written once per session as a PNG (``cracks_{size}_{seed}.png``)."""
    import tempfile

    from barkgen.io import write_png

    key = (size, seed, cell, grey)
    if key not in _CRACK_FILES:
        folder = Path(tempfile.mkdtemp(prefix="barkgen-test-cracks-"))
        path = folder / f"cracks_{size}_{seed}.png"
        write_png(path, crack_photo(size, seed, cell=cell, grey=grey))
        _CRACK_FILES[key] = path
    return _CRACK_FILES[key]


@pytest.fixture(scope="session")
def synthetic_exemplar() -> np.ndarray:
    """A small structured colour texture that needs no shared data."""
    rng = np.random.default_rng(7)
    y, x = np.mgrid[0:48, 0:40]
    base = 128 + 60 * np.sin(x / 3.0) * np.cos(y / 5.0)
    img = np.stack([base, base * 0.8 + 20, 255 - base], axis=-1) + rng.normal(0, 8, (48, 40, 3))
    return np.clip(img, 0, 255).astype(np.uint8)


def assert_continuous_copy(
    out: np.ndarray, source: np.ndarray, references: np.ndarray, tolerance: float = 0.15
) -> None:
    """``out`` is ``source`` through ``references`` in the gradient domain: inside the copied
    pieces it steps as the plain copy does (median error under ``tolerance`` of the copy's mean
    step), and across their borders it steps no more than about the copy's largest step."""
    ry, rx = references[..., 0], references[..., 1]
    plain = np.asarray(source, np.float64)[ry, rx]
    got = np.asarray(out, np.float64).reshape(plain.shape)
    inside = (ry[1:] == ry[:-1] + 1) & (rx[1:] == rx[:-1])
    d_got, d_plain = np.diff(got, axis=0), np.diff(plain, axis=0)
    scale = max(np.abs(d_plain[inside]).mean(), 1e-9)
    assert np.median(np.abs(d_got[inside] - d_plain[inside])) < tolerance * scale
    assert np.abs(d_got).max() <= 1.1 * np.abs(d_plain).max() + 1e-6


def label_fidelity(exemplar: np.ndarray, labels_in: np.ndarray, output: np.ndarray, labels_out: np.ndarray) -> dict:
    """How well ``output`` follows ``labels_out``, from its pixels alone: a random forest learns
    each pixel's label of ``labels_in`` from the exemplar's local colour statistics (CIELAB,
    its 7 px means and deviations, L's over 15 px: :func:`barkgen.testing` features) and
    labels the output; ``fidelity`` is its agreement with ``labels_out``, ``ratio`` that over
    its agreement on the exemplar itself (the ceiling) and ``balanced`` the mean per-label
    recall on the output (hertzmann2001's texture-by-numbers asks the output to look, pixel by
    pixel, like the exemplar's parts of the same label)."""
    from sklearn.ensemble import RandomForestClassifier

    from barkgen.testing import _features

    def grey(labels: np.ndarray) -> np.ndarray:
        labels = np.asarray(labels)
        return labels[..., 0] if labels.ndim == 3 else labels

    def u8(image: np.ndarray) -> np.ndarray:
        image = np.asarray(image)
        if image.dtype != np.uint8:
            image = np.clip(np.round(image * 255.0), 0, 255).astype(np.uint8) if image.dtype.kind == "f" else image
            image = (image >> 8).astype(np.uint8) if image.dtype == np.uint16 else image
        return np.ascontiguousarray(image[..., :3])

    a, b = grey(labels_in).ravel(), grey(labels_out).ravel()
    features = _features(u8(exemplar))
    x_ex = features.reshape(-1, features.shape[-1])
    rng = np.random.default_rng(7)
    pick = np.concatenate(
        [rng.choice(np.flatnonzero(a == v), min(int((a == v).sum()), 20_000), replace=False) for v in np.unique(a)]
    )
    forest = RandomForestClassifier(n_estimators=40, max_depth=18, min_samples_leaf=3, n_jobs=2, random_state=0)
    forest.fit(x_ex[pick], a[pick])
    ceiling = float((forest.predict(x_ex) == a).mean())
    predicted = forest.predict(_features(u8(output)).reshape(-1, features.shape[-1]))
    fidelity = float((predicted == b).mean())
    recalls = [float((predicted[b == v] == v).mean()) for v in np.unique(b)]
    return {"fidelity": fidelity, "ratio": fidelity / max(ceiling, 1e-9), "balanced": float(np.mean(recalls))}


# ---- the synth tests' inputs ------------------------------------------------------------------


@pytest.fixture(scope="session")
def sample256() -> np.ndarray:
    """The bundled sample (a texture that tiles itself) at 256 px."""
    import cv2

    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image

    return cv2.resize(read_image(sample_exemplar_path()), (256, 256), interpolation=cv2.INTER_AREA)


def _photo_like(seed: int = 0, shape=(96, 96)) -> np.ndarray:
    """A texture that does not tile: vertical furrows of random phase on a slope of colour."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    base = 110 + 50 * np.sin(x / 2.7 + rng.uniform(0, 6)) + 0.8 * y + rng.normal(0, 10, shape)
    return np.clip(np.stack([base, base * 0.9, base * 0.7], -1), 0, 255).astype(np.uint8)


@pytest.fixture(scope="session")
def photo_like():
    """``photo_like(seed=0, shape=(96, 96))``: a texture that does not tile (furrows on a slope)."""
    return _photo_like


def luminance_labels(image: np.ndarray, n: int = 2) -> np.ndarray:
    """Grey label map by luminance quantiles (a stand-in for the k-means label maps)."""
    lum = image.astype(np.float32).mean(axis=2)
    edges = np.quantile(lum, np.linspace(0, 1, n + 1)[1:-1])
    return (np.digitize(lum, edges) * (255 // (n - 1))).astype(np.uint8)


@pytest.fixture(scope="session")
def label_case(synthetic_exemplar):
    """A texture-by-numbers case: a 40 px exemplar, its luminance labels and a target of
    shuffled label blocks (64 px)."""
    from barkgen.testing import shuffled_blocks

    ex = synthetic_exemplar[:40, :40]
    a = luminance_labels(ex)
    b = shuffled_blocks(a, 64, block=8, seed=2)
    return ex, a, b


#: where scripts/test.sh installs the npm package gltf-validator
VALIDATOR = REPO / ".cache" / "node" / "node_modules" / "gltf-validator"
CHECK = """
const fs = require("fs");
const validator = require(process.argv[2]);
validator.validateBytes(new Uint8Array(fs.readFileSync(process.argv[1])), {maxIssues: 100}).then((r) => {
  console.log(JSON.stringify({errors: r.issues.numErrors, warnings: r.issues.numWarnings,
                              messages: r.issues.messages.filter((m) => m.severity <= 1)}));
});
"""


def validate_glb(path: Path) -> dict:
    """The Khronos validator's report of a .glb (its error and warning counts and messages)."""
    node = shutil.which("node")
    if node is None or not VALIDATOR.is_dir():
        pytest.skip(f"needs node and the npm package gltf-validator in {VALIDATOR} (scripts/test.sh installs it)")
    out = subprocess.run([node, "-e", CHECK, str(path), str(VALIDATOR)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)
