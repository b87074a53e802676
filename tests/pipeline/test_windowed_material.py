"""The windowed resolve pass (:mod:`barkgen.pipeline.windowed`): a tiled output's colour and
material set made window by window match the whole output's, across the windows' borders and
round the torus, to within a last bit of each file."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import bark_exemplar, shuffled_blocks

from barkgen._shared.canvas import Canvas
from barkgen.errors import InvalidInputError
from barkgen.pipeline.windowed import (
    MATERIAL_HALO,
    HeightRange,
    encoded_window,
    material_in_windows,
    read_references,
    resolve_windows,
)

SIZE, BLOCK, WINDOW = 384, 48, 128


@pytest.fixture(scope="module")
def whole_and_windowed():
    from barkgen.material import MaterialOptions, make_material, transfer_material
    from barkgen.material.presets import encoded_maps
    from barkgen.synth import blend_seams, resolve_continuous

    photo = bark_exemplar("fir_scaly_01", 128)
    source = make_material(photo, MaterialOptions(exemplar_wrap="no"))
    refs = shuffled_blocks((SIZE, SIZE), photo.shape[0], BLOCK, seed=0)
    canvas = Canvas((SIZE, SIZE), tile=True, exemplar_wrap=(False, False))
    whole = transfer_material(source, refs, canvas)
    files = encoded_maps(whole)
    files["texture"] = blend_seams(photo, refs, canvas)
    relief = (photo.astype(np.uint16).sum(axis=2) * 80).astype(np.uint16)  # an extra map
    files["relief"] = resolve_continuous(relief[:, :, None], refs, canvas)

    # the references through a reader, as a caller keeping them on disk gives them
    windows = list(
        material_in_windows(
            source,
            lambda rows, cols: refs[np.ix_(rows, cols)],
            canvas,
            window=WINDOW,
            halo=MATERIAL_HALO,
            texture_source=photo,
            extras={"relief": relief},
        )
    )
    height_range = HeightRange()
    for maps in windows:
        height_range = height_range.add(maps.material.height)
    pieces = {}
    for maps in windows:
        encoded = encoded_window(maps.material, height_range)
        encoded["texture"], encoded["relief"] = maps.texture, maps.extras["relief"]
        for name, pixels in encoded.items():
            if pixels is not None:
                pieces.setdefault(name, np.zeros(files[name].shape, files[name].dtype))[maps.target] = pixels
    return whole, files, height_range, pieces, len(windows)


def test_every_map_made_in_windows_matches_the_whole_output(whole_and_windowed):
    whole, files, height_range, pieces, n_windows = whole_and_windowed
    assert n_windows == (SIZE // WINDOW) ** 2
    assert set(pieces) == {name for name, pixels in files.items() if pixels is not None}
    # the displacement's range is the whole output's (only it is normalised over the output)
    assert height_range.low == pytest.approx(float(whole.height.min()), abs=1e-4 * whole.depth)
    assert height_range.high == pytest.approx(float(whole.height.max()), abs=1e-4 * whole.depth)
    assert height_range.depth == pytest.approx(whole.depth, rel=1e-4)
    assert height_range.midlevel == pytest.approx(whole.midlevel, abs=1e-4)
    # 8-bit maps within a last bit, the 16-bit displacement within a few, everywhere: the
    # windows' borders and the torus' edges (the outermost rows and columns) included
    for name, expected in files.items():
        if expected is None:
            continue
        diff = np.abs(pieces[name].astype(np.int64) - expected.astype(np.int64))
        # (measured: 1 LSB at most; 2.7 % of the displacement's pixels and 0.001 % of the 8-bit
        # maps' off by one, the whole solve's and the windows' rounding)
        limit, share = (2, 0.05) if name == "displacement" else (1, 0.01)
        assert diff.max() <= limit, (name, int(diff.max()))
        assert diff.mean() < share, (name, float(diff.mean()))
        edges = np.concatenate([diff[:2].ravel(), diff[-2:].ravel(), diff[:, :2].ravel(), diff[:, -2:].ravel()])
        assert edges.max() <= limit, name


def test_a_short_halo_leaves_the_displacement_off_near_the_core_borders(whole_and_windowed):
    """What the halo buys: with a tenth of it the height's solve is cut short."""
    from barkgen.material import MaterialOptions, make_material

    whole = whole_and_windowed[0]
    photo = bark_exemplar("fir_scaly_01", 128)
    source = make_material(photo, MaterialOptions(exemplar_wrap="no"))
    canvas = Canvas((SIZE, SIZE), tile=True, exemplar_wrap=(False, False))
    heights = np.zeros(whole.shape, np.float32)
    for maps in material_in_windows(
        source, shuffled_blocks((SIZE, SIZE), 128, BLOCK, seed=0), canvas, window=WINDOW, halo=MATERIAL_HALO // 10
    ):
        heights[maps.target] = maps.material.height
    assert np.abs(heights - whole.height).max() / whole.depth * 65535 > 4


def test_the_windows_cover_the_output_once_round_the_torus_or_clipped():
    tiled = resolve_windows((300, 200), 128, 16, tile=True)
    assert len(tiled) == 3 * 2
    cover = np.zeros((300, 200), int)
    for win in tiled:
        cover[win.target] += 1
        assert np.array_equal(win.rows[win.core[0]], np.arange(300)[win.target[0]])
        assert win.shape == (
            win.target[0].stop - win.target[0].start + 32,
            win.target[1].stop - win.target[1].start + 32,
        )
    assert (cover == 1).all()
    assert tiled[0].rows[0] == 300 - 16 and tiled[-1].cols[-1] == 15  # read round the torus
    clipped = resolve_windows((300, 200), 128, 16, tile=False)
    assert clipped[0].rows[0] == 0 and clipped[0].core[0] == slice(0, 128)
    assert clipped[-1].rows[-1] == 299 and clipped[-1].cols[-1] == 199
    assert clipped[-1].inner(8) == (slice(8, 300 - 256 + 16), slice(8, 200 - 128 + 16))


def test_a_reference_reader_gives_the_rectangle_asked_for():
    refs = np.arange(6 * 5 * 2).reshape(6, 5, 2)
    rows, cols = np.array([5, 0, 1]), np.array([4, 0])
    expected = refs[np.ix_(rows, cols)]
    assert np.array_equal(read_references(refs, rows, cols), expected)
    assert np.array_equal(read_references(lambda r, c: refs[np.ix_(r, c)], rows, cols), expected)
    with pytest.raises(InvalidInputError, match="block"):
        read_references(lambda r, c: refs[: r.size], rows, cols)
    with pytest.raises(InvalidInputError, match="flow"):
        next(material_in_windows(None, refs, Canvas((6, 5), exemplar_wrap=(False, False), flow=np.zeros((6, 5)))))


def test_the_seam_blend_in_windows_is_the_whole_blend(whole_and_windowed):
    """The texture stage's colour blended core by core (what a windowed run does) is the whole
    blend's within a last bit, at the windows' borders and round the torus; and it blends."""
    from barkgen.synth import apply_references, blend_seams_in_windows

    files = whole_and_windowed[1]
    photo = bark_exemplar("fir_scaly_01", 128)
    refs = shuffled_blocks((SIZE, SIZE), photo.shape[0], BLOCK, seed=0)
    canvas = Canvas((SIZE, SIZE), tile=True, exemplar_wrap=(False, False))
    windowed = blend_seams_in_windows(photo, refs, canvas, WINDOW)
    assert windowed.dtype == files["texture"].dtype and windowed.shape == files["texture"].shape
    diff = np.abs(windowed.astype(np.int64) - files["texture"])
    assert diff.max() <= 1 and diff.mean() < 0.01, (int(diff.max()), float(diff.mean()))
    assert (windowed != apply_references(refs, photo)).mean() > 0.01  # the seams were blended
