"""Branching structures: polylines with a thickness per vertex (sibbing2010 §3, §4.1).

A :class:`Structure` is a list of :class:`Branch` es, each a polyline ``points`` of
``(x, y, thickness)`` rows in pixels of the image it belongs to, uniformly resampled at the
structure's ``step`` h. A branch may start on a vertex of an earlier branch (``parent``,
``parent_vertex``: a furcation, §4.1) and, beyond the paper, may end on one (``joins``,
``join_vertex``: a merge, as in dried mud or reticulate bark, where the paper's tree model
cannot go).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TypeGuard

import numpy as np

from barkgen.errors import InvalidInputError

STRUCTURE_VERSION = 1


@dataclass
class Branch:
    """One branch: ``points`` is a float ``(n, 3)`` array of ``x, y, thickness`` rows."""

    points: np.ndarray
    parent: int | None = None
    parent_vertex: int | None = None
    joins: int | None = None
    join_vertex: int | None = None

    @property
    def xy(self) -> np.ndarray:
        return self.points[:, :2]

    @property
    def thickness(self) -> np.ndarray:
        return self.points[:, 2]

    def length(self) -> float:
        """Arc length in pixels."""
        if len(self.points) < 2:
            return 0.0
        return float(np.hypot(*np.diff(self.xy, axis=0).T).sum())


@dataclass
class Structure:
    """A branching structure in an image of ``size = (width, height)`` pixels.

    ``periodic``: the image is a torus (a tileable output, :func:`~barkgen.branching.grow_structure`
    with ``tile``): branches run on across its edges, their points outside ``[0, width) x
    [0, height)`` stand for the same places modulo the size, and :func:`rasterize` folds them.
    """

    step: float
    size: tuple[int, int]
    branches: list[Branch] = field(default_factory=list)
    periodic: bool = False

    @property
    def width(self) -> int:
        return int(self.size[0])

    @property
    def height(self) -> int:
        return int(self.size[1])

    def total_length(self) -> float:
        return float(sum(b.length() for b in self.branches))

    def n_vertices(self) -> int:
        return int(sum(len(b.points) for b in self.branches))

    def junctions(self) -> int:
        """Number of furcations plus merges (branch ends on another branch)."""
        return int(sum((b.parent is not None) + (b.joins is not None) for b in self.branches))

    def free_ends(self, margin: float = 3.0) -> int:
        """Branch ends connected to nothing: starts without a parent and ends without a merge,
        farther than ``margin`` px from the image border (where a crack just leaves the image;
        a periodic structure has no border). Closed cells, as in dried mud, have few."""
        w, h = self.width, self.height

        def inside(p: np.ndarray) -> bool:
            return self.periodic or (margin < p[0] < w - 1 - margin and margin < p[1] < h - 1 - margin)

        return int(
            sum(
                (b.parent is None and inside(b.points[0])) + (b.joins is None and inside(b.points[-1]))
                for b in self.branches
                if len(b.points)
            )
        )

    def to_dict(self) -> dict:
        """The JSON form of the issue: version, step, size and branches."""
        out = []
        for b in self.branches:
            item = {
                "parent": b.parent,
                "parent_vertex": b.parent_vertex,
                "points": [[round(float(x), 3), round(float(y), 3), round(float(t), 3)] for x, y, t in b.points],
            }
            if b.joins is not None:
                item["joins"] = b.joins
                item["join_vertex"] = b.join_vertex
            out.append(item)
        head = {"version": STRUCTURE_VERSION, "step": float(self.step), "size": [self.width, self.height]}
        if self.periodic:
            head["periodic"] = True
        return {**head, "branches": out}

    @classmethod
    def from_dict(cls, data: object, where: str = "structure") -> Structure:
        """Validate and build a structure from its JSON form; errors are one clear line."""
        if not isinstance(data, dict):
            raise InvalidInputError(f"{where}: expected a JSON object with version, step, size, branches")
        unknown = set(data) - {"version", "step", "size", "branches", "periodic"}
        if unknown:
            raise InvalidInputError(f"{where}: unknown key(s) {', '.join(sorted(map(str, unknown)))}")
        if data.get("version") != STRUCTURE_VERSION:
            raise InvalidInputError(f"{where}: version must be {STRUCTURE_VERSION}, got {data.get('version')!r}")
        step = data.get("step")
        if not _is_number(step) or not 0.25 <= float(step) <= 64:
            raise InvalidInputError(f"{where}: step must be a number of pixels in [0.25, 64], got {step!r}")
        size = data.get("size")
        if (
            not isinstance(size, list)
            or len(size) != 2
            or not all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 65536 for v in size)
        ):
            raise InvalidInputError(f"{where}: size must be [width, height] in pixels, got {size!r}")
        branches = data.get("branches")
        if not isinstance(branches, list):
            raise InvalidInputError(f"{where}: branches must be a list")
        if not branches:
            raise InvalidInputError(f"{where}: the structure is empty (no branches)")
        built = []
        for i, item in enumerate(branches):
            built.append(_branch_from_dict(item, i, len(branches), f"{where}: branch {i}"))
        periodic = data.get("periodic", False)
        if not isinstance(periodic, bool):
            raise InvalidInputError(f"{where}: periodic must be true or false, got {periodic!r}")
        structure = cls(float(step), (size[0], size[1]), built, periodic=periodic)
        structure.validate(where)
        return structure

    def validate(self, where: str = "structure") -> None:
        """Check links to other branches and vertex indices."""
        if not self.branches:
            raise InvalidInputError(f"{where}: the structure is empty (no branches)")
        for i, b in enumerate(self.branches):
            for ref, vertex, what in ((b.parent, b.parent_vertex, "parent"), (b.joins, b.join_vertex, "joins")):
                if ref is None:
                    continue
                if not 0 <= ref < len(self.branches) or ref == i:
                    raise InvalidInputError(f"{where}: branch {i} {what} {ref} is not another branch")
                if vertex is None or not 0 <= vertex < len(self.branches[ref].points):
                    raise InvalidInputError(
                        f"{where}: branch {i} {what} vertex {vertex} is outside "
                        f"branch {ref} (0..{len(self.branches[ref].points) - 1})"
                    )


def junction_radius(parent_thickness: float, child_thickness: float, step: float) -> float:
    """Around a furcation a child may touch its parent: within the two thicknesses plus one
    step of the furcation point (growth allows it there; intersection counts ignore it)."""
    return parent_thickness + child_thickness + step


def _is_number(v: object) -> TypeGuard[float]:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and bool(np.isfinite(v))


def _branch_from_dict(item: object, index: int, n: int, where: str) -> Branch:
    if not isinstance(item, dict):
        raise InvalidInputError(f"{where}: expected an object with parent, parent_vertex, points")
    unknown = set(item) - {"parent", "parent_vertex", "points", "joins", "join_vertex"}
    if unknown:
        raise InvalidInputError(f"{where}: unknown key(s) {', '.join(sorted(map(str, unknown)))}")
    for key in ("parent", "parent_vertex", "joins", "join_vertex"):
        v = item.get(key)
        if v is not None and (not isinstance(v, int) or isinstance(v, bool) or v < 0):
            raise InvalidInputError(f"{where}: {key} must be null or a non-negative integer, got {v!r}")
    if (item.get("parent") is None) != (item.get("parent_vertex") is None):
        raise InvalidInputError(f"{where}: parent and parent_vertex must both be set or both be null")
    if (item.get("joins") is None) != (item.get("join_vertex") is None):
        raise InvalidInputError(f"{where}: joins and join_vertex must both be set or both be null")
    pts = item.get("points")
    if (
        not isinstance(pts, list)
        or len(pts) < 2
        or not all(isinstance(p, list) and len(p) == 3 and all(_is_number(v) for v in p) for p in pts)
    ):
        raise InvalidInputError(f"{where}: points must be a list of at least two [x, y, thickness] numbers")
    arr = np.asarray(pts, np.float64)
    if (arr[:, 2] <= 0).any():
        raise InvalidInputError(f"{where}: thickness must be > 0")
    return Branch(arr, item.get("parent"), item.get("parent_vertex"), item.get("joins"), item.get("join_vertex"))


def resample_polyline(points: np.ndarray, step: float) -> np.ndarray:
    """Resample ``(n, 3)`` ``x, y, thickness`` rows at a constant arc-length ``step`` (§4.1).

    The first vertex is kept; the thickness is interpolated linearly along the arc. A polyline
    shorter than one step comes back as its two end points.
    """
    points = np.asarray(points, np.float64)
    seg = np.hypot(*np.diff(points[:, :2], axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    if total < step:
        return points[[0, -1]].copy()
    n = int(np.floor(total / step + 1e-9))
    t = np.arange(n + 1) * step
    return np.stack([np.interp(t, s, points[:, c]) for c in range(3)], axis=1)


def turning_angles(xy: np.ndarray) -> np.ndarray:
    """Signed angle (radians, in (-pi, pi]) between successive edges, one per inner vertex."""
    d = np.diff(xy, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0])
    return np.angle(np.exp(1j * np.diff(heading)))


def rasterize(
    structure: Structure, shape: tuple[int, int] | None = None, *, scale: float = 1.0, min_radius: float = 0.5
) -> np.ndarray:
    """Boolean ``(H, W)`` mask of every pixel within its branch's thickness of the skeleton.

    ``thickness`` is the half-width (radius) of the branch at a vertex. A
    :attr:`~Structure.periodic` structure is drawn on the torus: each segment is moved by whole
    periods next to the image, drawn on a canvas with a margin, and the margin folded back onto
    the opposite edges, so the mask tiles.
    """
    import cv2

    h, w = shape if shape is not None else (structure.height, structure.width)
    ends, widths = [], []
    for b in structure.branches:
        p = b.points
        if len(p) < 2:
            continue
        r = np.maximum((p[:-1, 2] + p[1:, 2]) / 2 * scale, min_radius)
        segments = np.stack([p[:-1, :2], p[1:, :2]], axis=1)
        ends.append(segments)
        widths.append(np.maximum(1, np.round(2 * r)).astype(np.int64))
    if not ends:
        return np.zeros((h, w), bool)
    segments = np.concatenate(ends)
    width = np.concatenate(widths)
    margin = 0
    if structure.periodic:  # each segment's start moved into the image by whole periods
        segments = segments - np.floor(segments[:, :1] / (w, h)) * (w, h)
        reach = np.abs(segments[:, 1] - segments[:, 0]).max() if len(segments) else 0.0
        margin = int(np.ceil(reach + width.max())) + 2
    canvas = np.zeros((h + 2 * margin, w + 2 * margin), np.uint8)
    fixed = np.round((segments + margin) * 16).astype(np.int32)  # 4 fractional bits (cv2 shift=4)
    for t in np.unique(width):  # one call per line width
        cv2.polylines(canvas, list(fixed[width == t]), False, 1, thickness=int(t), lineType=cv2.LINE_8, shift=4)
    if margin:
        canvas = _fold(canvas, margin, (h, w))
    return canvas.astype(bool)


def _fold(canvas: np.ndarray, margin: int, shape: tuple[int, int]) -> np.ndarray:
    """A canvas drawn with ``margin`` px around an ``(h, w)`` torus, its margins OR-ed onto the
    opposite edges (the margin may exceed the image: it wraps as often as needed)."""
    h, w = shape
    rows = (np.arange(canvas.shape[0]) - margin) % h
    cols = (np.arange(canvas.shape[1]) - margin) % w
    out = np.zeros((h, canvas.shape[1]), np.uint8)
    np.maximum.at(out, rows, canvas)
    folded = np.zeros((w, h), np.uint8)
    np.maximum.at(folded, cols, out.T)
    return folded.T.copy()
