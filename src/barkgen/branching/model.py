"""The statistical structure model of sibbing2010 §4, learned from a source structure.

- Bending (§4.2): a Markov model on sequences of (turning angle, thickness) elements. Every
  window of ``k + 1`` elements of a source branch is a candidate history; the ``m`` elements
  that follow it are its continuation.
- Histogram targets (§4.2): the source's angle and thickness histograms (``B = 16`` bins
  between the source's minimum and maximum).
- Furcations (§4.3): a linear SVM on the non-causal neighbourhood of every source vertex
  (``2k + 1`` angles and thicknesses plus the index distances ``n-`` and ``n+`` to the
  previous and next furcation), the number of children per branch, and for every source
  furcation its neighbourhood, branching angle and the child's first elements.
- Merges (beyond the paper): how often a branch ends on another branch, and at what angle.

Element ``j`` of a branch with vertices ``x_0..x_{n-1}`` is ``(alpha_j, r_{j+1})``: the turn
at vertex ``j`` (``1 <= j <= n-2``) and the thickness of the vertex it leads to, so appending
an element to a growing branch means: turn, step ``h``, set the new vertex's thickness.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from barkgen.branching.structure import Branch, Structure, resample_polyline, turning_angles
from barkgen.errors import InvalidInputError


@dataclass(frozen=True)
class ModelOptions:
    """Parameters of the model (defaults: sibbing2010 §4.2-4.3)."""

    k: int = 3  # order of the Markov process (k = 3 in all the paper's experiments)
    m: int = 4  # elements appended per step (typical feature size / h)
    c: int = 2  # candidates to choose from (variability)
    omega_g: float = 50.0  # weight of the histogram matching
    bins: int = 16  # histogram bins (B)

    def validate(self) -> ModelOptions:
        if not 1 <= self.k <= 16:
            raise InvalidInputError(f"k must be in 1..16, got {self.k}")
        if not 1 <= self.m <= 64:
            raise InvalidInputError(f"m must be in 1..64, got {self.m}")
        if not 1 <= self.c <= 64:
            raise InvalidInputError(f"c must be in 1..64, got {self.c}")
        if not 0 <= self.omega_g <= 1e4:
            raise InvalidInputError(f"omega_g must be in [0, 1e4], got {self.omega_g}")
        if not 2 <= self.bins <= 256:
            raise InvalidInputError(f"bins must be in 2..256, got {self.bins}")
        return self


@dataclass
class Furcations:
    """Source furcations: the parent's neighbourhood, the branching angle, the child's start."""

    nb_angles: np.ndarray  # (F, 2k+1)
    nb_thickness: np.ndarray  # (F, 2k+1)
    branch_angle: np.ndarray  # (F,) child's first heading minus the parent's tangent
    child_thickness: np.ndarray  # (F,) thickness of the child's first vertex
    child_first: np.ndarray  # (F,) index of the child's first element in the flat arrays (-1: none)
    child_len: np.ndarray  # (F,) number of the child's elements


@dataclass
class BranchModel:
    """Everything growth needs, learned from one source structure by :func:`fit_model`."""

    options: ModelOptions
    step: float
    angles: np.ndarray  # flat element arrays of all branches
    thickness: np.ndarray
    element_end: np.ndarray  # per element: one past the last element of its branch
    history_start: np.ndarray  # (N,) first element of each candidate history (k+1 elements)
    branch_end: np.ndarray  # (N,) one past the last element of the candidate's branch
    end_joins: np.ndarray  # (N,) that branch ended on another branch
    angle_edges: np.ndarray
    thickness_edges: np.ndarray
    angle_hist: np.ndarray  # normalised source histograms
    thickness_hist: np.ndarray
    heading_hist: np.ndarray  # edge directions as axes (0-180 degrees): bark fissures run upright
    svm_w: np.ndarray | None  # furcation classifier on standardised features
    svm_b: float
    platt: tuple[float, float]  # furcation probability = sigmoid(a * margin + b)
    feat_mean: np.ndarray
    feat_scale: np.ndarray
    children_per_branch: np.ndarray
    furcations: Furcations
    root_heading: np.ndarray  # absolute first heading of each source branch with elements
    root_first: np.ndarray  # its first element index
    root_thickness: np.ndarray  # thickness of its first vertex
    join_rate: float  # share of branch ends that end on another branch
    branch_length: np.ndarray  # (B,) arc length of every source branch
    branch_is_root: np.ndarray  # (B,) it starts no furcation
    branch_joined: np.ndarray  # (B,) it ends on another branch
    roots_per_length: float  # separate networks per pixel of skeleton length
    merges_per_length: float  # merges per pixel of skeleton length
    join_angles: np.ndarray  # incidence angles (radians in [0, pi/2]) of the source's merges
    length_density: float  # skeleton length per pixel of the source
    junction_density: float  # furcations + merges per pixel
    rho: float  # space-colonisation spread (pixels)
    meta: dict = field(default_factory=dict)
    # (N,) and (B,): the branch leaves the image, so where and how it ends is unseen (censored);
    # growth ends such a branch as the source's seen ends end (joined at ``join_rate``)
    end_cut: np.ndarray | None = None
    branch_cut: np.ndarray | None = None
    # roots that start in the open (not on the image border) per pixel of skeleton length: the
    # rest of growth's new networks start on a branch (None: every root starts in the open)
    free_starts_per_length: float | None = None
    # branch ends in the open (on no branch, not on the border) per pixel of skeleton length
    free_ends_per_length: float | None = None


def _elements(branch: Branch) -> tuple[np.ndarray, np.ndarray]:
    p = branch.points
    if len(p) < 3:
        return np.zeros(0), np.zeros(0)
    return turning_angles(p[:, :2]), p[2:, 2].copy()


def _neighbourhoods(angles: np.ndarray, thickness: np.ndarray, k: int) -> np.ndarray:
    """The 2k+1 angles and 2k+1 thicknesses around every vertex (edge-replicated)."""
    n = len(angles)
    idx = np.clip(np.arange(n)[:, None] + np.arange(-k, k + 1)[None, :], 0, n - 1)
    return np.concatenate([angles[idx], thickness[idx]], axis=1)


def _furcation_distances(furcation_at: np.ndarray) -> np.ndarray:
    """``n-`` and ``n+`` of every vertex: index distances to the previous and next furcation
    (or the branch's ends), as two columns."""
    n = len(furcation_at)
    i: np.ndarray = np.arange(n, dtype=np.float64)
    marks = np.flatnonzero(furcation_at)
    if len(marks) == 0:
        out = np.empty((n, 2))
        out[:, 0] = i
        out[:, 1] = n - 1 - i
        return out
    i = np.arange(n)
    prev_marks = np.concatenate([[0], marks])
    next_marks = np.concatenate([marks, [n - 1]])
    n_minus = i - prev_marks[np.maximum(np.searchsorted(prev_marks, i, side="left") - 1, 0)]
    n_plus = next_marks[np.minimum(np.searchsorted(next_marks, i, side="right"), len(next_marks) - 1)] - i
    n_plus = np.where(n_plus < 0, n - 1 - i, n_plus)
    return np.stack([n_minus, n_plus], axis=1).astype(np.float64)


def _vertex_features(angles: np.ndarray, thickness: np.ndarray, k: int, furcation_at: np.ndarray) -> np.ndarray:
    """Non-causal features of every vertex of one branch (§4.3): 2k+1 angles, 2k+1
    thicknesses (edge-replicated), and index distances to the previous and next furcation or
    branch end; ``angles`` and ``thickness`` are per vertex (angle 0 at the two ends)."""
    return np.concatenate([_neighbourhoods(angles, thickness, k), _furcation_distances(furcation_at)], axis=1)


def vertex_angles(points: np.ndarray) -> np.ndarray:
    """Turning angle per vertex (0 at both ends)."""
    out = np.zeros(len(points))
    if len(points) >= 3:
        out[1:-1] = turning_angles(points[:, :2])
    return out


def _tangent(points: np.ndarray, i: int) -> float:
    a = points[max(i - 1, 0), :2]
    b = points[min(i + 1, len(points) - 1), :2]
    return float(np.arctan2(b[1] - a[1], b[0] - a[0]))


def _wrap(a):
    return np.angle(np.exp(1j * np.asarray(a, np.float64)))


def fit_model(source: Structure, options: ModelOptions | None = None) -> BranchModel:
    """Learn the bending, furcation and merge statistics of ``source`` (sibbing2010 §4.2-4.3).

    The source is resampled at its own ``step`` first (§4.1), so hand-made structures with
    uneven vertex spacing are accepted.
    """
    options = (options or ModelOptions()).validate()
    k = options.k
    source.validate("source structure")
    h = float(source.step)
    branches = _resampled(source, h)
    flat_a, flat_r, element_end, starts, ends, joined, first_index = _histories(branches, k, h)
    cut = [_leaves(b, source.width, source.height) for b in branches]
    history_cut = np.repeat(cut, [max(len(_elements(b)[0]) - k, 0) for b in branches])
    a_edges, r_edges, a_hist, r_hist, h_hist = _bending_histograms(branches, flat_a, flat_r, options.bins)
    children, fur_rows, feat_mean, feat_scale, svm_w, svm_b, platt = _furcation_classifier(branches, k)
    furcations = _furcations(branches, fur_rows, first_index, k)
    root_heading, root_first, root_thickness = _roots(branches, first_index)
    join_angles = _join_angles(branches)
    free_ends = _free_ends(branches, source.width, source.height)
    n_joins = sum(b.joins is not None for b in branches)
    join_rate = n_joins / max(n_joins + free_ends, 1)

    area = float(source.width * source.height)
    length = float(sum(b.length() for b in branches))
    junctions = sum((b.parent is not None) + (b.joins is not None) for b in branches)
    rho = _spread(branches, source.width, source.height)
    return BranchModel(
        options,
        h,
        flat_a,
        flat_r,
        element_end,
        np.asarray(starts, int),
        np.asarray(ends, int),
        np.asarray(joined, bool),
        a_edges,
        r_edges,
        a_hist,
        r_hist,
        h_hist,
        svm_w,
        svm_b,
        platt,
        feat_mean,
        feat_scale,
        children,
        furcations,
        root_heading,
        root_first,
        root_thickness,
        float(join_rate),
        np.array([b.length() for b in branches]),
        np.array([b.parent is None for b in branches]),
        np.array([b.joins is not None for b in branches]),
        _networks(branches) / max(length, 1e-9),
        n_joins / max(length, 1e-9),
        join_angles,
        length / area,
        junctions / area,
        rho,
        meta={
            "source_length": length,
            "branches": len(branches),
            "vertices": int(sum(len(b.points) for b in branches)),
            "furcations": len(fur_rows),
            "merges": n_joins,
        },
        end_cut=history_cut.astype(bool),
        free_starts_per_length=_free_starts(branches, source.width, source.height) / max(length, 1e-9),
        free_ends_per_length=free_ends / max(length, 1e-9),
        branch_cut=np.asarray(cut, bool),
    )


def _resampled(source: Structure, h: float) -> list[Branch]:
    """The source's branches resampled at step ``h`` (§4.1), their links moved with them."""
    branches = [Branch(resample_polyline(b.points, h), b.parent, None, b.joins, None) for b in source.branches]
    # vertex indices of links move with the resampling: map them by arc length
    for b_new, b_old in zip(branches, source.branches):
        if b_old.parent is not None:
            assert b_old.parent_vertex is not None  # set with parent (Structure.validate)
            b_new.parent_vertex = _remap_vertex(source.branches[b_old.parent], b_old.parent_vertex, h)
        if b_old.joins is not None:
            assert b_old.join_vertex is not None  # set with joins (Structure.validate)
            b_new.join_vertex = _remap_vertex(source.branches[b_old.joins], b_old.join_vertex, h)
    return branches


def _histories(branches: list[Branch], k: int, h: float):
    """The elements (turning angle, thickness) of all branches end to end, where each element's
    branch ends, and the ``k + 1``-element histories (§4.2): their starts, where their branch
    ends and whether it ends on another; plus each branch's first element (-1: none)."""
    angles, thick, starts, ends, joined, element_end = [], [], [], [], [], []
    offset = 0
    first_index = []
    for b in branches:
        a, r = _elements(b)
        first_index.append(offset if len(a) else -1)
        n = len(a)
        for s in range(0, n - k):  # history s..s+k, continuation from s+k+1 (may be empty)
            starts.append(offset + s)
            ends.append(offset + n)
            joined.append(b.joins is not None)
        angles.append(a)
        thick.append(r)
        element_end.append(np.full(n, offset + n, int))
        offset += n
    if not starts:
        raise InvalidInputError(
            f"source structure: no branch is long enough to learn from (need at least {k + 3} "
            f"vertices at step {h:g} px; the longest has {max(len(b.points) for b in branches)})"
        )
    return (
        np.concatenate(angles),
        np.concatenate(thick),
        np.concatenate(element_end),
        starts,
        ends,
        joined,
        first_index,
    )


def _bending_histograms(branches: list[Branch], flat_a: np.ndarray, flat_r: np.ndarray, bins: int):
    """The bin edges and the source's histograms of turning angle and thickness (§4.2), and of
    the directions of the edges the elements lead to."""
    all_r = np.concatenate([b.thickness for b in branches])
    a_lo, a_hi = float(flat_a.min()), float(flat_a.max())
    r_lo, r_hi = float(all_r.min()), float(all_r.max())
    if a_hi - a_lo < 1e-6:
        a_lo, a_hi = a_lo - 0.1, a_hi + 0.1
    if r_hi - r_lo < 1e-6:
        r_lo, r_hi = r_lo * 0.9, r_hi * 1.1 + 1e-3
    a_edges = np.linspace(a_lo, a_hi, bins + 1)
    r_edges = np.linspace(r_lo, r_hi, bins + 1)
    a_hist = histogram(flat_a, a_edges)
    r_hist = histogram(flat_r, r_edges)
    # directions of the edges that elements lead to (the paper's model is rotation invariant;
    # matching this histogram too keeps upright bark fissures upright)
    headings = np.concatenate([np.arctan2(*np.diff(b.xy, axis=0)[1:, ::-1].T) for b in branches if len(b.points) >= 3])
    h_hist = histogram(np.mod(headings, np.pi), np.linspace(0, np.pi, bins + 1))
    return a_edges, r_edges, a_hist, r_hist, h_hist


def _furcation_classifier(branches: list[Branch], k: int):
    """The furcations (§4.3): children per branch, ``(parent, vertex, child)`` rows, and the
    linear SVM on the standardised vertex features (mean, scale, weights, bias) with the Platt
    scaling of its margin (``None`` weights when every vertex or none is a furcation)."""
    children = np.zeros(len(branches), int)
    furcation_at = [np.zeros(len(b.points), bool) for b in branches]
    fur_rows = []
    for ci, b in enumerate(branches):
        if b.parent is None:
            continue
        children[b.parent] += 1
        assert b.parent_vertex is not None  # set with parent (Structure.validate)
        v = int(b.parent_vertex)
        furcation_at[b.parent][v] = True
        fur_rows.append((b.parent, v, ci))
    feat_rows, label_rows = [], []
    for bi, b in enumerate(branches):
        va = vertex_angles(b.points)
        feat_rows.append(_vertex_features(va, b.thickness, k, furcation_at[bi]))
        label_rows.append(furcation_at[bi])
    feats = np.concatenate(feat_rows)
    labels = np.concatenate(label_rows)
    feat_mean = feats.mean(axis=0)
    feat_scale = feats.std(axis=0) + 1e-6
    svm_w, svm_b, platt = None, 0.0, (0.0, 0.0)
    if labels.any() and not labels.all():
        from sklearn.linear_model import LogisticRegression
        from sklearn.svm import LinearSVC

        standard = (feats - feat_mean) / feat_scale
        clf = LinearSVC(C=1.0, class_weight="balanced", max_iter=5000, random_state=0)
        clf.fit(standard, labels)
        svm_w, svm_b = clf.coef_[0].copy(), float(clf.intercept_[0])
        # Platt scaling of the margin into a probability on the true class balance: summed
        # over a branch it is the expected number of furcations, which gives d (§4.3)
        margin = (standard @ svm_w + svm_b)[:, None]
        lr = LogisticRegression(C=100.0).fit(margin, labels)
        platt = (float(lr.coef_[0, 0]), float(lr.intercept_[0]))
    return children, fur_rows, feat_mean, feat_scale, svm_w, svm_b, platt


def _furcations(
    branches: list[Branch], fur_rows: list[tuple[int, int, int]], first_index: list[int], k: int
) -> Furcations:
    """Per source furcation (§4.3): the parent's non-causal neighbourhood (2k+1 turning angles
    and thicknesses), the child's angle to the parent's tangent and start thickness, and where
    the child's elements start and how many there are."""
    nb_a, nb_r, b_ang, c_thick, c_first, c_len = [], [], [], [], [], []
    for pi, v, ci in fur_rows:
        parent = branches[pi]
        va = vertex_angles(parent.points)
        idx = np.clip(np.arange(v - k, v + k + 1), 0, len(va) - 1)
        nb_a.append(va[idx])
        nb_r.append(parent.thickness[idx])
        child = branches[ci]
        d = child.points[1, :2] - child.points[0, :2]
        b_ang.append(float(_wrap(np.arctan2(d[1], d[0]) - _tangent(parent.points, v))))
        c_thick.append(float(child.points[0, 2]))
        c_first.append(first_index[ci])
        c_len.append(max(len(child.points) - 2, 0))
    return Furcations(
        np.asarray(nb_a).reshape(-1, 2 * k + 1),
        np.asarray(nb_r).reshape(-1, 2 * k + 1),
        np.asarray(b_ang, float),
        np.asarray(c_thick, float),
        np.asarray(c_first, int),
        np.asarray(c_len, int),
    )


def _roots(branches: list[Branch], first_index: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start heading, first element and start thickness of every branch that has elements."""
    roots = [i for i, b in enumerate(branches) if first_index[i] >= 0]
    root_heading = np.array([np.arctan2(*(branches[i].points[1, 1::-1] - branches[i].points[0, 1::-1])) for i in roots])
    root_first = np.array([first_index[i] for i in roots], int)
    root_thickness = np.array([branches[i].points[0, 2] for i in roots])
    return root_heading, root_first, root_thickness


def _join_angles(branches: list[Branch]) -> np.ndarray:
    """Incidence angle (0..90 degrees, radians) of every merge on the branch it ends on."""
    join_angles = []
    for b in branches:
        if b.joins is None:
            continue
        target = branches[b.joins]
        d = b.points[-1, :2] - b.points[-2, :2]
        assert b.join_vertex is not None  # set with joins (Structure.validate)
        inc = abs(_wrap(np.arctan2(d[1], d[0]) - _tangent(target.points, int(b.join_vertex))))
        join_angles.append(min(inc, np.pi - inc))
    return np.asarray(join_angles, float)


def _networks(branches: list[Branch]) -> int:
    """Number of connected networks (branches linked by furcations or merges)."""
    root = list(range(len(branches)))

    def find(i: int) -> int:
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    for i, b in enumerate(branches):
        for j in (b.parent, b.joins):
            if j is not None:
                root[find(i)] = find(j)
    return len({find(i) for i in range(len(branches))})


def _remap_vertex(branch: Branch, vertex: int, step: float) -> int:
    seg = np.hypot(*np.diff(branch.xy, axis=0).T)
    s = float(np.concatenate([[0.0], np.cumsum(seg)])[vertex])
    n = len(resample_polyline(branch.points, step))
    return int(min(round(s / step), n - 1))


def _leaves(branch: Branch, width: int, height: int, margin: float = 3.0) -> bool:
    """The branch's end lies within ``margin`` of the image border and on no branch: it runs on
    out of the image, and its real end is unseen."""
    x, y = branch.points[-1, :2]
    inside = margin <= x <= width - 1 - margin and margin <= y <= height - 1 - margin
    return branch.joins is None and not inside


def _free_starts(branches: list[Branch], width: int, height: int, margin: float = 3.0) -> int:
    """Roots (branches without a parent) that start away from the image border: in the open."""
    count = 0
    for b in branches:
        x, y = b.points[0, :2]
        count += b.parent is None and margin <= x <= width - 1 - margin and margin <= y <= height - 1 - margin
    return count


def _free_ends(branches: list[Branch], width: int, height: int, margin: float = 3.0) -> int:
    """Branch ends that neither join another branch nor leave the image (they stop freely)."""
    count = 0
    for b in branches:
        if b.joins is not None:
            continue
        x, y = b.points[-1, :2]
        if margin <= x <= width - 1 - margin and margin <= y <= height - 1 - margin:
            count += 1
    return count


def _spread(branches: list[Branch], width: int, height: int) -> float:
    """Space-colonisation ``rho`` (§4.4): half the median distance from a pixel to the nearest
    branch of the source, i.e. how close branches come to each other in the example."""
    import cv2

    canvas = np.full((height, width), 255, np.uint8)
    for b in branches:
        pts = np.round(b.xy).astype(np.int32)
        cv2.polylines(canvas, [pts], False, 0, 1)
    dist = cv2.distanceTransform(canvas, cv2.DIST_L2, 5)
    return float(max(np.median(dist[canvas > 0]) * 0.5, 1.5))


def histogram(values: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Normalised histogram; values outside the edges count in the end bins."""
    b = len(edges) - 1
    if len(values) == 0:
        return np.zeros(b)
    idx = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, b - 1)
    counts = np.bincount(idx, minlength=b).astype(np.float64)
    return counts / counts.sum()
