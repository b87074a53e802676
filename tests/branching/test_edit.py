"""Editing a branching structure by hand and rectifying a photo first (sibbing2010 §6, Fig. 8):
extend a branch to a click, add a furcation, delete a sub-tree, find the branch under a click,
and warp a plane seen at an angle back to a rectangle."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from conftest import crack_photo

from barkgen.branching import (
    Branch,
    Structure,
    add_furcation,
    delete_branch,
    extend_branch,
    fit_model,
    nearest_branch,
    rectify_perspective,
    resample_polyline,
    turning_angles,
)
from barkgen.errors import InvalidInputError

STEP = 2.0


def _line(a, b, r: float = 1.5) -> np.ndarray:
    return resample_polyline(np.array([[*a, r], [*b, r]], float), STEP)


def _tree() -> Structure:
    """0: a horizontal trunk; 1: a child of 0 going up; 2: a child of 1 going right; 3: a free
    branch that ends on 1 (a merge); 4: a child of 0 going down."""
    trunk = _line((10, 60), (110, 60), 2.0)
    up = _line((40, 60), (40, 10))
    right = _line((40, 30), (90, 30), 1.0)
    free = _line((10, 20), (38, 20), 1.0)
    down = _line((80, 60), (80, 95))
    return Structure(
        STEP,
        (120, 100),
        [
            Branch(trunk, None, None),
            Branch(up, 0, 15),
            Branch(right, 1, 15),
            Branch(free, None, None, 1, 20),
            Branch(down, 0, 35),
        ],
    )


def _same(a: Structure, b: Structure) -> bool:
    return a.to_dict() == b.to_dict()


def _round_trip(s: Structure) -> Structure:
    back = Structure.from_dict(s.to_dict())
    assert _same(back, s)
    return back


def test_nearest_branch_measures_to_the_skeleton_not_only_its_vertices():
    s = _tree()
    assert nearest_branch(s, (70, 61.5)) == (0, pytest.approx(1.5))
    index, distance = nearest_branch(s, (41, 45))
    assert index == 1 and distance == pytest.approx(1.0)
    assert nearest_branch(s, (80, 90))[0] == 4
    with pytest.raises(InvalidInputError, match="two finite numbers"):
        nearest_branch(s, (1, float("nan")))


def test_extension_reaches_the_point_smoothly_and_keeps_the_other_end():
    s = _tree()
    before = copy.deepcopy(s.to_dict())
    out = extend_branch(s, 0, (115, 90))  # the trunk's end (110, 60) runs on, bending down
    assert s.to_dict() == before  # the input is never changed
    old, new = s.branches[0], out.branches[0]
    assert len(new.points) > len(old.points)
    np.testing.assert_array_equal(new.points[: len(old.points)], old.points)  # the other end, every vertex kept
    np.testing.assert_allclose(new.xy[-1], (115, 90), atol=1e-9)  # reaches the click
    added = new.points[len(old.points) - 1 :]
    spacing = np.hypot(*np.diff(added[:, :2], axis=0).T)
    assert np.all(spacing[:-1] == pytest.approx(STEP, rel=0.05)) and spacing[-1] <= STEP + 1e-6
    assert np.all(added[:, 2] == old.points[-1, 2])  # thickness carried from the end
    # smooth: it leaves along the trunk (no kink at the old end) and bends gradually
    turns = np.degrees(np.abs(turning_angles(new.xy[len(old.points) - 3 :])))
    assert turns.max() < 15, turns
    # links into the branch are untouched; the rest of the structure too
    assert [(b.parent, b.parent_vertex) for b in out.branches] == [(b.parent, b.parent_vertex) for b in s.branches]
    _round_trip(out)


def test_extending_a_start_moves_the_links_into_the_branch_and_ends_its_furcation():
    s = _tree()
    out = extend_branch(s, 1, (40, 75), end="start")  # branch 1 starts on the trunk at (40, 60)
    b = out.branches[1]
    np.testing.assert_allclose(b.xy[0], (40, 75))
    np.testing.assert_array_equal(b.points[-len(s.branches[1].points) :], s.branches[1].points)  # its end kept
    assert b.parent is None and b.parent_vertex is None  # no longer on its parent
    # branch 2 (a child of 1) and branch 3 (merging into 1) still meet 1 at the same places
    for j, vertex in ((2, "parent_vertex"), (3, "join_vertex")):
        xy_before = s.branches[1].xy[getattr(s.branches[j], vertex)]
        xy_after = out.branches[1].xy[getattr(out.branches[j], vertex)]
        np.testing.assert_allclose(xy_after, xy_before)
    # the end nearer the click by default; an extended end is no merge any more
    merged = extend_branch(s, 3, (5, 5))
    assert merged.branches[3].joins == 1  # its start was extended: its merge stays
    np.testing.assert_allclose(merged.branches[3].xy[0], (5, 5))
    unmerged = extend_branch(s, 3, (30, 5), end="end")
    assert unmerged.branches[3].joins is None and unmerged.branches[3].join_vertex is None
    _round_trip(unmerged)


@pytest.mark.parametrize(
    "index, point, kwargs, message",
    [
        (7, (50, 50), {}, "branch 7 is not in the structure"),
        (True, (50, 50), {}, "integer"),
        (0, (500, 50), {}, "outside the 120x100 px image"),
        (0, (110.5, 60), {}, "within one step"),
        (0, (50, 50), {"end": "middle"}, "end must be"),
    ],
)
def test_bad_extensions_are_one_line(index, point, kwargs, message):
    with pytest.raises(InvalidInputError, match=message) as info:
        extend_branch(_tree(), index, point, **kwargs)
    assert "\n" not in str(info.value)


def test_a_furcation_is_recorded_and_starts_on_its_parent():
    s = _tree()
    out = add_furcation(s, 0, (61, 62), (60, 90))
    assert len(out.branches) == len(s.branches) + 1 and len(s.branches) == 5
    child = out.branches[-1]
    parent = out.branches[0]
    assert child.parent == 0
    assert child.parent_vertex == int(np.argmin(np.hypot(*(parent.xy - (61, 62)).T)))
    np.testing.assert_allclose(child.xy[0], parent.xy[child.parent_vertex])  # starts on the parent
    np.testing.assert_allclose(child.xy[-1], (60, 90))
    assert np.all(child.thickness == parent.thickness[child.parent_vertex])
    assert out.junctions() == s.junctions() + 1
    back = _round_trip(out)
    assert back.branches[-1].parent == 0 and back.branches[-1].parent_vertex == child.parent_vertex
    thin = add_furcation(s, 1, (40, 40), (10, 45), thickness=0.5)
    assert np.all(thin.branches[-1].thickness == 0.5) and thin.branches[-1].parent == 1
    with pytest.raises(InvalidInputError, match="shorter than one step"):
        add_furcation(s, 0, (60, 60), (60.5, 60.5))
    with pytest.raises(InvalidInputError, match="thickness"):
        add_furcation(s, 0, (60, 60), (60, 90), thickness=-1)


def test_delete_removes_the_sub_tree_and_keeps_the_rest_linked():
    s = _tree()
    out = delete_branch(s, 1)  # 1 and its child 2 go; 3 merged into 1: its end is free now
    assert len(out.branches) == 3
    np.testing.assert_array_equal(out.branches[0].points, s.branches[0].points)
    np.testing.assert_array_equal(out.branches[1].points, s.branches[3].points)
    np.testing.assert_array_equal(out.branches[2].points, s.branches[4].points)
    assert out.branches[1].joins is None and out.branches[1].join_vertex is None
    assert (out.branches[2].parent, out.branches[2].parent_vertex) == (0, 35)  # renumbered link
    out.validate()
    _round_trip(out)
    assert len(s.branches) == 5  # unchanged
    # a leaf: only itself; the trunk: every branch hanging off it, recursively
    assert len(delete_branch(s, 2).branches) == 4
    only = delete_branch(s, 0)
    assert len(only.branches) == 1 and only.branches[0].joins is None
    np.testing.assert_array_equal(only.branches[0].points, s.branches[3].points)
    with pytest.raises(InvalidInputError, match="would delete every branch"):
        delete_branch(only, 0)


def test_edits_of_a_photos_network_change_what_the_model_learns():
    """A photo-like crack network (conftest's drawn mud): deleting the trunk's sub-trees leaves fewer branches
    and furcations for the model (§4) to learn; a furcation adds one; each still validates."""
    from barkgen.branching import extract_structure

    source = extract_structure(crack_photo(256, 0))
    pruned = source
    while len(pruned.branches) > 3:
        pruned = delete_branch(pruned, len(pruned.branches) - 1)
    before, after = fit_model(source).meta, fit_model(_round_trip(pruned)).meta
    assert after["branches"] == 3 < before["branches"]
    assert after["source_length"] < before["source_length"]
    forked = add_furcation(pruned, 0, pruned.branches[0].xy[len(pruned.branches[0].points) // 2], (128, 128))
    assert fit_model(forked).meta["furcations"] >= fit_model(pruned).meta["furcations"]


# --------------------------------------------------------------------------- rectification

CELL = 24
CELLS = 8


def _checkerboard() -> np.ndarray:
    y, x = np.mgrid[0 : CELL * CELLS, 0 : CELL * CELLS]
    board = ((x // CELL + y // CELL) % 2 * 200 + 28).astype(np.uint8)
    return np.stack([board, board, board], -1)


def _photographed(board: np.ndarray):
    """The board as a photo taken at an angle: warped by a known homography into a larger
    frame; the board's corners (pixel centres) in the photo."""
    import cv2

    side = CELL * CELLS
    plane = np.array([[0, 0], [side - 1, 0], [side - 1, side - 1], [0, side - 1]], np.float32)
    seen = np.array([[40, 30], [250, 62], [236, 268], [52, 230]], np.float32)  # a tilted, foreshortened square
    matrix = cv2.getPerspectiveTransform(plane, seen)
    photo = cv2.warpPerspective(board, matrix, (300, 300), flags=cv2.INTER_LINEAR, borderValue=(90, 120, 60))
    return photo, seen


def _edges(line: np.ndarray) -> np.ndarray:
    """Sub-pixel positions where a row of the board crosses mid-grey."""
    v = line.astype(float) - 128
    above = v >= 0
    i = np.nonzero(above[:-1] != above[1:])[0]
    return i + v[i] / (v[i] - v[i + 1])


def _cell_lines(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the vertical boundaries cross every cell row's middle, and the horizontal ones
    every cell column's middle: (rows, boundaries) arrays, in the output's pixels."""
    grey = image[..., 0]
    h, w = grey.shape
    rows = [_edges(grey[int((j + 0.5) * h / CELLS)]) for j in range(CELLS)]
    cols = [_edges(grey[:, int((j + 0.5) * w / CELLS)]) for j in range(CELLS)]
    assert all(len(r) == CELLS - 1 for r in rows + cols), [len(r) for r in rows + cols]
    return np.array(rows), np.array(cols)


def test_rectification_recovers_straight_square_cells():
    board = _checkerboard()
    photo, corners = _photographed(board)
    # rectified at the board's size: every boundary back where it was, straight, within 0.6 px
    side = CELL * CELLS
    out = rectify_perspective(photo, corners, size=(side, side))
    assert out.shape == board.shape and out.dtype == np.uint8
    rows, cols = _cell_lines(out)
    truth = np.arange(1, CELLS) * CELL - 0.5  # between pixel CELL*k - 1 and CELL*k
    assert np.abs(rows - truth).max() < 0.6 and np.abs(cols - truth).max() < 0.6, (rows, cols)
    assert np.ptp(rows, axis=0).max() < 0.6 and np.ptp(cols, axis=0).max() < 0.6  # straight
    inner = np.abs(out[4:-4, 4:-4].astype(int) - board[4:-4, 4:-4].astype(int))
    assert np.mean(inner) < 6  # the same board, up to resampling at the cell edges
    # the default size: the quad's mean side lengths; the cells come out square within 8 %
    auto = rectify_perspective(photo, corners)
    h, w = auto.shape[:2]
    assert abs(w / h - 1) < 0.08, (w, h)
    rows, cols = _cell_lines(auto)
    cell_w, cell_h = np.diff(rows, axis=1).mean(), np.diff(cols, axis=1).mean()
    assert abs(cell_w / cell_h - 1) < 0.08 and np.ptp(rows, axis=0).max() < 1.0
    # corners clicked the other way round give the same, unmirrored result; grey images work
    back = rectify_perspective(photo, corners[[0, 3, 2, 1]], size=(side, side))
    np.testing.assert_array_equal(back, out)
    grey = rectify_perspective(photo[..., 0], corners, size=(side, side))
    assert grey.shape == (side, side)
    np.testing.assert_array_equal(grey, out[..., 0])
    floats = rectify_perspective(photo.astype(np.float64) / 255, corners, size=(side, side))
    assert floats.dtype == np.float64 and np.abs(floats * 255 - out).max() < 1.5


@pytest.mark.parametrize(
    "corners, message",
    [
        ([[10, 10], [90, 10], [90, 90]], "four"),
        ([[10, 10], [90, 10], [90, 90], [10, float("inf")]], "four"),
        ([[10, 10], [90, 10], [90, 90], [90, 90]], "distinct"),
        ([[10, 10], [90, 90], [90, 10], [10, 90]], "convex"),  # a bow tie: the order crosses
        ([[10, 10], [90, 10], [30, 30], [10, 90]], "convex"),  # one corner inside the others
        ([[2, 10], [50, 9], [98, 10], [50, 13]], "degenerate"),  # a sliver
        ([[10, 10], [190, 10], [90, 90], [10, 90]], "corner 2 .* outside the 100x100 px image"),
        ([[-1, 10], [90, 10], [90, 90], [10, 90]], "corner 1"),
        ("four corners", "four"),
    ],
)
def test_bad_corners_are_one_line(corners, message):
    photo = np.zeros((100, 100, 3), np.uint8)
    with pytest.raises(InvalidInputError, match=message) as info:
        rectify_perspective(photo, corners)
    assert "\n" not in str(info.value)


def test_bad_sizes_and_images_are_one_line():
    photo = np.zeros((100, 100, 3), np.uint8)
    quad = [[10, 10], [90, 10], [90, 90], [10, 90]]
    for size in ((0, 10), (10,), (10.5, 10), (True, 10), (100000, 10)):
        with pytest.raises(InvalidInputError, match="size"):
            rectify_perspective(photo, quad, size=size)
    with pytest.raises(InvalidInputError, match="image"):
        rectify_perspective(np.zeros((100, 100, 6), np.uint8), quad)
    with pytest.raises(InvalidInputError, match="dtype"):
        rectify_perspective(np.zeros((100, 100), bool), quad)
    assert rectify_perspective(photo, quad).shape == (80, 80, 3)


def test_generate_learns_from_a_given_network_of_the_photos_size_only():
    """``analyze_photo(..., cracks=)``, then ``generate(..., analysis=)``: the crack model learns
    from the structure given (the report says so); a structure with another variant or of
    another size is refused in one line."""
    from barkgen.pipeline import GenerateOptions, analyze_photo, generate

    photo = crack_photo(256, 0)
    options = GenerateOptions(structure="cracks", size=(64, 64), seed=2)
    source = _tree()  # 120 x 100: not this photo's size
    with pytest.raises(InvalidInputError, match="120x100 px image but the photo is 256x256"):
        analyze_photo(photo, options, cracks=source)
    mine = Structure(STEP, (256, 256), _tree().branches)
    with pytest.raises(InvalidInputError, match="structure='cracks' only"):
        analyze_photo(photo, GenerateOptions(size=(64, 64)), cracks=mine)
    result = generate(photo, options, analysis=analyze_photo(photo, options, cracks=mine))
    assert result.report["crack_model"]["branches"] == 5 and result.report["crack_model"]["furcations"] == 3
    assert result.cracks is not None
