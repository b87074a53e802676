"""Fragment-based rendering along a branching structure (sibbing2010 §5).

Everything runs on a synthetic crack photo drawn from a known structure, so no extractor, grower
or shared data is needed.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from barkgen.branching import _render_kernels as K
from barkgen.branching.render import RenderOptions, RenderResult, _Warp, render_branches
from barkgen.branching.structure import Branch, Structure, rasterize
from barkgen.errors import InvalidInputError

SIZE = 192


def _wavy(start, angle, length, amp, waves, thick, step=2.0):
    """A gently waving polyline of ``x, y, thickness`` rows, cut where it leaves the image."""
    t = np.arange(0.0, length, step)
    u = np.stack([t, amp * np.sin(2 * np.pi * waves * t / length)], axis=1)
    c, s = math.cos(angle), math.sin(angle)
    xy = u @ np.array([[c, s], [-s, c]]) + np.asarray(start, float)
    inside = (xy >= 3).all(axis=1) & (xy <= SIZE - 4).all(axis=1)
    n = len(xy) if inside.all() else int(np.argmin(inside))
    return np.column_stack([xy[:n], np.linspace(thick, 0.75 * thick, len(t))[:n]])


def _child(parent: np.ndarray, vertex: int, angle: float, length: float, waves: float) -> np.ndarray:
    pts = _wavy(parent[vertex, :2], angle, length, 4.0, waves, 0.85 * parent[vertex, 2])
    pts[0, :2] = parent[vertex, :2]
    return pts


def _source_structure() -> Structure:
    a = _wavy((3, 50), 0.35, 240, 7.0, 1.5, 2.2)
    b = _wavy((150, 188), -2.2, 240, 6.0, 1.2, 2.0)
    branches = [
        Branch(a),
        Branch(b),
        Branch(_child(a, 20, -0.6, 90, 1.0), parent=0, parent_vertex=20),
        Branch(_child(a, 55, 1.4, 80, 0.8), parent=0, parent_vertex=55),
        Branch(_child(b, 25, -1.0, 70, 1.0), parent=1, parent_vertex=25),
    ]
    s = Structure(2.0, (SIZE, SIZE), branches)
    s.validate()
    return s


def _target_structure(size: int = SIZE) -> Structure:
    a = _wavy((3, 120), -0.3, 260, 8.0, 1.3, 2.1)
    branches = [
        Branch(a),
        Branch(_child(a, 30, 0.9, 90, 1.1), parent=0, parent_vertex=30),
        Branch(_child(a, 60, -1.3, 80, 0.9), parent=0, parent_vertex=60),
    ]
    s = Structure(2.0, (size, size), branches)
    s.validate()
    return s


def _draw(structure: Structure, seed: int = 3) -> np.ndarray:
    """A light, noisy, brownish photo with the structure's cracks drawn dark."""
    rng = np.random.default_rng(seed)
    lum = np.full((SIZE, SIZE), 165.0, np.float32)
    for sigma, amp in ((12.0, 14.0), (3.0, 9.0), (0.8, 8.0)):
        n = cv2.GaussianBlur(rng.normal(0, 1, (SIZE, SIZE)).astype(np.float32), (0, 0), sigma)
        lum += amp * n / n.std()
    mask = np.zeros((SIZE, SIZE), np.float32)
    for b in structure.branches:
        p = b.points
        for i in range(len(p) - 1):
            cv2.line(
                mask,
                tuple(int(v) for v in np.rint(p[i, :2] * 16)),
                tuple(int(v) for v in np.rint(p[i + 1, :2] * 16)),
                1.0,
                max(1, int(round(p[i, 2] + p[i + 1, 2]))),
                cv2.LINE_AA,
                shift=4,
            )
    mask = cv2.GaussianBlur(mask, (0, 0), 0.6)
    lum = lum * (1 - mask) + (40.0 + 6.0 * rng.normal(0, 1, (SIZE, SIZE))) * mask
    rgb = np.stack([lum * 1.0, lum * 0.8, lum * 0.62], axis=-1)
    return np.clip(rgb, 0, 255).astype(np.uint8)


def _skeleton(structure: Structure, shape) -> np.ndarray:
    m = np.zeros(shape, np.uint8)
    for b in structure.branches:
        pts = np.rint(b.points[:, :2] * 16).astype(np.int32)
        cv2.polylines(m, [pts], False, 1, 1, cv2.LINE_8, shift=4)
    return m.astype(bool)


def _luma(img: np.ndarray) -> np.ndarray:
    return img.astype(np.float64) @ np.array([0.299, 0.587, 0.114]) if img.ndim == 3 else img.astype(np.float64)


@pytest.fixture(scope="module")
def scene():
    source = _source_structure()
    return _draw(source), source, _target_structure()


@pytest.fixture(scope="module")
def rendered(scene) -> RenderResult:
    image, source, target = scene
    return render_branches(image, source, target, seed=0)


def test_result_fields(scene, rendered):
    image, _, target = scene
    assert rendered.image.shape == (SIZE, SIZE, 3) and rendered.image.dtype == np.uint8
    assert rendered.labels.dtype == np.uint8 and rendered.coverage.dtype == bool
    assert rendered.fragment_map.shape == (SIZE, SIZE)
    assert rendered.n_fragments > 10 and rendered.n_source_fragments > 10
    assert {"fill", "fragments", "total"} <= set(rendered.timings)
    # fragments were placed over the whole target skeleton
    assert rendered.coverage[_skeleton(target, (SIZE, SIZE))].all()


def test_labels_are_the_rasterized_target(rendered, scene):
    target = scene[2]
    np.testing.assert_array_equal(rendered.labels, rasterize(target).astype(np.uint8) * 255)
    assert set(np.unique(rendered.labels)) == {0, 255}


def test_same_seed_same_bytes_other_seed_differs(scene, rendered):
    image, source, target = scene
    again = render_branches(image, source, target, seed=0)
    assert again.image.tobytes() == rendered.image.tobytes()
    assert np.array_equal(again.fragment_map, rendered.fragment_map)
    other = render_branches(image, source, target, seed=1)
    assert other.image.tobytes() != rendered.image.tobytes()
    assert np.abs(other.image.astype(int) - rendered.image.astype(int)).mean() > 2.0


def test_cracks_are_continuous_and_dark_along_the_target(scene, rendered):
    """Luminance along the target skeleton within 15 % of the source's crack luminance, and
    far darker than the background: the cracks run unbroken along the new structure."""
    image, source, target = scene
    src_crack = _luma(image)[_skeleton(source, image.shape[:2])].mean()
    out_lum = _luma(rendered.image)
    skel = _skeleton(target, out_lum.shape)
    out_crack = out_lum[skel].mean()
    assert abs(out_crack / src_crack - 1) <= 0.15, (out_crack, src_crack)
    far = cv2.distanceTransform((rendered.labels == 0).astype(np.uint8), cv2.DIST_L2, 3) > 6
    assert out_crack < 0.5 * out_lum[far].mean()
    # continuity: no stretch of the skeleton is light (a gap in the crack)
    assert np.percentile(out_lum[skel], 98) < 0.6 * out_lum[far].mean()


def test_no_crack_is_painted_where_the_target_has_none(scene, rendered):
    out_lum = _luma(rendered.image)
    far = cv2.distanceTransform((rendered.labels == 0).astype(np.uint8), cv2.DIST_L2, 3) > 6
    src_lum = _luma(scene[0])
    threshold = 0.5 * (src_lum.mean() + src_lum[_skeleton(scene[1], src_lum.shape)].mean())
    assert (out_lum[far] < threshold).mean() < 0.005


def test_no_visible_seams(rendered):
    """Mean gradient magnitude on the fragments' boundaries, against the same distance band
    from the cracks elsewhere."""
    lum = _luma(rendered.image).astype(np.float32)
    grad = np.hypot(cv2.Sobel(lum, cv2.CV_32F, 1, 0), cv2.Sobel(lum, cv2.CV_32F, 0, 1))
    f = rendered.fragment_map
    edge = np.zeros(f.shape, bool)
    edge[:, 1:] |= f[:, 1:] != f[:, :-1]
    edge[:, :-1] |= f[:, 1:] != f[:, :-1]
    edge[1:] |= f[1:] != f[:-1]
    edge[:-1] |= f[1:] != f[:-1]
    dist = cv2.distanceTransform((rendered.labels == 0).astype(np.uint8), cv2.DIST_L2, 3)
    band = (dist > 2) & (dist < 12)
    assert (edge & band).sum() > 200
    # 1.32 on an AVX-512 machine, lower on others: numba's fastmath kernels round by the CPU
    assert grad[edge & band].mean() < 1.4 * grad[~edge & band].mean()


def test_without_fill_the_gaps_stay_black(scene):
    image, source, target = scene
    res = render_branches(image, source, target, seed=0, fill=False)
    assert (res.image[~res.coverage] == 0).all()
    assert res.coverage.mean() < 0.6 and res.coverage[_skeleton(target, (SIZE, SIZE))].all()
    assert (res.fragment_map >= 0).sum() == res.coverage.sum()


def test_grey_photo_and_other_output_size(scene):
    image, source, _ = scene
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    target = _target_structure(224)
    res = render_branches(grey, source, target, seed=0, fill=False)
    assert res.image.shape == (224, 224) and res.labels.shape == (224, 224)
    assert res.image[_skeleton(target, (224, 224))].mean() < 0.5 * grey.mean()
    # (H, W, 1) stays (H, W, 1); 16 bits are rendered like their 8-bit values
    one = render_branches(grey[:, :, None], source, target, seed=0, fill=False)
    assert one.image.shape == (224, 224, 1) and np.array_equal(one.image[:, :, 0], res.image)
    sixteen = render_branches(grey.astype(np.uint16) * 257, source, target, seed=0, fill=False)
    assert np.array_equal(sixteen.image, res.image)


def test_progress_reaches_the_end(scene):
    image, source, target = scene
    calls = []
    render_branches(image, source, target, seed=0, fill=False, progress=lambda d, t: calls.append((d, t)))
    assert calls and calls[-1][0] == calls[-1][1]
    assert all(b[0] >= a[0] for a, b in zip(calls, calls[1:]))


def test_bad_inputs_are_one_line_errors(scene):
    image, source, target = scene
    empty = Structure(2.0, (SIZE, SIZE), [])
    with pytest.raises(InvalidInputError, match="empty"):
        render_branches(image, source, empty)
    with pytest.raises(InvalidInputError, match="target structure must be a Structure"):
        render_branches(image, source, {"branches": []})
    outside = Structure(2.0, (SIZE, SIZE), [Branch(np.array([[10.0, 10, 2], [SIZE + 40.0, 50, 2]]))])
    with pytest.raises(InvalidInputError, match="outside"):
        render_branches(image, outside, target)
    with pytest.raises(InvalidInputError, match="source image is"):
        render_branches(image[:100], source, target)
    with pytest.raises(InvalidInputError, match="uint8"):
        render_branches(image.astype(np.float32), source, target)
    with pytest.raises(InvalidInputError, match=r"\(H, W\) or \(H, W, 3\)"):
        render_branches(np.dstack([image, image[:, :, :1]]), source, target)
    with pytest.raises(InvalidInputError, match="thickness"):
        render_branches(image, source, Structure(2.0, (64, 64), [Branch(np.array([[1.0, 1, 0], [9, 9, 0]]))]))
    tiny = Structure(2.0, (SIZE, SIZE), [Branch(np.array([[96.0, 96, 2], [97, 96, 2]]))])
    with pytest.raises(InvalidInputError, match="no fragment"):
        render_branches(image, Structure(2.0, (SIZE, SIZE), [Branch(np.array([[1.0, 1, 2], [2, 1, 2]]))]), tiny)
    with pytest.raises(InvalidInputError, match="lambda_spacing"):
        RenderOptions(lambda_spacing=0.0)
    with pytest.raises(InvalidInputError, match="max_radius"):
        RenderOptions(min_radius=20.0, max_radius=10.0)
    with pytest.raises(InvalidInputError, match="seed"):
        render_branches(image, source, target, seed=-1)


def test_warp_interpolates_its_constraints_smoothly():
    """§5.3: the displacement field meets every sample's vector exactly and is smooth."""
    warp = _Warp()
    half = 10
    pts = np.array([3 + 4j, 10 + 10j, 16 + 15j])
    vec = np.array([1.0 - 0.5j, 0.5 + 0.5j, -1.0 + 0.25j])
    field = warp.field(half, pts, vec, slice(0, 21), slice(0, 21))
    for p, v in zip(pts, vec):  # integer points fall on pixels
        assert abs(field[int(p.imag), int(p.real)] - v) < 0.05
    assert np.abs(np.diff(field, axis=0)).max() < 0.6 and np.abs(np.diff(field, axis=1)).max() < 0.6
    none = warp.field(half, np.zeros(0, complex), np.zeros(0, complex), slice(0, 21), slice(0, 21))
    assert not none.any()


def test_procrustes_finds_the_rotation_and_the_reversal():
    """§5.2: a rotated copy of a fragment's samples costs ~0 at the right angle; the reversed
    order of a symmetric-less shape costs more."""
    k = 9
    t = np.linspace(-1, 1, k)
    q = 10 * t + 3j * t**2
    theta = 0.7
    p = q * np.exp(-1j * theta)  # the source is the target rotated by -theta
    rows_re = np.stack([p.real, p[::-1].real])
    rows_im = np.stack([p.imag, p[::-1].imag])
    mu = np.full((2, k), 2.0)
    cost, zre, zim = K.shape_costs(
        rows_re,
        rows_im,
        mu,
        np.full(2, 100.0),
        q.real.copy(),
        q.imag.copy(),
        np.full(k, 2.0),
        np.ones(k),
        2.0,
        math.pi,
        10.0,
    )
    assert cost[0] < 1e-9 and cost[1] > 1.0
    assert abs(math.atan2(zim[0], zre[0]) - theta) < 1e-9
    # clamped to 20 degrees, the same fit is worse
    clamped, _, _ = K.shape_costs(
        rows_re,
        rows_im,
        mu,
        np.full(2, 100.0),
        q.real.copy(),
        q.imag.copy(),
        np.full(k, 2.0),
        np.ones(k),
        2.0,
        math.radians(20),
        10.0,
    )
    assert clamped[0] > 1.0
    # too close to the photo border: never chosen
    border, _, _ = K.shape_costs(
        rows_re,
        rows_im,
        mu,
        np.full(2, 5.0),
        q.real.copy(),
        q.imag.copy(),
        np.full(k, 2.0),
        np.ones(k),
        2.0,
        math.pi,
        10.0,
    )
    assert np.isinf(border).all()


def test_seam_cut_on_the_free_pixels_equals_the_cut_of_the_whole_grid():
    """§5.3's graph cut reduced to the pixels the constraints leave free (tied pixels folded
    into terminal capacities) separates them exactly as the cut of the whole box with the
    tied pixels as hard terminals."""
    import maxflow

    rng = np.random.default_rng(4)
    for _ in range(20):
        h, w = rng.integers(6, 24, 2)
        yy, xx = np.mgrid[:h, :w]
        take = np.hypot(yy - h / 2, xx - w / 2) < rng.uniform(1.5, 3.5)  # a core tied to the new
        keep = (yy == 0) | (xx == 0) | (yy == h - 1) | (xx == w - 1)  # a rim tied to the old
        keep &= ~take
        right = rng.uniform(0.01, 5.0, (h, w))
        down = rng.uniform(0.01, 5.0, (h, w))
        n_free = int((~take & ~keep).sum())
        free, ei, ej, cap, src_caps, sink_caps = K.seam_graph(take, keep, right, down, n_free)
        g = maxflow.Graph[float]()
        nodes = g.add_nodes(len(free))
        g.add_edges(nodes[ei], nodes[ej], cap, cap)
        g.add_grid_tedges(nodes, src_caps, sink_caps)
        flow = g.maxflow()
        reduced = take.copy()
        reduced.flat[free] = ~g.get_grid_segments(nodes)

        full = maxflow.Graph[float]()
        grid = full.add_grid_nodes((h, w))
        full.add_grid_edges(grid, weights=right, structure=np.array([[0, 0, 0], [0, 0, 1], [0, 0, 0]]), symmetric=True)
        full.add_grid_edges(grid, weights=down, structure=np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0]]), symmetric=True)
        full.add_grid_tedges(grid, np.where(take, 1e9, 0.0), np.where(keep, 1e9, 0.0))
        full_flow = full.maxflow()
        whole = ~full.get_grid_segments(grid) & ~keep
        # the same minimum cut: the whole grid's also cuts every edge between a pixel tied to
        # the new fragment and one tied to the old content
        between = (
            np.where((take[:, :-1] & keep[:, 1:]) | (keep[:, :-1] & take[:, 1:]), right[:, :-1], 0).sum()
            + np.where((take[:-1] & keep[1:]) | (keep[:-1] & take[1:]), down[:-1], 0).sum()
        )
        assert math.isclose(flow + between, full_flow, rel_tol=1e-9)
        assert np.array_equal(reduced, whole)  # random real weights: one minimum cut


def test_fragment_choice_draws_among_the_c_best_with_probability_inverse_to_the_cost():
    """§5.2: one of the ``c`` cheapest candidates, drawn with probability ~ 1 / cost."""
    total = np.array([4.0, 1.0, 2.0, 8.0])
    picks = np.array([K.draw_candidate(total, 2, u) for u in np.linspace(0.0, 1.0, 3001)[:-1]])
    assert set(picks) == {1, 2}
    assert abs((picks == 1).mean() - 2 / 3) < 0.01
    assert K.draw_candidate(np.array([1.0, np.inf]), 2, 0.5) == -1
    assert K.draw_candidate(np.zeros(0), 2, 0.5) == -1


def test_shape_cost_rotation_is_clamped_to_the_limit():
    """The closed-form rigid fit (§5.2) of a fragment that is the target turned by ``theta``:
    free rotation fits it exactly; clamped to ``limit`` the fit is the one at the limit,
    ``|p|^2 + |q|^2 - 2 |z| cos(theta - limit)`` (the kernel avoids trigonometry per row)."""
    k = 9
    q = (np.linspace(-8, 8, k) + 1j * np.sin(np.linspace(0, 3, k))).astype(np.complex128)
    thetas = np.radians([0.0, 15.0, 40.0, 90.0, 170.0, -60.0])
    p = np.stack([q * np.exp(-1j * t) for t in thetas])  # rotated back by theta fits q
    mu = np.ones((len(thetas), k))
    weight = np.ones(k)
    qq = float((np.abs(q) ** 2).sum())
    for limit in (np.radians(20.0), np.pi):
        cost, zre, zim = K.shape_costs(
            np.ascontiguousarray(p.real),
            np.ascontiguousarray(p.imag),
            mu,
            np.full(len(thetas), 100.0),
            np.ascontiguousarray(q.real),
            np.ascontiguousarray(q.imag),
            np.ones(k),
            weight,
            2.0,
            limit,
            0.0,
        )
        for t, c in zip(thetas, cost):
            fit = np.cos(max(abs(t) - limit, 0.0)) if limit < np.pi else 1.0
            assert math.isclose(c, max(2 * qq - 2 * qq * fit, 0.0), rel_tol=1e-6, abs_tol=1e-6)
        np.testing.assert_allclose(np.angle(zre + 1j * zim), thetas, atol=1e-9)
