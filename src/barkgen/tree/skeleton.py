"""The built-in tree: a skeleton of tapered limbs, its surface as a smooth implicit union, and
the branch axis and radius at any point of it.

A limb is a segment from ``start`` to ``end`` whose radius goes linearly from ``r0`` to ``r1``
(a cone-sphere). The surface is the zero level of the limbs' signed distances joined by a
polynomial smooth minimum (Quilez 2013), so a branch grows out of the trunk through a collar,
not a crease (mazzolini2012 §3.1.4: no seams where branches join); marching cubes
(scikit-image) turns it into a mesh. The same soft membership gives every surface point its
branch axis and radius, blended through the collars.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from barkgen.errors import InvalidInputError

#: metres over which two limbs' surfaces blend into a collar
COLLAR = 0.08
#: the marching-cubes cell (metres) of the built-in tree (with the smoothing that follows, xatlas
#: cuts it into about 24 charts in 5 s; at 0.02 m, 250 charts in 12 s)
CELL = 0.03


@dataclass(frozen=True)
class Limb:
    """One limb: a segment ``start`` -> ``end`` (metres, y up) with radii ``r0`` -> ``r1``."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    r0: float
    r1: float


@dataclass(frozen=True)
class Skeleton:
    """The limbs of a tree, the trunk first."""

    limbs: tuple[Limb, ...]

    def bounds(self, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """The box ``(low, high)`` round every limb, ``margin`` metres wider."""
        points = np.array([p for limb in self.limbs for p in (limb.start, limb.end)], np.float64)
        radius = max(max(limb.r0, limb.r1) for limb in self.limbs)
        return points.min(axis=0) - radius - margin, points.max(axis=0) + radius + margin


def default_skeleton(seed: int = 0) -> Skeleton:
    """A trunk 3 m tall with two branches and a twig, their angles and lengths varied a little
    by ``seed``."""
    rng = np.random.default_rng([int(seed), 34])
    jitter = rng.uniform(-1.0, 1.0, 8)
    trunk = Limb((0.0, -0.2, 0.0), (0.0, 3.0, 0.0), 0.26, 0.12)

    def branch(height: float, tilt: float, heading: float, length: float, r0: float, r1: float) -> Limb:
        tilt, heading = math.radians(tilt), math.radians(heading)
        direction = (math.sin(tilt) * math.cos(heading), math.cos(tilt), math.sin(tilt) * math.sin(heading))
        start = (0.0, height, 0.0)
        end = tuple(s + length * d for s, d in zip(start, direction, strict=True))
        return Limb(start, end, r0, r1)  # type: ignore[arg-type]

    return Skeleton(
        (
            trunk,
            branch(1.2 + 0.1 * jitter[0], 48 + 6 * jitter[1], 10 + 20 * jitter[2], 1.5 + 0.1 * jitter[3], 0.12, 0.05),
            branch(1.9 + 0.1 * jitter[4], 42 + 6 * jitter[5], 190 + 20 * jitter[6], 1.3 + 0.1 * jitter[7], 0.10, 0.045),
            branch(2.5, 35, 100, 0.7, 0.06, 0.03),
        )
    )


def _limb_distance(limb: Limb, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The signed distance of ``points`` (n, 3) to the limb's surface and their parameter along
    it (0 at ``start``, 1 at ``end``)."""
    a, b = np.asarray(limb.start), np.asarray(limb.end)
    axis = b - a
    t = np.clip(((points - a) @ axis) / float(axis @ axis), 0.0, 1.0)
    nearest = a + t[:, None] * axis
    radius = limb.r0 + (limb.r1 - limb.r0) * t
    return np.linalg.norm(points - nearest, axis=1) - radius, t


def _smooth_min(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def skeleton_field(skeleton: Skeleton, points: np.ndarray) -> np.ndarray:
    """The implicit surface's value at ``points`` (n, 3): negative inside the tree."""
    value = None
    for limb in skeleton.limbs:
        d, _ = _limb_distance(limb, points)
        value = d if value is None else _smooth_min(value, d, COLLAR)
    assert value is not None
    return value


def axis_and_radius(skeleton: Skeleton, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each point's branch axis (unit, from a limb's start to its end: up and out) and its
    limb's radius there, blended between limbs by how near the point is to each (soft
    membership over the collar's width), so they turn smoothly through a collar."""
    weights, axes, radii = [], [], []
    for limb in skeleton.limbs:
        d, t = _limb_distance(limb, points)
        axis = np.asarray(limb.end, np.float64) - np.asarray(limb.start, np.float64)
        axes.append(np.broadcast_to(axis / np.linalg.norm(axis), points.shape))
        radii.append(limb.r0 + (limb.r1 - limb.r0) * t)
        weights.append(np.exp(-np.maximum(d, 0.0) / (COLLAR / 3.0)))
    w = np.stack(weights)
    w /= np.maximum(w.sum(axis=0, keepdims=True), 1e-12)
    axis = np.einsum("ln,lnc->nc", w, np.stack(axes))
    axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-12)
    return axis, (w * np.stack(radii)).sum(axis=0)


def skeleton_surface(skeleton: Skeleton, cell: float = CELL) -> tuple[np.ndarray, np.ndarray]:
    """The tree's surface as a triangle mesh: ``(vertices (n, 3) float32 metres, faces (m, 3))``,
    counter-clockwise seen from outside, by marching cubes over cells of ``cell`` metres."""
    from skimage.measure import marching_cubes

    if not 0.004 <= cell <= 0.2:
        raise InvalidInputError(f"the tree's cell must be 0.004 to 0.2 m, not {cell}")
    low, high = skeleton.bounds(3 * cell)
    counts = np.ceil((high - low) / cell).astype(int) + 1
    axes = [low[i] + cell * np.arange(counts[i]) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    volume = skeleton_field(skeleton, grid).reshape(tuple(counts)).astype(np.float32)
    vertices, faces, _, _ = marching_cubes(volume, level=0.0, spacing=(cell, cell, cell))
    vertices = vertices + low
    return vertices.astype(np.float32), faces.astype(np.int64)
