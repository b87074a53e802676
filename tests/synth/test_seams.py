"""Seamless at 1:1 (:mod:`barkgen.synth.seams`): pieces across a wrapping exemplar's edge,
graph-cut seams that do not run straight, copy-size pieces round a tiled output, expansion
moves, and material maps without cliffs, measured with :mod:`barkgen.evaluate` where it says
what a user sees (the exemplar's edges themselves: ``test_edges.py``)."""

from __future__ import annotations

import cv2
import numpy as np

from barkgen import Canvas, evaluate
from barkgen.material import Boundary
from barkgen.synth import SynthesisConfig, exemplar_wraps, synthesize
from barkgen.synth.seams.cuts import cut_straight_seams
from barkgen.synth.seams.gradient import resolve_continuous


def longest(references, exemplar_shape, *, tile, wrap):
    """The longest straight seam (px) between copied pieces, the references continuing across
    the photo's edges when it wraps."""
    exemplar_wrap = tuple(exemplar_shape) if any(wrap) else None
    return evaluate.longest_seam(references, tile=tile, exemplar_wrap=exemplar_wrap)


def test_pieces_run_across_a_wrapping_exemplars_edge(sample256):
    """On the torus a piece crosses the exemplar's edge; measured with the references continuing
    across it (``exemplar_wrap``), the output of a tiling exemplar has no long straight seam, while the same
    exemplar used as a rectangle must end every piece at its edge."""
    res = synthesize(sample256, 512, tile=True, seed=1)
    assert res.exemplar_wrap == (True, True)
    y, x = res.references[..., 0], res.references[..., 1]
    crossing = np.mean((y[1:] == 0) & (y[:-1] == 255) & (x[1:] == x[:-1]))
    assert crossing > 0  # output neighbours that continue one piece across the exemplar's edge
    assert longest(res.references, res.exemplar_shape, tile=True, wrap=(True, True)) <= 48
    flat = synthesize(sample256, 512, tile=True, seed=1, exemplar_wrap="no")
    assert flat.exemplar_wrap == (False, False)
    fy, fx = flat.references[..., 0], flat.references[..., 1]
    assert not np.any((fy[1:] == 0) & (fy[:-1] == 255) & (fx[1:] == fx[:-1]))


# ------------------------------------------------------------------------------------------
# seams that do not run straight


def test_no_long_straight_seam_in_a_small_tiled_case(sample256):
    """256 px sample -> 512 px tiled: today's engine left 85 / 112 px straight seams (seeds 0 /
    1); the graph cuts and the torus bring them under 48 px."""
    for seed in (0, 1):
        res = synthesize(sample256, 512, tile=True, seed=seed)
        assert longest(res.references, res.exemplar_shape, tile=True, wrap=res.exemplar_wrap) <= 48


def test_a_straight_seam_is_recut_along_the_texture(photo_like):
    """Two pieces meeting on a straight line between rows 31 and 32: the cut moves the border
    onto a path of lower seam cost, every pixel keeps a reference of one of the two pieces, and
    the straight run is broken."""
    ex = photo_like(2, (128, 128)).astype(np.float32)
    refs = np.zeros((64, 96, 2), np.int32)
    yy, xx = np.mgrid[0:64, 0:96]
    refs[..., 0] = np.where(yy < 32, yy + 10, yy + 50)
    refs[..., 1] = xx + 5
    out = cut_straight_seams(refs, ex, Canvas(refs.shape[:2], tile=False))
    assert out.shape == refs.shape and out.dtype == np.int32
    piece_a = (out[..., 0] == yy + 10) & (out[..., 1] == xx + 5)
    piece_b = (out[..., 0] == yy + 50) & (out[..., 1] == xx + 5)
    assert np.all(piece_a | piece_b)
    assert not np.array_equal(out, refs)
    border_rows = [np.flatnonzero(piece_b[:, x])[0] for x in range(96)]
    assert len(set(border_rows)) > 3  # the border no longer runs along one row

    def cost(r):
        a = ex[r[..., 0], r[..., 1]]
        same = r[1:, :, 0] == r[:-1, :, 0] + 1
        return float(np.linalg.norm(a[1:] - a[:-1], axis=-1)[~same].sum())

    assert cost(out) <= cost(refs)


def test_a_seam_on_a_flat_stretch_meanders_instead_of_staying_straight():
    """Two pieces whose difference is the same everywhere (a ramp shifted by 40 rows): every
    border costs the same per unit of length, so a plain minimum cut keeps the shortest one, the
    straight line; the second pass, pulled towards a random meander, breaks it into short runs."""
    ramp = np.repeat(np.linspace(0, 10, 256, dtype=np.float32)[:, None, None], 256, axis=1)
    refs = np.zeros((64, 192, 2), np.int32)
    yy, xx = np.mgrid[0:64, 0:192]
    refs[..., 0] = np.where(yy < 32, yy + 40, yy + 80)
    refs[..., 1] = xx + 20

    def longest_row_run(r):
        step = ~((r[1:, :, 0] == r[:-1, :, 0] + 1) & (r[1:, :, 1] == r[:-1, :, 1]))
        best = 0
        for row in step:
            edges = np.diff(np.concatenate([[0], row.astype(np.int8), [0]]))
            starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
            best = max(best, int((ends - starts).max(initial=0)))
        return best

    plain = cut_straight_seams(refs, ramp, Canvas(refs.shape[:2], tile=False, exemplar_wrap=(False, True)))
    assert longest_row_run(plain) == 192
    out = cut_straight_seams(
        refs, ramp, Canvas(refs.shape[:2], tile=False, exemplar_wrap=(False, True)), rng=np.random.default_rng(0)
    )
    piece_a = (out[..., 0] == yy + 40) & (out[..., 1] == xx + 20)
    piece_b = (out[..., 0] == yy + 80) & (out[..., 1] == xx + 20)
    assert np.all(piece_a | piece_b)
    assert longest_row_run(out) < 24
    assert np.array_equal(
        out,
        cut_straight_seams(
            refs, ramp, Canvas(refs.shape[:2], tile=False, exemplar_wrap=(False, True)), rng=np.random.default_rng(0)
        ),
    )


def test_a_seam_stuck_at_the_exemplar_border_is_given_to_the_solver():
    """A straight seam where the upper piece ends on the exemplar's last row and the lower one
    starts on its first (the fir crop's 69 px seam, between columns there): no cut can move it,
    as neither piece continues past the border; the lower piece's offset is forbidden on the
    rows below it, so the next iterations put other pieces there. A seam of the same length
    that a cut can move is left to the cut."""
    from types import SimpleNamespace

    from barkgen.synth.seams.pieces import UNSTICK_DEPTH, offset_codes, unstick_border_seams

    eh, ew, H, W = 80, 120, 64, 96
    cy, cx = np.divmod(np.arange(eh * ew, dtype=np.int32), np.int32(ew))
    level = SimpleNamespace(
        coords_y=cy, coords_x=cx, height=eh, width=ew, wrap=(False, False), grid=(cy, cx, eh, ew, False, False)
    )
    yy, xx = np.mgrid[0:H, 0:W]
    stuck_rows = np.where(yy < 32, yy + (eh - 32), yy - 32)  # rows 48..79, then rows 0..31
    for transposed in (False, True):
        if not transposed:
            ry, rx = stuck_rows, xx + 10
        else:  # the same seam between columns 31 and 32 of a 64 x 64 output
            yy_t, xx_t = np.mgrid[0:H, 0:64]
            ry, rx = yy_t + 5, np.where(xx_t < 32, xx_t + (ew - 32), xx_t - 32)
        refs = np.ascontiguousarray(ry * ew + rx, dtype=np.int32)
        coords = np.stack([ry, rx], axis=-1).astype(np.int32)
        assert np.array_equal(
            cut_straight_seams(coords, np.zeros((eh, ew, 3), np.float32), Canvas(coords.shape[:2], tile=False)), coords
        )  # the cut cannot move it
        forbid = np.full(refs.shape, -1, np.int64)
        assert unstick_border_seams(refs, SimpleNamespace(analysis=level, tile=False), forbid, 24) == 1
        band = (
            (slice(32, 32 + UNSTICK_DEPTH), slice(None))
            if not transposed
            else (slice(None), slice(32, 32 + UNSTICK_DEPTH))
        )
        ys, xs = np.mgrid[0 : refs.shape[0], 0 : refs.shape[1]]
        want = offset_codes(ry - ys, rx - xs)
        assert np.array_equal(forbid[band], want[band])  # the lower piece, on its first rows
        forbid[band] = -1
        assert (forbid == -1).all()  # nothing else
    # a seam whose lower piece can continue upwards is the cut's: nothing forbidden
    movable = np.where(yy < 32, yy + (eh - 32), yy - 20)
    refs = np.ascontiguousarray(movable * ew + xx + 10, dtype=np.int32)
    forbid = np.full(refs.shape, -1, np.int64)
    assert (
        unstick_border_seams(refs, SimpleNamespace(analysis=level, tile=False), forbid, 24) == 0
        and (forbid == -1).all()
    )
    # along an axis that wraps there is no border to be stuck at
    level.wrap = (True, False)
    refs = np.ascontiguousarray(stuck_rows * ew + xx + 10, dtype=np.int32)
    assert unstick_border_seams(refs, SimpleNamespace(analysis=level, tile=False), forbid, 24) == 0


def test_the_copy_size_control_cuts_a_piece_along_meandering_lines():
    """A piece larger than the copy limit gets its offset forbidden on a cross through its centre;
    the cross's lines meander (straight, they would leave two straight seams that the seam cuts
    close again, joining the piece), reproducibly from the generator."""
    from types import SimpleNamespace

    from barkgen.synth.seams.pieces import limit_copies

    eh = ew = 160
    cy, cx = np.divmod(np.arange(eh * ew, dtype=np.int32), np.int32(ew))
    level = SimpleNamespace(
        coords_y=cy, coords_x=cx, height=eh, width=ew, wrap=(False, False), grid=(cy, cx, eh, ew, False, False)
    )
    yy, xx = np.mgrid[0:128, 0:128]
    refs = np.ascontiguousarray((yy + 10) * ew + xx + 10, dtype=np.int32)  # one 128 x 128 piece

    def solver_level(seed):  # the solver's level as limit_copies reads it: a limit of 0.2
        config = SimpleNamespace(max_copy=0.2)
        return SimpleNamespace(analysis=level, config=config, tile=False, rng=np.random.default_rng(seed))

    def forbidden(seed):
        forbid = np.full(refs.shape, -1, np.int64)
        assert limit_copies(refs, solver_level(seed), forbid) == 1
        return forbid >= 0

    band = forbidden(0)
    assert 0.02 < band.mean() < 0.08  # two lines about 3 px wide
    # the horizontal line's rows, column by column, away from the vertical line
    cols = [x for x in range(128) if band[:, x].sum() <= 5]
    rows = np.array([np.flatnonzero(band[:, x]).mean() for x in cols])
    assert rows.max() - rows.min() > 6  # it swings
    assert np.abs(np.diff(rows)).max() <= 2  # and stays one connected line
    assert np.array_equal(band, forbidden(0)) and not np.array_equal(band, forbidden(1))


def test_a_piece_round_a_tiled_output_is_one_piece():
    """Copy-size control: a strip of the exemplar that runs round a tiled output is one piece
    (its offset changes where it wraps), so it is cut like any other large piece."""
    from barkgen.synth.seams import _kernels as K

    H, W, eh, ew = 64, 32, 80, 40
    yy, xx = np.mgrid[0:H, 0:W]
    ry = (yy + 30) % H  # rows 0..33 come from exemplar rows 30..63, rows 34.. from 0..29
    refs = (ry * ew + xx).astype(np.int32)
    cy, cx = np.divmod(np.arange(eh * ew, dtype=np.int32), np.int32(ew))
    labels = np.empty((H, W), np.int32)
    # on an 80-row exemplar, rows 63 -> 0 do not continue: not tiled, two pieces; tiled, the
    # output's last row continues into its first, and the strip round the torus is one piece
    assert sorted(K.label_pieces((refs, False), (cy, cx, eh, ew, False, False), labels)) == [30 * W, 34 * W]
    assert K.label_pieces((refs, True), (cy, cx, eh, ew, False, False), labels).tolist() == [H * W]
    # on a 64-row exemplar that wraps, rows 63 -> 0 continue: one piece either way
    cy2, cx2 = np.divmod(np.arange(64 * ew, dtype=np.int32), np.int32(ew))
    assert K.label_pieces((refs, False), (cy2, cx2, 64, ew, True, False), labels).tolist() == [H * W]


def test_same_bytes_on_one_or_two_threads(sample256):
    one = synthesize(sample256, 192, tile=True, seed=3, config=SynthesisConfig(threads=1))
    two = synthesize(sample256, 192, tile=True, seed=3, config=SynthesisConfig(threads=2))
    assert np.array_equal(one.references, two.references)


# ------------------------------------------------------------------------------------------
# material maps without cliffs


def test_a_continuous_map_has_no_cliff_where_pieces_meet():
    """Two pieces of a smooth ramp meet at different heights: copied, the border is a cliff;
    through the gradient domain it is an ordinary step, inside the pieces the slope is the
    exemplar's, and a tiled output still tiles."""
    h = np.add.outer(np.arange(64.0), np.zeros(64)).astype(np.float32)  # height = row
    yy, xx = np.mgrid[0:48, 0:48]
    refs = np.stack([np.where(xx < 24, yy, yy + 16), xx], -1).astype(np.int32)
    plain = h[refs[..., 0], refs[..., 1]]
    assert np.abs(np.diff(plain, axis=1)).max() == 16  # the cliff
    for tile in (False, True):
        u = resolve_continuous(h, refs, Canvas(refs.shape[:2], tile=tile))
        assert u.dtype == np.float32 and u.shape == (48, 48)
        assert np.abs(np.diff(u, axis=1)).max() < 2.0
        if not tile:  # (on a torus a ramp cannot close: its mean slope is 0 there)
            assert np.allclose(np.diff(u, axis=0)[5:40, 5:20], 1.0, atol=0.05)
    u = resolve_continuous(h, refs, Canvas(refs.shape[:2], tile=True)).astype(np.float64)
    wrap_step = np.abs(u[0] - u[-1]).mean()
    assert wrap_step < 3 * np.abs(np.diff(u, axis=0)).mean()
    # 16-bit maps stay 16-bit
    u16 = resolve_continuous((h * 1000).astype(np.uint16), refs, Canvas(refs.shape[:2], tile=False))
    assert u16.dtype == np.uint16


def test_the_screened_poisson_solve_leaves_its_inputs_alone():
    """The solve works in place on the arrays it makes itself (issue 69: a material window holds
    4 arrays of its size, not 9), never on its caller's: the plain map and the gradients are
    the same after it, on the torus and with a Neumann border."""
    from barkgen._shared.arrays import Boundary
    from barkgen.synth import screened_poisson

    rng = np.random.default_rng(5)
    plain, gy, gx = rng.random((3, 40, 30, 2))
    kept = plain.copy(), gy.copy(), gx.copy()
    for tile in (False, True):
        u = screened_poisson(plain, gy, gx, Boundary(tile), screening=1e-2)
        assert u.shape == plain.shape and np.isfinite(u).all()
        for before, after in zip(kept, (plain, gy, gx)):
            assert np.array_equal(before, after)
    # the solve does what it says: the plain map's own gradients give the plain map back
    steps_y = np.concatenate([np.diff(plain, axis=0), np.zeros((1, 30, 2))], axis=0)
    steps_x = np.concatenate([np.diff(plain, axis=1), np.zeros((40, 1, 2))], axis=1)
    np.testing.assert_allclose(screened_poisson(plain, steps_y, steps_x, Boundary(False)), plain, atol=1e-9)


def test_synthesized_material_maps_have_no_cliffs(sample256):
    """generate --tile --material: the displacement, normals, AO and roughness step across the
    borders of the copied pieces no more than 1.5x as much as inside them (measured 0.84 /
    0.99 / 0.95 / 0.99; before the maps were blended: 9.7x / 6.2x / 10.3x / 4.0x); the albedo's seams are blended as the colour's (exactly the
    references' with ``blend="none"``), normals stay unit and consistent with the height, the
    set tiles."""
    from barkgen.material import make_material, transfer_material
    from barkgen.material.materialset import derived_maps

    source = make_material(sample256)
    res = synthesize(sample256, 384, tile=True, seed=0)
    mat = transfer_material(
        source, res.references, canvas=Canvas(res.references.shape[:2], tile=True, exemplar_wrap=res.exemplar_wrap)
    )
    y, x = res.references[..., 0].astype(np.int64), res.references[..., 1].astype(np.int64)

    def step_ratio(img):
        return evaluate.border_step_ratio(
            np.asarray(img, np.float64), res.references, tile=True, exemplar_wrap=(256, 256)
        )

    for name, img in (("height", mat.height), ("normals", mat.normals), ("ao", mat.ao), ("roughness", mat.roughness)):
        ratio = step_ratio(img)
        assert ratio <= 1.5, (name, ratio)
    albedo = np.asarray(mat.color, np.float64)
    exact = transfer_material(
        source,
        res.references,
        canvas=Canvas(res.references.shape[:2], tile=True, exemplar_wrap=res.exemplar_wrap),
        blend="none",
    )
    assert np.array_equal(exact.color, source.color[y, x])
    assert step_ratio(albedo) < 0.9 * step_ratio(exact.color)
    assert np.allclose(np.linalg.norm(mat.normals, axis=-1), 1.0, atol=1e-4)
    normals, _ = derived_maps(mat.height, boundary=Boundary(True))
    assert np.allclose(normals, mat.normals)
    d = mat.displacement()
    assert np.abs(d[0] - d[-1]).mean() < 3 * np.abs(np.diff(d, axis=0)).mean()


# ------------------------------------------------------------------------------------------
# expansion moves: whole borders moved onto the texture's low-error paths


def _seam_energy(refs: np.ndarray, feat: np.ndarray) -> float:
    """Kwatra 2003's seam cost summed over neighbouring pixels of an output that does not tile
    (pieces that stay inside the exemplar): ||A(p) - B(p)|| + ||A(q) - B(q)||."""
    total = 0.0
    for axis in (0, 1):
        d = np.zeros(2, np.int32)
        d[axis] = 1
        p = refs[:-1] if axis == 0 else refs[:, :-1]
        q = refs[1:] if axis == 0 else refs[:, 1:]
        a_q = p + d  # the piece at p continued to q
        b_p = q - d  # the piece at q continued back to p
        cont = np.all(a_q == q, axis=-1)
        cost = np.linalg.norm(feat[p[..., 0], p[..., 1]] - feat[b_p[..., 0], b_p[..., 1]], axis=-1) + np.linalg.norm(
            feat[a_q[..., 0], a_q[..., 1]] - feat[q[..., 0], q[..., 1]], axis=-1
        )
        total += float(cost[~cont].sum())
    return total


def _staircase_case():
    """Two pieces of a smooth random texture meeting along a staircase of 2x2 blocks (what the
    coarse levels' up-sampling leaves), on a 64 x 64 output that does not tile."""
    from barkgen.synth.seams.expansion import exemplar_grid

    rng = np.random.default_rng(5)
    feat = cv2.GaussianBlur(rng.normal(0, 20, (160, 160, 3)).astype(np.float32), (0, 0), 3)
    yy, xx = np.mgrid[0:64, 0:64]
    upper = ((yy // 2) + (xx // 2)) < 32  # the staircase, on the 2x2 grid
    offsets = np.where(upper[..., None], np.array([12, 20]), np.array([70, 48]))
    coords = np.stack([yy, xx], -1) + offsets
    flat = np.ascontiguousarray(coords[..., 0] * 160 + coords[..., 1], dtype=np.int32)
    return feat, flat, exemplar_grid((160, 160), (False, False)), upper


def test_expansion_moves_a_staircase_border_onto_a_cheaper_path():
    """Every pixel near the border may take the other piece continued; a minimum cut per piece
    moves whole stretches at once: the seam cost falls (and never rises), every pixel keeps one
    of the two pieces, nothing farther than a band per round from the border changes, the border leaves
    the 2x2 grid, and the same input gives the same output."""
    from barkgen.synth.seams.expansion import expand_pieces

    feat, flat, grid, upper = _staircase_case()
    unguided = (np.zeros(1, np.int32), np.zeros((1, 1), np.int32))
    forbid = np.full(flat.shape, -1, np.int64)
    out = expand_pieces(flat, grid, feat, Canvas(flat.shape, tile=False), forbid, unguided, band=8, rounds=2)
    assert out.dtype == np.int32 and out.shape == flat.shape
    as_coords = lambda r: np.stack(np.divmod(r, 160), -1)  # noqa: E731
    before, after = _seam_energy(as_coords(flat), feat), _seam_energy(as_coords(out), feat)
    assert after < 0.8 * before, (before, after)
    yy, xx = np.mgrid[0:64, 0:64]
    piece_a = out == (yy + 12) * 160 + xx + 20
    piece_b = out == (yy + 70) * 160 + xx + 48
    assert np.all(piece_a | piece_b)
    changed = out != flat
    assert changed.any()
    dist = cv2.distanceTransform((~upper).astype(np.uint8), cv2.DIST_C, 3)
    dist = np.maximum(dist, cv2.distanceTransform(upper.astype(np.uint8), cv2.DIST_C, 3))
    assert dist[changed].max() <= 2 * 8  # a band per round
    # the border's corners no longer all sit on even rows and columns
    rows = np.nonzero(piece_a[:-1] != piece_a[1:])[0] + 1
    assert (rows % 2).any()
    assert np.array_equal(
        out, expand_pieces(flat, grid, feat, Canvas(flat.shape, tile=False), forbid, unguided, band=8, rounds=2)
    )
    assert np.array_equal(
        expand_pieces(flat, grid, feat, Canvas(flat.shape, tile=False), forbid, unguided, band=0, rounds=2), flat
    )


def test_the_expansion_buffers_grow_to_the_largest_piece_with_the_same_result(monkeypatch):
    """A move's graph buffers start small and double when a piece needs more (memory follows
    the largest piece, not the output): the same reference map as buffers of the output's size,
    on a tiled output of many pieces, some running round it."""
    import barkgen.synth.seams.expansion as expansion

    rng = np.random.default_rng(3)
    feat = cv2.GaussianBlur(rng.normal(0, 20, (96, 96, 3)).astype(np.float32), (0, 0), 2)
    grid = expansion.exemplar_grid((96, 96), (True, True))
    yy, xx = np.mgrid[0:80, 0:120]
    blocks = rng.integers(0, 96, (5, 6, 2))[yy // 16, xx // 20]  # 30 pieces, the edge ones wrap
    flat = np.ascontiguousarray(((yy + blocks[..., 0]) % 96) * 96 + (xx + blocks[..., 1]) % 96, dtype=np.int32)
    unguided = (np.zeros(1, np.int32), np.zeros((1, 1), np.int32))
    forbid = np.full(flat.shape, -1, np.int64)

    def expanded(first: int) -> np.ndarray:
        monkeypatch.setattr(expansion, "FIRST_NODES", first)
        return expansion.expand_pieces(
            flat, grid, feat, Canvas(flat.shape, tile=True), forbid, unguided, band=6, rounds=2
        )

    whole, grown = expanded(flat.size), expanded(8)
    assert (whole != flat).sum() > 100  # the moves did move borders
    assert np.array_equal(grown, whole)
    codes = expansion.piece_offsets(flat, grid)
    monkeypatch.setattr(expansion, "_BAND_ROWS", 7)  # the offset codes made by bands of rows
    assert np.array_equal(expansion.piece_offsets(flat, grid), codes)
    assert len(np.unique(codes)) == 30


def test_expansion_keeps_forbidden_offsets_and_labels():
    """A pixel never takes its forbidden offset (the copy-size control's cuts), and when guided a
    pixel of the wanted label never takes a wrong one."""
    from barkgen.synth.seams.expansion import expand_pieces, piece_offsets

    feat, flat, grid, upper = _staircase_case()
    unguided = (np.zeros(1, np.int32), np.zeros((1, 1), np.int32))
    free = expand_pieces(
        flat, grid, feat, Canvas(flat.shape, tile=False), np.full(flat.shape, -1, np.int64), unguided, band=8, rounds=2
    )
    codes = piece_offsets(flat, grid)
    a_code = codes[0, 0]
    # forbid the upper piece everywhere below the staircase: it can no longer grow
    forbid = np.where(upper, -1, a_code).astype(np.int64)
    out = expand_pieces(flat, grid, feat, Canvas(flat.shape, tile=False), forbid, unguided, band=8, rounds=2)
    assert not np.any(piece_offsets(out, grid)[~upper] == a_code)
    assert not np.array_equal(out, free)
    # labels: exemplar label 1 on its left half; the target wants label 1 on its left half too
    ex_labels = (np.arange(160 * 160) % 160 < 80).astype(np.int32)
    target = np.zeros((64, 64), np.int32)
    target[:, :32] = 1
    out = expand_pieces(
        flat,
        grid,
        feat,
        Canvas(flat.shape, tile=False),
        np.full(flat.shape, -1, np.int64),
        (ex_labels, target),
        band=8,
        rounds=2,
    )
    right_before = ex_labels[flat] == target
    assert np.all(ex_labels[out][right_before] == target[right_before])


def test_generated_texture_steps_little_more_across_seams_than_inside():
    """generate --tile (the joint label map, then texture-by-numbers): the label map's finest
    level is up-sampled from the level above, and its pieces' borders, on the 2x2 grid, were
    seams the texture had to follow. Moved by expansion moves onto the photo's low-error paths,
    the colour steps across the texture's seams at most 1.45x as much as inside its pieces
    (the engine before them: 1.54 / 1.56 for seeds 0 / 1; with them 1.31 / 1.40)."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image
    from barkgen.pipeline import GenerateOptions, generate

    photo = cv2.resize(read_image(sample_exemplar_path()), (512, 512), interpolation=cv2.INTER_AREA)
    for seed in (0, 1):
        res = generate(photo, GenerateOptions(size=(512, 512), tile=True, seed=seed))
        ratio = evaluate.border_step_ratio(res.texture, res.references, tile=True, exemplar_wrap=(512, 512))
        assert ratio <= 1.45, (seed, ratio)


def test_generate_leaves_no_straight_seam_where_a_piece_ends_at_the_photos_edge():
    """A photo that does not tile ends each copied piece with its own straight edge. In the
    joint label map such a border survives the coarser level's cuts and is doubled by the
    up-sampling; texture-by-numbers may not move a label border, so the texture kept it. The
    lit peeling photo, 320 px crop -> 640 px tiled: straight seams of 47 / 70 px (seeds 0 / 1)
    before the label map's finest level was cut too, 28 / 35 px after."""
    from conftest import bark_exemplar

    from barkgen.pipeline import GenerateOptions, generate

    photo = bark_exemplar("lichen_covered_01", 320)
    for seed in (0, 1):
        res = generate(photo, GenerateOptions(size=(640, 640), tile=True, seed=seed))
        wrap = tuple(res.report["exemplar_wrap"])
        assert wrap == (False, False)
        assert longest(res.references, photo.shape[:2], tile=True, wrap=wrap) <= 48, seed


# ------------------------------------------------------------------ no line in any map, no step


def longest_line(image: np.ndarray, *, tile: bool = True) -> int:
    """:func:`barkgen.evaluate.longest_line` (px) of a map, stretched to [0, 1] and rounded to
    16 bits first (as a user's file of it would be measured)."""
    img = np.asarray(image, np.float64)
    lo, hi = float(img.min()), float(img.max())
    return evaluate.longest_line(np.round((img - lo) / max(hi - lo, 1e-12) * 65535).astype(np.uint16), tile=tile)


def test_an_extra_map_whose_edges_do_not_meet_draws_no_line(sample256):
    """``synth --tile --extra height=H`` from a photo that wraps, H made from the photo taken as
    a rectangle (its own edges do not meet): H is not wrapped, so no straight line runs through
    the output's height; carried round the photo's wrap as the colour is, it draws one."""
    from barkgen.material import MaterialOptions, make_material

    assert exemplar_wraps(sample256) == (True, True)
    height = make_material(sample256, MaterialOptions(exemplar_wrap="no")).height
    res = synthesize(sample256, 384, tile=True, seed=0, extra={"height": height})
    assert res.extra_wraps == {"height": (False, False)}
    forced = resolve_continuous(
        height, res.references, Canvas(res.references.shape[:2], tile=True, exemplar_wrap=(True, True))
    )
    # (measured: the forced line 165 px, the carried height's 61 px and the wrapped one's 55 px:
    # the control must stay well above the 96 px the carried height's longest is held to)
    assert longest_line(forced) > 105
    assert longest_line(res.extras["height"]) <= 96
    # a height that wraps with the photo is wrapped with it
    wrapped = make_material(sample256).height
    again = synthesize(sample256, 384, tile=True, seed=0, extra={"height": wrapped})
    assert again.extra_wraps == {"height": (True, True)}
    assert longest_line(again.extras["height"]) <= 96


def test_no_line_in_any_map_of_a_tiled_material_set(sample256):
    """``generate --tile --material`` from a photo that wraps: no straight line
    (:func:`longest_line`, the output's own wrap included) longer than 112 px in the texture or
    any map of its set (measured: 97 px in the texture and albedo, 53-71 px in the maps; a
    height carried round a wrap it does not have draws 165 px); the photo's own maps wrap with
    it."""
    from barkgen.pipeline import GenerateOptions, generate

    result = generate(sample256, GenerateOptions(size=(384, 384), tile=True, material=True, seed=1))
    mat = result.material
    maps = {
        "texture": result.texture,
        "albedo": mat.color,
        "height": mat.height,
        "normals": mat.normals,
        "ao": mat.ao,
        "roughness": mat.roughness,
    }
    found = {name: longest_line(img) for name, img in maps.items()}
    assert max(found.values()) <= 112, found


def test_colour_steps_little_more_across_seams_on_a_lit_structured_photo():
    """The plated pine (plates parted by dark fissures, lit from one side): with the seams
    blended the colour steps no more across the borders between pieces than inside them;
    copied exactly it steps at least 1.3x as much as blended. The references are the same."""
    from conftest import bark_exemplar

    photo = bark_exemplar("pine_plated_01", 192)
    blended = synthesize(photo, 384, tile=True, seed=0)
    exact = synthesize(photo, 384, tile=True, seed=0, config=SynthesisConfig(blend="none"))
    assert np.array_equal(blended.references, exact.references)
    ratio = evaluate.border_step_ratio(blended.image, blended.references)
    before = evaluate.border_step_ratio(exact.image, exact.references)
    # measured 0.84 blended, 1.22 copied exactly (the blend leaves the part of each step the photo
    # could have taken there)
    assert ratio <= 1.0 and before >= 1.3 * ratio, (ratio, before)


def _two_pieces(photo: np.ndarray, row_shift: int, column_jump: int) -> np.ndarray:
    """The ``(32, 32, 2)`` references of two pieces of ``photo`` side by side: the left copies
    its columns 0-15, the right its columns ``16 + column_jump`` on, ``row_shift`` rows down."""
    ry, rx = np.mgrid[0:32, 0:32]
    right = rx >= 16
    ry = np.where(right, ry + row_shift, ry)
    rx = np.where(right, rx + column_jump, rx)
    return np.stack([ry, rx], axis=-1).astype(np.int32)


def test_the_colour_blend_spreads_a_large_step_over_a_few_pixels_and_keeps_the_rest():
    """Two pieces of a lit photo meet with a step of over 12x the photo's mean step: the blend
    spreads it over the few columns either side of the border, each step there under
    ``SPREAD_STEPS`` of the photo's own; every other pixel stays the photo's, and the level
    on either side of the ramp does not move."""
    from barkgen.synth import blend_seams
    from barkgen.synth.seams.gradient import SPREAD_STEPS

    rng = np.random.default_rng(3)
    columns = np.arange(64, dtype=float)[None, :, None]
    photo = np.clip(60 + 2.0 * columns + rng.normal(0, 2, (64, 64, 3)), 0, 255).astype(np.uint8)
    refs = _two_pieces(photo, 0, 24)
    copy = photo[refs[..., 0], refs[..., 1]].astype(float)
    blended = blend_seams(photo, refs, Canvas((32, 32))).astype(float)
    changed = np.flatnonzero(np.any(blended != copy, axis=(0, 2)))
    assert changed.min() >= 12 and changed.max() <= 19 and {15, 16} <= set(changed), changed
    own_step = np.linalg.norm(np.diff(photo.astype(float), axis=1), axis=-1).mean()
    steps_copied, steps_blended = (np.linalg.norm(np.diff(m, axis=1), axis=-1).mean(axis=0) for m in (copy, blended))
    # measured: 87 copied at the border, the photo's own 5.6; blended 15-16 over seven columns
    assert steps_copied[15] > 12.0 * own_step and steps_blended.max() < SPREAD_STEPS * own_step, steps_blended
    assert steps_blended[12:19].min() > 2.0 * own_step  # spread, not left at the border


def test_the_colour_blend_leaves_a_step_the_photo_could_have_taken():
    """A border whose step is off the photo's own there by less than 3/4 of that step is left as
    it is: the blend is the exact copy (here grey and 16-bit); beyond that, only the excess is
    taken out."""
    from barkgen.synth import blend_seams

    rows, columns = np.mgrid[0:64, 0:64]
    photo = (4000 + 400 * columns + 100 * rows).astype(np.uint16)  # steps 400 across, 100 down
    refs = _two_pieces(photo, 3, 0)  # the right piece 3 rows lower: 300 more than the photo's 400
    copy = photo[refs[..., 0], refs[..., 1]]
    assert np.array_equal(blend_seams(photo, refs, Canvas((32, 32))), copy)
    steeper = _two_pieces(photo, 4, 0)  # 400 more: some is beyond what the photo could take, spread
    steps = np.diff(blend_seams(photo, steeper, Canvas((32, 32))).astype(float), axis=1)
    assert np.all((steps[:, 15] >= 700) & (steps[:, 15] < 800)), steps[:, 15]  # 800 copied
    assert np.all((steps[:, [14, 16]] > 400) & (steps[:, [14, 16]] <= 450)), steps[:, [14, 16]]
    assert np.allclose(steps[:, 13:18].sum(axis=1), 2400), steps[:, 13:18]  # nothing drifts
