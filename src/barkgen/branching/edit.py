"""Editing a branching structure by hand, and rectifying a photo first (sibbing2010 §6, Fig. 8).

The paper's interactive system lets the user point and click to extend single branches, place
furcations, delete unwanted sub-branches, and rectify the perspective of a source image that was
not taken from the front (its Fig. 8) before the structure is captured. These are those
metaphors as pure functions: each takes a :class:`~barkgen.branching.structure.Structure` and
returns a new one (the input is never changed), so a front end keeps an undo history by keeping
the structures; :func:`nearest_branch` turns a click into a branch index.

- :func:`extend_branch`: the branch's end nearer the click runs on, smoothly, to the click;
- :func:`add_furcation`: a new child branch from the parent's vertex nearest a click to another;
- :func:`delete_branch`: a branch and every branch that starts on it, recursively;
- :func:`rectify_perspective`: four corners of a plane in the photo warped to a rectangle.

Points are ``(x, y)`` in pixels of the structure's image, as its vertices are.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from barkgen.branching.structure import Branch, Structure, resample_polyline
from barkgen.errors import InvalidInputError

__all__ = ["add_furcation", "delete_branch", "extend_branch", "nearest_branch", "rectify_perspective"]

#: the smallest side (px) of a quad :func:`rectify_perspective` accepts, and of its output
MIN_RECTIFY_SIDE = 4
#: the least turn (degrees) at every corner of that quad: none almost straight or a sliver
MIN_RECTIFY_ANGLE = 5.0
#: the largest output side (px) of :func:`rectify_perspective`
MAX_RECTIFY_SIDE = 16384


def _copy(structure: Structure, branches: list[Branch]) -> Structure:
    return Structure(float(structure.step), (structure.width, structure.height), branches, structure.periodic)


def _copy_branch(b: Branch) -> Branch:
    return Branch(b.points.copy(), b.parent, b.parent_vertex, b.joins, b.join_vertex)


def _point(point: object, what: str, structure: Structure | None = None) -> np.ndarray:
    """``point`` as a float ``(2,)`` array; inside the structure's image when one is given."""
    try:
        p = np.asarray(point, np.float64)
    except (TypeError, ValueError):
        p = np.zeros(0)
    if p.shape != (2,) or not np.isfinite(p).all():
        raise InvalidInputError(f"{what} must be two finite numbers (x, y), got {point!r}")
    if structure is not None and not (0 <= p[0] <= structure.width and 0 <= p[1] <= structure.height):
        raise InvalidInputError(
            f"{what} ({p[0]:g}, {p[1]:g}) is outside the {structure.width}x{structure.height} px image"
        )
    return p


def _index(structure: Structure, branch_index: object) -> int:
    n = len(structure.branches)
    if isinstance(branch_index, bool) or not isinstance(branch_index, (int, np.integer)):
        raise InvalidInputError(f"branch index must be an integer, got {branch_index!r}")
    if not 0 <= int(branch_index) < n:
        raise InvalidInputError(f"branch {branch_index} is not in the structure (0..{n - 1})")
    return int(branch_index)


def _segment_distances(xy: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distance of ``p`` to every segment of the polyline ``xy`` (to its vertex if it has one)."""
    if len(xy) < 2:
        return np.hypot(*(xy - p).T)
    a, b = xy[:-1], xy[1:]
    d = b - a
    length2 = np.maximum((d * d).sum(1), 1e-12)
    t = np.clip(((p - a) * d).sum(1) / length2, 0.0, 1.0)
    return np.hypot(*(a + t[:, None] * d - p).T)


def nearest_branch(structure: Structure, point) -> tuple[int, float]:
    """The branch nearest a click (sibbing2010 §6: point and click).

    Parameters
    ----------
    structure : Structure
    point : (x, y)
        The click, in pixels of the structure's image.

    Returns
    -------
    (int, float)
        The branch's index and the click's distance (px) to its skeleton (segments, not only
        vertices).

    References
    ----------
    .. [1] sibbing2010, §6 (the user's point-and-click metaphors).
    """
    p = _point(point, "the point")
    if not structure.branches:
        raise InvalidInputError("the structure is empty (no branches)")
    distances = [float(_segment_distances(b.xy, p).min()) if len(b.points) else np.inf for b in structure.branches]
    index = int(np.argmin(distances))
    return index, distances[index]


def _smooth_path(start: np.ndarray, heading: np.ndarray | None, target: np.ndarray, step: float) -> np.ndarray:
    """A curve from ``start`` leaving along the unit ``heading`` (straight if None) and ending
    at ``target``, sampled finely: the cubic Hermite curve whose end tangents are those of the
    circular arc through both points that leaves along the heading (the heading, and the
    heading mirrored across the chord), scaled as a cubic that follows the arc, so the turn is
    spread along the whole extension. A target more than 90 degrees off the heading makes a
    U-turn no wider than the arc to a target 90 degrees off would."""
    chord = target - start
    length = float(np.hypot(*chord))
    n = max(8, int(np.ceil(8 * length / step)))
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    if heading is None:
        return start + t * chord
    u = chord / max(length, 1e-12)
    cos_theta = float(np.clip(np.dot(heading, u), -1.0, 1.0))
    # the arc of turn 2 theta as a cubic: tangents of length L / cos^2(theta / 2) = 2 L / (1 + cos theta)
    scale = length * 2.0 / (1.0 + max(cos_theta, 0.0))
    m0 = heading * scale
    m1 = (2 * cos_theta * u - heading) * scale
    h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
    h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
    return h00 * start + h10 * m0 + h01 * target + h11 * m1


def _end_heading(xy: np.ndarray, step: float) -> np.ndarray | None:
    """The unit direction in which the polyline ``xy`` leaves its last vertex, over about
    three steps of it (None for a single point)."""
    if len(xy) < 2:
        return None
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy[::-1], axis=0).T))])
    j = min(int(np.searchsorted(s, 3 * step)), len(xy) - 1)
    d = xy[-1] - xy[::-1][j]
    norm = float(np.hypot(*d))
    return d / norm if norm > 1e-9 else None


def extend_branch(
    structure: Structure, branch_index: int, point, *, end: Literal["start", "end"] | None = None
) -> Structure:
    """The structure with a branch extended to a clicked point (sibbing2010 §6: "extend existing
    single branches (point and click)").

    The branch's end nearer ``point`` (or the one ``end`` names) runs on to ``point`` along a
    smooth curve that leaves in the direction the branch had there, resampled at the structure's
    step; the new vertices carry the thickness of the end vertex. The branch's existing vertices
    stay as they are, so its other end, and every link into it, is kept. An extended start stops
    being a furcation (it no longer starts on its parent), an extended end stops being a merge.

    Parameters
    ----------
    structure : Structure
    branch_index : int
        The branch to extend.
    point : (x, y)
        Where it should reach, in pixels of the structure's image (inside it), at least one step
        from the end.
    end : {"start", "end"}, optional
        Which end to extend (default: the one nearer ``point``).

    Returns
    -------
    Structure
        A new structure; ``structure`` is unchanged.

    Raises
    ------
    InvalidInputError
        An unknown branch, a point outside the image or within one step of the end.

    References
    ----------
    .. [1] sibbing2010, §6 and §4.1 (branches resampled at the step h).
    """
    i = _index(structure, branch_index)
    p = _point(point, "the point", structure)
    if end not in (None, "start", "end"):
        raise InvalidInputError(f"end must be 'start' or 'end', got {end!r}")
    old = structure.branches[i]
    xy = old.xy
    if end is None:
        end = "start" if np.hypot(*(xy[0] - p)) < np.hypot(*(xy[-1] - p)) else "end"
    at_start = end == "start"
    pts = old.points[::-1] if at_start else old.points
    step = float(structure.step)
    if np.hypot(*(pts[-1, :2] - p)) < step:
        raise InvalidInputError(f"the point is within one step ({step:g} px) of branch {i}'s {end}: click farther away")
    path = _smooth_path(pts[-1, :2], _end_heading(pts[:, :2], step), p, step)
    new = resample_polyline(np.column_stack([path, np.full(len(path), pts[-1, 2])]), step)[1:]
    if np.hypot(*(new[-1, :2] - p)) > 1e-6:  # the last step lands on the click itself
        new = np.vstack([new, [p[0], p[1], pts[-1, 2]]])
    branches = [_copy_branch(b) for b in structure.branches]
    b = branches[i]
    if at_start:
        b.points = np.vstack([new[::-1], old.points])
        b.parent = b.parent_vertex = None
        # links into this branch move with its prepended vertices
        for other in branches:
            if other.parent == i and other.parent_vertex is not None:
                other.parent_vertex += len(new)
            if other.joins == i and other.join_vertex is not None:
                other.join_vertex += len(new)
    else:
        b.points = np.vstack([old.points, new])
        b.joins = b.join_vertex = None
    out = _copy(structure, branches)
    out.validate("extended structure")
    return out


def add_furcation(
    structure: Structure, branch_index: int, at_point, to_point, *, thickness: float | None = None
) -> Structure:
    """The structure with a new child branch (sibbing2010 §6: "place furcations ... manually").

    The child starts on the vertex of branch ``branch_index`` nearest ``at_point`` (recorded as
    a furcation: ``parent``, ``parent_vertex``, §4.1) and runs straight to ``to_point``,
    resampled at the structure's step. It is appended as the last branch.

    Parameters
    ----------
    structure : Structure
    branch_index : int
        The parent branch.
    at_point, to_point : (x, y)
        Where on the parent the child starts (its nearest vertex), where the child ends (inside
        the image, at least one step from the start).
    thickness : float, optional
        The child's thickness (half-width, px; default: the parent's at the furcation).

    Returns
    -------
    Structure
        A new structure whose last branch is the child.

    Raises
    ------
    InvalidInputError
        An unknown branch, a point outside the image, a child shorter than one step or a
        thickness that is not a positive number.

    References
    ----------
    .. [1] sibbing2010, §6 and §4.3 (furcations).
    """
    i = _index(structure, branch_index)
    at = _point(at_point, "the furcation point", structure)
    to = _point(to_point, "the end point", structure)
    parent = structure.branches[i]
    vertex = int(np.argmin(np.hypot(*(parent.xy - at).T)))
    start = parent.points[vertex]
    if thickness is None:
        thickness = float(start[2])
    elif isinstance(thickness, bool) or not isinstance(thickness, (int, float)) or not 0 < thickness < 1e4:
        raise InvalidInputError(f"thickness must be a positive number of pixels, got {thickness!r}")
    step = float(structure.step)
    if np.hypot(*(to - start[:2])) < step:
        raise InvalidInputError(f"the new branch would be shorter than one step ({step:g} px): click farther away")
    line = np.array([[start[0], start[1], thickness], [to[0], to[1], thickness]])
    points = resample_polyline(line, step)
    if np.hypot(*(points[-1, :2] - to)) > 1e-6:
        points = np.vstack([points, [to[0], to[1], thickness]])
    branches = [_copy_branch(b) for b in structure.branches]
    branches.append(Branch(points, parent=i, parent_vertex=vertex))
    out = _copy(structure, branches)
    out.validate("structure with a furcation")
    return out


def delete_branch(structure: Structure, branch_index: int) -> Structure:
    """The structure without a branch and its sub-branches (sibbing2010 §6: "manually delete
    unwanted subbranches").

    Every branch that starts on a deleted branch (its ``parent``) is deleted too, recursively.
    A branch that ends on a deleted one (a merge, ``joins``) stays, its end now free. The
    remaining branches keep their order; their links are renumbered.

    Parameters
    ----------
    structure : Structure
    branch_index : int

    Returns
    -------
    Structure
        A new structure.

    Raises
    ------
    InvalidInputError
        An unknown branch, or one whose sub-tree is the whole structure (a structure has at
        least one branch).

    References
    ----------
    .. [1] sibbing2010, §6.
    """
    i = _index(structure, branch_index)
    gone = {i}
    grew = True
    while grew:  # children of deleted branches, until none is added
        more = {j for j, b in enumerate(structure.branches) if b.parent in gone and j not in gone}
        gone |= more
        grew = bool(more)
    if len(gone) == len(structure.branches):
        raise InvalidInputError(
            f"deleting branch {i} would delete every branch (it carries the whole structure); "
            "a structure keeps at least one"
        )
    new_index: dict[int, int] = {}
    for j in range(len(structure.branches)):
        if j not in gone:
            new_index[j] = len(new_index)
    branches = []
    for j, old in enumerate(structure.branches):
        if j in gone:
            continue
        b = _copy_branch(old)
        # (a parent is never deleted without its children: a kept branch's parent is kept)
        b.parent = new_index[b.parent] if b.parent is not None else None
        if b.joins is not None and b.joins in gone:
            b.joins = b.join_vertex = None
        elif b.joins is not None:
            b.joins = new_index[b.joins]
        branches.append(b)
    out = _copy(structure, branches)
    out.validate("structure after the deletion")
    return out


def _quad(corners, shape: tuple[int, int]) -> np.ndarray:
    """Four corners as a float ``(4, 2)`` array, checked, clockwise on screen from the first."""
    try:
        q = np.asarray(corners, np.float64)
    except (TypeError, ValueError):
        q = np.zeros(0)
    if q.shape != (4, 2) or not np.isfinite(q).all():
        raise InvalidInputError(f"corners must be four (x, y) points, got {np.shape(corners)} values")
    h, w = shape
    outside = [k for k in range(4) if not (0 <= q[k, 0] <= w and 0 <= q[k, 1] <= h)]
    if outside:
        k = outside[0]
        raise InvalidInputError(f"corner {k + 1} ({q[k, 0]:g}, {q[k, 1]:g}) is outside the {w}x{h} px image")
    sides = np.hypot(*(np.roll(q, -1, axis=0) - q).T)
    pairwise = np.hypot(*(q[:, None] - q[None]).transpose(2, 0, 1))[np.triu_indices(4, 1)]
    if pairwise.min() < MIN_RECTIFY_SIDE:
        raise InvalidInputError(f"the four corners must be distinct points at least {MIN_RECTIFY_SIDE} px apart")
    edges = np.roll(q, -1, axis=0) - q
    cross = edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1] - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0]
    if not ((cross > 0).all() or (cross < 0).all()):
        raise InvalidInputError(
            "the four corners must be given in order around a convex quadrilateral (no three in a line, no crossing)"
        )
    sines = np.abs(cross) / np.maximum(sides * np.roll(sides, -1), 1e-12)  # at corners 2, 3, 4, 1
    if sines.min() < np.sin(np.radians(MIN_RECTIFY_ANGLE)):
        raise InvalidInputError(
            f"the quadrilateral is degenerate: a corner's angle is under {MIN_RECTIFY_ANGLE:g} "
            f"or over {180 - MIN_RECTIFY_ANGLE:g} degrees"
        )
    if cross[0] < 0:  # counter-clockwise on screen (y down): the same corners the other way round
        q = q[[0, 3, 2, 1]]
    return q


def rectify_perspective(image: np.ndarray, corners, size: tuple[int, int] | None = None) -> np.ndarray:
    """A plane seen at an angle in a photo, warped to a rectangle (sibbing2010 §6, Fig. 8).

    sibbing2010's Fig. 8 takes its source structure from a photo "not captured from a frontal
    view" after "a proper perspective rectification". The four corners of a rectangle of the
    plane (clicked in the photo, in order around it, either way) give the homography that maps
    them onto the corners of the output: the first corner becomes the output's top left and the
    output runs clockwise from it, so the result is never mirrored.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
        The photo (uint8, uint16 or float; C at most 4).
    corners : array_like, shape (4, 2)
        The plane's corners ``(x, y)`` in the photo's pixels, in order around the plane; they
        must be distinct, inside the photo and make a convex, non-degenerate quadrilateral.
    size : (width, height), optional
        The output's size in pixels. Default: the mean lengths of the quadrilateral's two pairs
        of opposite sides (the plane's proportions where the perspective is mild).

    Returns
    -------
    ndarray, shape (height, width) or (height, width, C)
        The rectified photo, ``image``'s dtype (bilinear; the border replicated).

    Raises
    ------
    InvalidInputError
        Corners that are not four distinct points in order around a convex quadrilateral inside
        the photo, or a bad size.

    References
    ----------
    .. [1] sibbing2010, §6 and Fig. 8.
    """
    import cv2

    image = np.asarray(image)
    if image.ndim not in (2, 3) or (image.ndim == 3 and not 1 <= image.shape[2] <= 4) or min(image.shape[:2]) < 2:
        raise InvalidInputError(f"the image must be (H, W) or (H, W, C) with C at most 4, got shape {image.shape}")
    if image.dtype == bool or image.dtype.kind not in "uif":
        raise InvalidInputError(f"the image must be of numbers, got dtype {image.dtype}")
    q = _quad(corners, image.shape[:2])
    if size is None:
        sides = np.hypot(*(np.roll(q, -1, axis=0) - q).T)  # top, right, bottom, left
        size = (max(int(round((sides[0] + sides[2]) / 2)), 2), max(int(round((sides[1] + sides[3]) / 2)), 2))
    if (
        not isinstance(size, (tuple, list))
        or len(size) != 2
        or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in size)
        or not all(2 <= v <= MAX_RECTIFY_SIDE for v in size)
    ):
        raise InvalidInputError(f"size must be (width, height) in pixels, 2 to {MAX_RECTIFY_SIDE}, got {size!r}")
    w, h = int(size[0]), int(size[1])
    target = np.array([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]], np.float32)
    matrix = cv2.getPerspectiveTransform(q.astype(np.float32), target)
    source = image.astype(np.float32) if image.dtype.kind == "f" and image.dtype != np.float32 else image
    if source.dtype.kind in "ui" and source.dtype not in (np.uint8, np.uint16, np.int16):
        source = source.astype(np.float32)
    out = cv2.warpPerspective(source, matrix, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    if image.ndim == 3 and out.ndim == 2:  # one channel comes back without its axis
        out = out[:, :, None]
    return out.astype(image.dtype, copy=False)
