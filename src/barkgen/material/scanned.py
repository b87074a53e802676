"""The material set of a scanned set: the scan's own maps, nothing estimated that it has.

A scanned set (:func:`barkgen.io.read_scanned_set`) already holds what :func:`make_material`
estimates from a photo. Its maps become the :class:`MaterialSet` as they are — the colour is the
scan's albedo (no shading removal), the normals, AO, roughness, metalness and opacity are the
scan's — and only what the set lacks is made:

- a height from the scan's displacement, in pixels: the displacement's range is unknown in a
  file, so it is scaled to fit the scan's normals by least squares (their slopes are the
  height's, in pixels); without normals, :data:`DEFAULT_DEPTH` of the width;
- without a displacement, the height is the scan's normals integrated (the least-squares height
  of their slopes, :func:`integrate_normals`), so the relief is still the scan's own;
- with neither, and for any other map the set lacks, the photo estimate of
  :func:`make_material` on the scan's colour.

:func:`transfer_material` then carries the scan's maps through a synthesis's reference map as
they are (:func:`barkgen.synth.resolve_local`) instead of recomputing them.

Tiling is judged per map (:attr:`ScannedSet.wraps <barkgen.io.ScannedSet>`, from each map's own
pixels), not from the colour alone: a map wraps along the axes the colour wraps along *and* it
tiles along itself (:data:`MaterialSet.map_wraps <barkgen.material.MaterialSet>`). A height that
does not tile while its colour does is carried with its last step where a piece runs on across
the colour's edge, not with its step from last row to first (a straight line through the
output's height, normals and AO), and integrated and scaled on its own boundary.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen.material.maps import normal_map
from barkgen.material.materialset import MaterialOptions, MaterialSet, make_material
from barkgen.material.realsize import ASSUMED_PHOTO_WIDTH_M

#: the displacement depth (fraction of the width) of a scan with a height map and no normals
DEFAULT_DEPTH = 0.02
#: screening of the normals' integration: small enough to leave every relief of the scan in the
#: height (a bump of 1000 px would be flattened), large enough to fix the mean
INTEGRATION_SCREENING = 1e-6


def integrate_normals(normals: np.ndarray, boundary: Boundary) -> np.ndarray:
    """The least-squares height (pixels) of a normal map (OpenGL): the field whose forward steps
    best fit the normals' slopes ``-nx/nz`` (along x) and ``ny/nz`` (down the rows), averaged
    between neighbours; on the torus when the ``boundary`` wraps both axes, else with a Neumann
    border; mean 0.

    References
    ----------
    .. [1] Frankot & Chellappa 1988 (integrable height of a gradient field, by transform).
    """
    from barkgen.synth import screened_poisson

    n = np.asarray(normals, np.float64)
    nz = np.maximum(n[..., 2], 0.05)  # a normal grazing the surface would give a vertical cliff
    p, q = -n[..., 0] / nz, n[..., 1] / nz
    torus = boundary.wraps_both
    if torus:
        gx, gy = 0.5 * (p + np.roll(p, -1, 1)), 0.5 * (q + np.roll(q, -1, 0))
    else:
        gx = np.concatenate([0.5 * (p[:, :-1] + p[:, 1:]), p[:, -1:]], axis=1)
        gy = np.concatenate([0.5 * (q[:-1] + q[1:]), q[-1:]], axis=0)
    height = screened_poisson(
        np.zeros(p.shape + (1,)), gy[..., None], gx[..., None], Boundary(torus), screening=INTEGRATION_SCREENING
    )[..., 0]
    return (height - height.mean()).astype(np.float32)


def displacement_depth(displacement: np.ndarray, normals: np.ndarray | None, boundary: Boundary) -> float:
    """The depth (pixels) of a displacement map in [0, 1]: the least-squares scale at which its
    slopes (round the ``boundary``) match the normals' (:data:`DEFAULT_DEPTH` of the width
    without normals)."""
    if normals is None:
        return DEFAULT_DEPTH * displacement.shape[1]
    gx, gy = boundary.gradient(displacement)
    n = np.asarray(normals, np.float64)
    nz = np.maximum(n[..., 2], 0.05)
    p, q = -n[..., 0] / nz, n[..., 1] / nz
    num = float((gx * p).sum() + (gy * q).sum())
    den = float((gx.astype(np.float64) ** 2).sum() + (gy.astype(np.float64) ** 2).sum())
    if den <= 0 or num <= 0:  # a flat displacement, or one inverted against its normals
        return DEFAULT_DEPTH * displacement.shape[1]
    return num / den


#: a scan's file kinds -> the MaterialSet map their precision belongs to
_BITS_OF = {
    "color": "color",
    "normal_gl": "normals",
    "normal_dx": "normals",
    "normal": "normals",
    "roughness": "roughness",
    "gloss": "roughness",
    "specular": "roughness",
    "ao": "ao",
    "metalness": "metalness",
    "opacity": "opacity",
}


def scanned_material(
    scan,
    *,
    wrap: tuple[bool, bool] = (False, False),
    relief: float = 1.0,
    seed: int = 0,
    k: int = 3,
    label_map: np.ndarray | None = None,
) -> MaterialSet:
    """The :class:`MaterialSet` of a scanned set (see the module).

    Parameters
    ----------
    scan : ScannedSet
        The decoded set (:func:`barkgen.io.read_scanned_set`).
    wrap : (bool, bool), default (False, False)
        ``(rows, columns)``: the scan tiles along that axis (its height is integrated on the
        torus when it tiles along both; estimates wrap as it does).
    relief : float, default 1.0
        Multiplies the height (and, where the scan has no normals, its slopes).
    seed : int, default 0
        Seeds the estimate of maps the scan lacks.
    k : int, default 3
        Labels of the estimate's structure cue (maps the scan lacks).
    label_map : ndarray, optional
        The colour's label codes, the estimate's structure cue.

    Returns
    -------
    MaterialSet
        ``scanned`` names the maps that are the scan's own; ``bits`` their files' precision
        where it is 16.

    References
    ----------
    .. [1] laitoch2018, §3.3.1 (extra maps synthesized with the colour).
    """
    from barkgen._shared.checks import check_image

    wraps = (bool(wrap[0]), bool(wrap[1]))
    tile = wraps[0] and wraps[1]
    map_wraps = _map_wraps(scan, wraps)
    # the scan's own height and normals are read on the torus only where they tile both ways
    # (normals that do not tile are integrated on the torus all the same where the colour tiles:
    # with a border, their inconsistency at the edge left a straight band along it, which the
    # pieces carried 600 px long through a 1024 px height and AO)
    boundary = Boundary(all(map_wraps.get("height", wraps)))
    color = check_image(scan.color)
    made: list[MaterialSet] = []

    def estimate() -> MaterialSet:
        """The photo estimate of the maps the scan lacks (made once, when one is needed)."""
        if not made:
            options = MaterialOptions(k=k, seed=seed, relief=relief, exemplar_wrap=wraps)
            made.append(make_material(color, options, label_map=label_map))
        return made[0]

    if scan.height is not None:
        height = (scan.height - np.median(scan.height)) * displacement_depth(scan.height, scan.normals, boundary)
    elif scan.normals is not None:
        height = integrate_normals(scan.normals, boundary)
    else:
        height = estimate().height / relief
    height = (relief * height).astype(np.float32)
    if scan.normals is not None:
        normals = scan.normals
    elif scan.height is not None:
        normals = normal_map(height, boundary=boundary)
    else:
        normals = estimate().normals
    scanned = tuple(scan.maps)
    if scan.height is not None and scan.normals is None:
        scanned += ("normals",)  # the scan's relief, differentiated: carried like the height
    bits = {_BITS_OF[kind]: b for kind, b in scan.bits.items() if kind in _BITS_OF and b == 16}
    return MaterialSet(
        color=color,
        height=height,
        normals=normals.astype(np.float32),
        ao=scan.ao if scan.ao is not None else estimate().ao,
        roughness=scan.roughness if scan.roughness is not None else estimate().roughness,
        metalness=scan.metalness,
        opacity=scan.opacity,
        tile=tile,
        wrap=wraps,
        scanned=tuple(dict.fromkeys(scanned)),
        bits=bits,
        pixel_size_m=ASSUMED_PHOTO_WIDTH_M / color.shape[1],
        map_wraps=map_wraps,
        scan_info=_scan_info(scan, wraps, map_wraps),
    )


def _map_wraps(scan, wraps: tuple[bool, bool]) -> dict[str, tuple[bool, bool]]:
    """The scan's maps that tile along fewer axes than the colour (``wraps``), with the axes
    each does: along both the colour's and its own (:attr:`ScannedSet.wraps`). A normal map
    derived from a height that does not tile wraps as the height does."""
    own = dict(getattr(scan, "wraps", {}) or {})
    if scan.normals is None and "height" in own:  # the normals are the height's slopes
        own["normals"] = own["height"]
    out = {}
    for kind, axes in own.items():
        both = (bool(wraps[0] and axes[0]), bool(wraps[1] and axes[1]))
        if both != wraps:
            out[kind] = both
    return out


def _scan_info(scan, wraps: tuple[bool, bool], map_wraps: dict[str, tuple[bool, bool]]) -> dict:
    """The metadata's ``scanned_info``: how the set was read, and the maps not wrapped."""
    info = dict(getattr(scan, "info", {}) or {})
    if map_wraps:
        info["not_wrapped"] = {
            kind: "".join("yx"[i] for i in (0, 1) if wraps[i] and not axes[i]) for kind, axes in map_wraps.items()
        }
    return info
