"""barkgen.evaluate on known answers: a copy of the photo, a copy of it in shuffled blocks, a
blurred copy, a copy with its colours shifted, a synthetic straight seam and step; and
``barkgen evaluate`` on a folder laid out as ``barkgen generate`` writes it."""

from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from barkgen.errors import InvalidInputError
from barkgen.evaluate import (
    Evaluation,
    as_lab,
    border_distance,
    border_step_ratio,
    coherence,
    colour_distance,
    completeness,
    evaluate,
    evaluate_folder,
    largest_copy,
    longest_line,
    longest_seam,
    piece_labels,
    seam_mask,
    sharpness_ratio,
    wrap_step_ratio,
)

BLOCK = 32


@pytest.fixture(scope="module")
def photo() -> np.ndarray:
    """The bundled sample at 128 px (the area average of the 1024 px photo)."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image

    return cv2.resize(read_image(sample_exemplar_path()), (128, 128), interpolation=cv2.INTER_AREA)


@pytest.fixture(scope="module")
def photo256() -> np.ndarray:
    """The bundled sample at 256 px."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image

    return cv2.resize(read_image(sample_exemplar_path()), (256, 256), interpolation=cv2.INTER_AREA)


def identity(h: int, w: int, dy: int = 0, dx: int = 0) -> np.ndarray:
    """The reference map of a plain copy (shifted by ``(dy, dx)``)."""
    ys, xs = np.mgrid[0:h, 0:w]
    return np.stack((ys + dy, xs + dx), axis=-1).astype(np.int32)


def shuffled_blocks(photo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The photo cut in BLOCK px blocks laid back in reverse order (so no two neighbouring blocks
    were neighbours in the photo), and its reference map."""
    h, w = photo.shape[:2]
    refs = identity(h, w)
    out, out_refs = np.empty_like(photo), np.empty_like(refs)
    nby, nbx = h // BLOCK, w // BLOCK
    for by in range(nby):
        for bx in range(nbx):
            sy, sx = (nby - 1 - by) * BLOCK, (nbx - 1 - bx) * BLOCK
            dst = np.s_[by * BLOCK : (by + 1) * BLOCK, bx * BLOCK : (bx + 1) * BLOCK]
            out[dst] = photo[sy : sy + BLOCK, sx : sx + BLOCK]
            out_refs[dst] = refs[sy : sy + BLOCK, sx : sx + BLOCK]
    return out, out_refs


# ---- a copy of the photo -----------------------------------------------------------------------


def test_a_copy_of_the_photo_scores_perfectly(photo):
    assert coherence(photo, photo) == pytest.approx(0.0, abs=1e-3)
    assert completeness(photo, photo) == pytest.approx(0.0, abs=1e-3)
    assert sharpness_ratio(photo, photo) == pytest.approx(1.0)
    assert colour_distance(photo, photo) == pytest.approx(0.0, abs=1e-6)
    assert largest_copy(identity(*photo.shape[:2])) == 1.0
    assert longest_seam(identity(*photo.shape[:2])) == 0
    assert not seam_mask(identity(*photo.shape[:2])).any()


def test_the_measures_are_deterministic(photo):
    noisy = np.clip(photo.astype(int) + np.random.default_rng(0).integers(-20, 21, photo.shape), 0, 255)
    noisy = noisy.astype(np.uint8)
    assert coherence(noisy, photo) == coherence(noisy, photo) > 1.0


def test_a_shifted_copy_of_a_photo_that_tiles_is_one_piece_when_the_output_tiles_too(photo):
    h, w = photo.shape[:2]
    refs = identity(h, w, 40, 70) % np.array([h, w])
    assert largest_copy(refs) < 1.0  # the photo's edges cut it in four
    assert largest_copy(refs, exemplar_wrap=(h, w)) == 1.0
    assert longest_seam(refs, exemplar_wrap=(h, w)) == 0
    shifted = np.roll(photo, (-40, -70), axis=(0, 1))
    # the same patches, those round the edges included: a photo that tiles shows no seam there
    assert coherence(shifted, photo, wrap=True) == pytest.approx(coherence(photo, photo, wrap=True))
    assert coherence(photo, photo, wrap=True) < 1.0


# ---- shuffled blocks ----------------------------------------------------------------------------


def test_shuffled_blocks_keep_coherence_low_and_show_their_seams(photo):
    blocks, refs = shuffled_blocks(photo)
    noise = np.random.default_rng(1).integers(0, 256, photo.shape, dtype=np.uint8)
    assert coherence(blocks, photo) < 0.25 * coherence(noise, photo)
    assert largest_copy(refs) == pytest.approx((BLOCK / photo.shape[0]) ** 2)
    mask = seam_mask(refs)
    for k in range(1, photo.shape[0] // BLOCK):
        assert mask[k * BLOCK - 1].all() and mask[k * BLOCK].all()  # both sides of each border
        assert mask[:, k * BLOCK - 1].all() and mask[:, k * BLOCK].all()
    inside = np.ones_like(mask)
    for k in range(0, photo.shape[0] // BLOCK + 1):
        inside[max(k * BLOCK - 1, 0) : k * BLOCK + 1] = False
        inside[:, max(k * BLOCK - 1, 0) : k * BLOCK + 1] = False
    assert not mask[inside].any()
    assert longest_seam(refs) == photo.shape[1]  # the block row's length
    assert border_step_ratio(blocks, refs) > 1.3
    assert border_step_ratio(photo, refs) == pytest.approx(1.0, abs=0.2)  # the borders of a copy are invisible
    distance = border_distance(refs)
    assert distance[BLOCK // 2, BLOCK // 2] == BLOCK // 2 - 1 and distance[BLOCK, 5] == 0


def test_shuffled_blocks_show_straight_lines_where_they_meet(photo256):
    """At 256 px (at 128 px the photo's own furrows step as much from one pixel to the next as
    the seams do: a line detector needs the texture to be smooth at the pixel scale)."""
    blocks, _ = shuffled_blocks(photo256)
    assert longest_line(blocks) >= 0.85 * 256
    assert longest_line(cv2.cvtColor(blocks, cv2.COLOR_RGB2GRAY)) >= 0.85 * 256
    assert longest_line(photo256) < 0.3 * 256


def test_piece_labels_number_the_blocks(photo):
    _, refs = shuffled_blocks(photo)
    labels = piece_labels(refs)
    assert labels.max() + 1 == (photo.shape[0] // BLOCK) ** 2
    assert (labels[:BLOCK, :BLOCK] == labels[0, 0]).all()


# ---- blur and colour ----------------------------------------------------------------------------


def test_a_blurred_copy_is_less_sharp(photo):
    blurred = cv2.GaussianBlur(photo, (0, 0), 1.5)
    assert sharpness_ratio(blurred, photo) < 0.6
    assert coherence(blurred, photo) > coherence(photo, photo) + 1.0


def test_a_colour_shift_is_measured_in_lab_units(photo):
    from skimage.color import lab2rgb

    lab = as_lab(photo).astype(np.float64)
    shifted = lab + np.array([3.0, 3.0, 3.0])
    rgb = np.round(np.clip(lab2rgb(shifted), 0, 1) * 65535).astype(np.uint16)
    same = np.round(np.clip(lab2rgb(lab), 0, 1) * 65535).astype(np.uint16)
    assert colour_distance(rgb, same) == pytest.approx(3.0, abs=0.2)
    assert colour_distance(rgb, photo) == pytest.approx(3.0, abs=0.3)
    assert colour_distance(photo[:, ::-1], photo) == pytest.approx(0.0, abs=1e-6)  # arrangement is free


# ---- synthetic straight seams and steps ---------------------------------------------------------


def test_a_synthetic_straight_seam_scores_its_length(photo):
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image

    big = read_image(sample_exemplar_path())[:512, :512]
    seamed = big.copy()
    seamed[200:] = big[:312][:, ::-1]  # below row 200: another part of the bark
    refs = identity(512, 512)
    refs[200:] = identity(312, 512)[:, ::-1]
    assert longest_seam(refs) == 512
    assert longest_line(seamed) >= 0.9 * 512
    assert longest_line(big) < 100


def test_a_synthetic_step_scores_its_length():
    step = np.zeros((96, 160), np.uint8)
    step[:, 70:] = 200
    assert longest_line(step) == 96
    assert longest_line(step.T) == 96
    assert longest_line(step, tile=True) == 96  # and the wrap round from the last column to the first
    assert longest_line(np.zeros((96, 160), np.float32)) == 0
    refs = identity(96, 160)
    refs[:, 70:, 1] += 500
    assert longest_seam(refs) == 96
    assert longest_seam(refs, tile=True) == 160  # round the output, its last row meets its first


def test_evaluate_knows_when_the_photo_tiles_itself(photo):
    h, w = photo.shape[:2]
    refs = identity(h, w, 40, 70) % np.array([h, w])
    shifted = np.roll(photo, (-40, -70), axis=(0, 1))
    both = evaluate(shifted, photo, references=refs, photo_wraps=True)
    assert both.largest_copy == 1.0 and both.longest_seam == 0
    assert evaluate(shifted, photo, references=refs, photo_wraps=(True, False)).longest_seam == h


def test_the_border_of_a_tiling_image_is_measured_when_it_repeats(photo, photo256):
    half = photo256[:, :128]  # its left and right edges are unrelated
    assert wrap_step_ratio(half) > 1.5
    rolled = np.roll(photo256, (90, 50), axis=(0, 1))  # the sample tiles itself: any roll does too
    assert wrap_step_ratio(rolled) == pytest.approx(1.0, abs=0.2)
    # a ramp along the rows: steps of 1/63 between columns and 0 between rows inside (mean 1/126);
    # across the wrap, 1 from the last column to the first and 0 from the last row (mean 1/2)
    ramp = np.tile(np.linspace(0, 1, 64), (64, 1))
    assert wrap_step_ratio(ramp) == pytest.approx(63.0)
    assert evaluate(photo[:, :64], photo, tile=True).wrap_step_ratio > 1.5


def test_a_seam_round_a_tiled_output_counts_only_when_it_tiles():
    refs = identity(64, 64, 3, 5)
    assert longest_seam(refs) == 0
    assert longest_seam(refs, tile=True) == 64  # the last row does not continue into the first
    assert longest_seam(refs % 64, tile=True, exemplar_wrap=(64, 64)) == 0


# ---- all at once --------------------------------------------------------------------------------


def test_evaluate_holds_every_measure(photo):
    blocks, refs = shuffled_blocks(photo)
    height = cv2.cvtColor(blocks, cv2.COLOR_RGB2GRAY)
    result = evaluate(blocks, photo, references=refs, maps={"height": height})
    assert isinstance(result, Evaluation)
    assert result.size == (128, 128) and result.longest_seam == 128
    assert result.largest_copy == pytest.approx(1 / 16)
    assert result.maps["height"].border_step_ratio > 1.3
    table = result.table()
    assert "coherence" in table and "map height" in table
    data = json.loads(json.dumps(result.as_dict()))
    assert data["longest_seam"] == 128 and data["maps"]["height"]["longest_line"] == result.maps["height"].longest_line
    bare = evaluate(photo, photo)
    assert bare.largest_copy is None and "largest_copy" not in bare.table()
    assert bare.wrap_step_ratio is None and "wrap_step_ratio" not in bare.table()  # not tiled
    with pytest.raises(InvalidInputError, match="references"):
        evaluate(photo, photo, references=refs[:10])
    with pytest.raises(dataclasses_error()):
        result.coherence = 0.0  # type: ignore[misc]


def dataclasses_error():
    import dataclasses

    return dataclasses.FrozenInstanceError


def test_bad_inputs_are_one_clear_error(photo):
    with pytest.raises(InvalidInputError, match="patch"):
        coherence(photo, photo, patch=4)
    with pytest.raises(InvalidInputError, match="references"):
        longest_seam(np.zeros((4, 4, 3), np.int32))
    with pytest.raises(InvalidInputError, match="flat"):
        sharpness_ratio(photo, np.zeros_like(photo))


# ---- a generate folder and the command ----------------------------------------------------------


@pytest.fixture(scope="module")
def folder(tmp_path_factory, photo):
    """A folder as ``barkgen generate`` writes it: the shuffled blocks, their reference map, an
    extra map and report.json; and the photo beside it."""
    from barkgen.io import write_png, write_reference

    root = tmp_path_factory.mktemp("evaluate")
    out = root / "out"
    out.mkdir()
    blocks, refs = shuffled_blocks(photo)
    write_png(out / "texture.png", blocks)
    write_png(out / "edges.png", cv2.Canny(blocks, 50, 150))
    write_reference(out / "reference.png", refs, photo.shape[:2])
    report = {"tile": False, "exemplar_wrap": [False, False], "extras": ["edges"]}
    (out / "report.json").write_text(json.dumps(report))
    write_png(root / "photo.png", photo)
    return out


def test_evaluate_folder_reads_what_generate_writes(folder):
    result = evaluate_folder(folder, folder.parent / "photo.png")
    assert result.longest_seam == 128 and result.largest_copy == pytest.approx(1 / 16)
    assert set(result.maps) == {"edges"}


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "barkgen", "evaluate", *args], capture_output=True, text=True, timeout=600
    )


def test_the_command_prints_the_table_or_json(folder):
    photo = str(folder.parent / "photo.png")
    table = run_cli(str(folder), "--photo", photo)
    assert table.returncode == 0, table.stderr
    assert "longest_seam" in table.stdout and "128 px" in table.stdout
    as_json = run_cli(str(folder), "--photo", photo, "--json")
    assert as_json.returncode == 0, as_json.stderr
    assert json.loads(as_json.stdout)["longest_seam"] == 128


@pytest.mark.parametrize(
    "args, words",
    [
        (["{missing}", "--photo", "{photo}"], "not a folder"),
        (["{folder}", "--photo", "{missing}"], "no such file"),
        (["{photo_folder}", "--photo", "{photo}"], "no texture.png"),
    ],
)
def test_the_command_says_what_is_wrong_in_one_line(folder, args, words):
    names = {
        "missing": str(folder.parent / "nothing"),
        "photo": str(folder.parent / "photo.png"),
        "folder": str(folder),
        "photo_folder": str(folder.parent),
    }
    r = run_cli(*(a.format(**names) for a in args))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("barkgen: error: ") and words in lines[0], r.stderr


def test_stacked_pieces_count_the_borders_that_continue_a_photo_column():
    """Two pieces one above the other copying the same photo columns, rows apart: every border
    pair stacks them; one column to the side instead: none does. Round a tiled output, the
    borders across its edges count too."""
    from barkgen.evaluate import stacked_pieces

    ry, rx = np.mgrid[0:20, 0:10]
    top = ry < 10
    stacked = np.stack([np.where(top, ry, ry + 7), rx + 5], axis=-1)
    assert stacked_pieces(stacked) == (10, 10)
    beside = np.stack([np.where(top, ry, ry + 7), np.where(top, rx + 5, rx + 6)], axis=-1)
    assert stacked_pieces(beside) == (0, 10)
    # round the torus: the last row against the first (the same columns) and the last column
    # against the first (the same rows, 10 columns back) stack too
    assert stacked_pieces(stacked, tile=True) == (40, 40)


def test_grid_step_ratio_sees_a_grid_of_cells_and_not_an_even_image():
    from barkgen.evaluate import grid_step_ratio

    rng = np.random.default_rng(0)
    noise = rng.integers(60, 200, (256, 256, 3)).astype(np.uint8)
    assert 0.9 < grid_step_ratio(noise, 64, tile=True) < 1.1
    cells = np.repeat(np.repeat(rng.integers(0, 255, (4, 4, 3)), 64, axis=0), 64, axis=1).astype(np.uint8)
    smooth = np.clip(cells.astype(int) + rng.integers(-3, 4, cells.shape), 0, 255).astype(np.uint8)
    assert grid_step_ratio(smooth, 64, tile=True) > 5
    assert grid_step_ratio(smooth, 64) > 5  # the three inner boundaries per axis, no wrap
    with pytest.raises(InvalidInputError, match="no larger than one 300 px cell"):
        grid_step_ratio(noise, 300)
