"""What each texel of a tree's UV atlas is on the surface: its point, its branch axis carried into
the atlas (the flow field of the synthesis), its scale, and, for the texels just outside a chart,
the texel of the other chart that shows their surface point (the links that make the two sides
of a chart border one piece of bark; mazzolini2012 §4.2, §3.1.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.synth import OutputLinks
from barkgen.tree.mesh import TreeMesh

#: texels beyond a chart's border that are linked across it (the synthesis's neighbourhoods
#: reach this far)
GUTTER = 4
#: how the plates widen with the branch's radius (scale ~ radius ** this), when asked
RADIUS_EXPONENT = 0.5


@dataclass
class TexelMap:
    """The surface behind each texel of an atlas.

    Attributes
    ----------
    shape : tuple of int
        ``(H, W)``.
    covered : ndarray of bool, shape (H, W)
        Texels inside a chart.
    triangle : ndarray of int32, shape (H, W)
        The triangle a texel is in (or, in a gutter, extrapolated from); -1 elsewhere.
    positions : ndarray of float32, shape (H, W, 3)
        Each texel's surface point (metres); NaN away from the charts.
    flow : ndarray of float32, shape (H, W)
        Degrees by which the photo is turned so that its upright fissures run along the branch
        axis (mod 180: bark reads the same upside down), every texel given its nearest chart
        texel's.
    scale : ndarray of float32, shape (H, W)
        The bark's scale (1 = the photo's): its real size at the atlas's median density (times
        the branch's radius, when asked).
    links : OutputLinks
        Gutter texel -> the texel of the other chart at its surface point.
    texels_per_metre : float
        The atlas's median density.
    """

    shape: tuple[int, int]
    covered: np.ndarray
    triangle: np.ndarray
    positions: np.ndarray
    flow: np.ndarray
    scale: np.ndarray
    links: OutputLinks
    texels_per_metre: float


def _jacobians(mesh: TreeMesh, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle: the map ``(2, 3)`` from surface directions (metres) to atlas directions
    (column, row texels), and its texels per metre."""
    p = mesh.vertices.astype(np.float64)[mesh.faces]
    edges = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=2)  # (m, 3, 2)
    uv_edges = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]], axis=2)  # (m, 2, 2)
    gram = np.einsum("mki,mkj->mij", edges, edges)
    det = gram[:, 0, 0] * gram[:, 1, 1] - gram[:, 0, 1] ** 2
    ok = det > 1e-24
    inverse = np.zeros_like(gram)
    safe = np.where(ok, det, 1.0)
    inverse[:, 0, 0], inverse[:, 1, 1] = gram[:, 1, 1] / safe, gram[:, 0, 0] / safe
    inverse[:, 0, 1] = inverse[:, 1, 0] = -gram[:, 0, 1] / safe
    jacobian = np.einsum("mij,mjk,mlk->mil", uv_edges, inverse, edges)
    area_3d = 0.5 * np.linalg.norm(np.cross(edges[:, :, 0], edges[:, :, 1]), axis=1)
    area_uv = 0.5 * np.abs(uv_edges[:, 0, 0] * uv_edges[:, 1, 1] - uv_edges[:, 0, 1] * uv_edges[:, 1, 0])
    density = np.sqrt(area_uv / np.maximum(area_3d, 1e-18))
    return np.where(ok[:, None, None], jacobian, 0.0), np.where(ok, density, 0.0)


def _barycentric(corners: np.ndarray, triangle: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of texel centres ``(rows, cols)`` in their ``triangle``'s
    corners, outside it too (negative weights: the triangle's plane extended)."""
    c = corners[triangle]  # (n, 3, 2)
    px, py = cols + 0.5, rows + 0.5
    x0, y0, x1, y1, x2, y2 = c[:, 0, 0], c[:, 0, 1], c[:, 1, 0], c[:, 1, 1], c[:, 2, 0], c[:, 2, 1]
    det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
    det = np.where(np.abs(det) < 1e-12, 1e-12, det)
    b0 = ((y1 - y2) * (px - x2) + (x2 - x1) * (py - y2)) / det
    b1 = ((y2 - y0) * (px - x2) + (x0 - x2) * (py - y2)) / det
    return np.stack([b0, b1, 1.0 - b0 - b1], axis=1)


def texel_map(
    mesh: TreeMesh,
    shape: tuple[int, int],
    *,
    photo_width_px: int,
    bark_width_m: float | None = None,
    scale_with_radius: bool = False,
) -> TexelMap:
    """The :class:`TexelMap` of ``mesh``'s atlas at ``shape`` ``(H, W)``.

    Parameters
    ----------
    mesh : TreeMesh
    shape : tuple of int
    photo_width_px : int
        The photo's width: with ``bark_width_m``, its pixels per metre.
    bark_width_m : float, optional
        How many metres of bark the photo's width shows (default: as many as the photo has
        pixels at the atlas's median texels per metre: the bark at the photo's resolution).
    scale_with_radius : bool
        Wider plates where the branch is thicker (scale ~ sqrt of the radius over the median;
        meshes with known radii, the built-in tree's).

    Returns
    -------
    TexelMap

    Raises
    ------
    InvalidInputError
        UVs outside [0, 1], an atlas no texel of which lies in a triangle, or a bark size the
        engine cannot draw at this atlas size.
    """
    from scipy import ndimage

    from barkgen.synth import FLOW_SCALE_RANGE
    from barkgen.tree._kernels import rasterize

    h, w = (int(v) for v in shape)
    uv = mesh.uv.astype(np.float64)
    if uv.size and (uv.min() < -1e-3 or uv.max() > 1.0 + 1e-3):
        raise InvalidInputError("the mesh's UVs leave the unit square; an atlas must lie in [0, 1]")
    corners = (uv * [w, h])[mesh.faces]  # (m, 3, 2): column, row
    triangle = np.full((h, w), -1, np.int32)
    bary = np.zeros((h, w, 3), np.float64)
    if rasterize(corners, h, w, triangle, bary) == 0:
        raise InvalidInputError("no texel of the atlas lies in a triangle: is the mesh's UV atlas empty?")
    covered = triangle >= 0
    jacobian, density = _jacobians(mesh, corners)
    # each texel's nearest covered texel, and the gutter within GUTTER of a chart
    distance, (near_rows, near_cols) = ndimage.distance_transform_edt(~covered, return_indices=True)
    gutter = ~covered & (distance <= GUTTER)
    tri = np.where(covered, triangle, triangle[near_rows, near_cols])
    rows, cols = np.nonzero(covered | gutter)
    weights = np.zeros((h, w, 3), np.float64)
    weights[covered] = bary[covered]
    gy, gx = np.nonzero(gutter)
    weights[gy, gx] = _barycentric(corners, tri[gy, gx], gy, gx)
    verts = mesh.faces[tri[rows, cols]]  # (n, 3)
    wts = weights[rows, cols][:, :, None]
    positions = np.full((h, w, 3), np.nan, np.float32)
    positions[rows, cols] = (wts * mesh.vertices.astype(np.float64)[verts]).sum(axis=1)
    # the branch axis at the texel (a gutter texel takes its nearest chart texel's) into the atlas
    axis_texel = (np.clip(wts, 0.0, None) * mesh.axis.astype(np.float64)[verts]).sum(axis=1)
    direction = np.einsum("nij,nj->ni", jacobian[tri[rows, cols]], axis_texel)
    angle = np.degrees(np.arctan2(-direction[:, 1], direction[:, 0])) - 90.0
    flow = np.zeros((h, w), np.float32)
    flow[rows, cols] = np.mod(angle + 90.0, 180.0) - 90.0
    # the bark's real size: the photo's pixels per metre against each texel's texels per metre
    median_density = float(np.median(density[triangle[covered]]))
    if bark_width_m is None:  # the photo at its own resolution where the atlas is at its median
        bark_width_m = photo_width_px / median_density
    if not bark_width_m > 0:
        raise InvalidInputError(f"the bark's width must be a positive number of metres, not {bark_width_m}")
    photo_per_metre = photo_width_px / bark_width_m
    scale = np.ones((h, w), np.float32)
    # one scale over the atlas, at its median density: xatlas scales its charts to one density,
    # and its conformal maps stretch areas within a chart a little (following that stretch took
    # five scales of the photo, and with them the angles down to 30 degrees apart)
    scale[rows, cols] = median_density / photo_per_metre
    if scale_with_radius and np.isfinite(mesh.radius).all():
        radius = (np.clip(wts, 0.0, None)[:, :, 0] * mesh.radius.astype(np.float64)[verts]).sum(axis=1)
        scale[rows, cols] *= (radius / np.median(radius)) ** RADIUS_EXPONENT
    # away from the charts: the nearest chart texel's field (no copies made for nothing)
    outside = ~(covered | gutter)
    flow[outside] = flow[near_rows[outside], near_cols[outside]]
    scale[outside] = scale[near_rows[outside], near_cols[outside]]
    low, high = FLOW_SCALE_RANGE
    if np.median(scale[covered]) < low * 1.05 or np.median(scale[covered]) > high / 1.05:
        raise InvalidInputError(
            f"at {w}x{h} texels the bark would be drawn at {np.median(scale[covered]):.2f}x the photo's scale "
            f"(it must be {low:g} to {high:g}): change the atlas size or the bark's width ({bark_width_m:.3g} m)"
        )
    scale = np.clip(scale, low, high)
    links = _gutter_links(positions, covered, gutter, median_density)
    return TexelMap((h, w), covered, np.where(covered | gutter, tri, -1), positions, flow, scale, links, median_density)


def _gutter_links(positions: np.ndarray, covered: np.ndarray, gutter: np.ndarray, density: float) -> OutputLinks:
    """Each gutter texel linked to the chart texel nearest to its surface point, where that is
    within two texels of it (else the chart's border is the surface's own: no link)."""
    from scipy.spatial import cKDTree

    h, w = covered.shape
    inside = np.flatnonzero(covered)
    outside = np.flatnonzero(gutter)
    points = positions.reshape(-1, 3)
    distance, nearest = cKDTree(points[inside]).query(points[outside])
    keep = distance <= 2.0 / max(density, 1e-12)
    return OutputLinks((h, w), outside[keep].astype(np.int64), inside[nearest[keep]].astype(np.int64))


#: the grid (texels) on which the charts' height correction is solved (it is smooth)
LEVEL_CELL = 8


def level_charts(height: np.ndarray, texels: TexelMap) -> np.ndarray:
    """A height map of the atlas corrected so that the heights on either side of every chart
    border agree on the surface. The solver's height is integrated in the gradient domain over
    the flat atlas, where charts lie apart, so each chart drifts from its neighbours on the
    surface; a smooth correction per chart (a membrane, solved on a grid of
    :data:`LEVEL_CELL` texels and interpolated within each chart) pulls the linked texel pairs
    together. Gutter texels then take their source's height."""
    from scipy import ndimage, sparse
    from scipy.sparse.linalg import spsolve

    h, w = texels.shape
    charts, count = ndimage.label(texels.covered)
    if count == 0 or texels.links.target.size == 0:
        return height
    cell = LEVEL_CELL
    ch, cw = -(-h // cell), -(-w // cell)
    # each grid cell belongs to the chart most of its texels are in
    padded = np.zeros((ch * cell, cw * cell), np.int64)
    padded[:h, :w] = charts
    blocks = padded.reshape(ch, cell, cw, cell).transpose(0, 2, 1, 3).reshape(ch, cw, -1)
    votes = np.zeros((ch, cw, count + 1), np.int32)
    for label in range(1, count + 1):
        votes[..., label] = (blocks == label).sum(axis=2)
    cell_chart = np.where(votes[..., 1:].max(axis=2) > 0, votes[..., 1:].argmax(axis=2) + 1, 0)
    index = np.full((ch, cw), -1, np.int64)
    used = cell_chart > 0
    index[used] = np.arange(int(used.sum()))
    n = int(used.sum())
    rows, cols, values = [], [], []
    # the membrane: neighbouring cells of one chart move together
    for dy, dx in ((0, 1), (1, 0)):
        a = index[: ch - dy, : cw - dx]
        b = index[dy:, dx:]
        same = (a >= 0) & (b >= 0) & (cell_chart[: ch - dy, : cw - dx] == cell_chart[dy:, dx:])
        a, b = a[same], b[same]
        rows += [a, b, a, b]
        cols += [a, b, b, a]
        values += [np.ones(a.size), np.ones(a.size), -np.ones(a.size), -np.ones(a.size)]
    # the links: the two texels of a pair at one height
    _, (near_rows, near_cols) = ndimage.distance_transform_edt(~texels.covered, return_indices=True)
    gy, gx = np.divmod(texels.links.target, w)
    ay, ax = near_rows[gy, gx], near_cols[gy, gx]
    sy, sx = np.divmod(texels.links.source, w)
    ca, cs = index[ay // cell, ax // cell], index[sy // cell, sx // cell]
    keep = (ca >= 0) & (cs >= 0) & (charts[ay, ax] != charts[sy, sx])
    ca, cs = ca[keep], cs[keep]
    difference = height[sy[keep], sx[keep]].astype(np.float64) - height[ay[keep], ax[keep]]
    rows += [ca, cs, ca, cs]
    cols += [ca, cs, cs, ca]
    values += [np.ones(ca.size), np.ones(ca.size), -np.ones(ca.size), -np.ones(ca.size)]
    right = np.zeros(n)
    np.add.at(right, ca, difference)
    np.add.at(right, cs, -difference)
    system = (
        sparse.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
        + sparse.identity(n) * 1e-4
    )  # (a chart with no link keeps its height)
    correction = np.zeros((ch, cw))
    correction[used] = spsolve(system.tocsc(), right)
    # back to texels: interpolated within each chart only (a neighbouring chart in the flat
    # atlas is no neighbour on the surface)
    fine = np.zeros((h, w))
    for label, box in enumerate(ndimage.find_objects(cell_chart), start=1):
        if box is None:
            continue
        y0, y1 = max(box[0].start - 1, 0), min(box[0].stop + 1, ch)
        x0, x1 = max(box[1].start - 1, 0), min(box[1].stop + 1, cw)
        mine = (cell_chart[y0:y1, x0:x1] == label).astype(np.float64)
        # the texels of these cells: cell centres at (i + 0.5) * cell, linear between them
        ty = (np.arange(y0 * cell, min(y1 * cell, h)) + 0.5) / cell - 0.5 - y0
        tx = (np.arange(x0 * cell, min(x1 * cell, w)) + 0.5) / cell - 0.5 - x0
        grid = np.meshgrid(np.clip(ty, 0, y1 - y0 - 1), np.clip(tx, 0, x1 - x0 - 1), indexing="ij")
        weight = ndimage.map_coordinates(mine, grid, order=1)
        value = ndimage.map_coordinates(correction[y0:y1, x0:x1] * mine, grid, order=1)
        region = (slice(y0 * cell, min(y1 * cell, h)), slice(x0 * cell, min(x1 * cell, w)))
        inside = charts[region] == label
        fine[region][inside] = value[inside] / np.maximum(weight[inside], 1e-6)
    out = height.astype(np.float64) + fine
    flat = out.reshape(-1)
    flat[texels.links.target] = flat[texels.links.source]
    return out.astype(height.dtype)
