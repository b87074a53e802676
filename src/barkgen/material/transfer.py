"""The material set of a texture synthesized from a photo, through its reference map.

The photo's albedo, height and roughness are
carried to the output through the synthesis's reference map — the same exemplar pixel for
every map, so all maps are aligned with the colour by construction — and normals and the
height's AO are recomputed from the carried height, wrapping when the texture tiles, so they
tile too (the AO's photo cavities are carried like the colour).
"""

from __future__ import annotations

import functools

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen._shared.canvas import Canvas
from barkgen._shared.threads import side_by_side
from barkgen.material.maps import AO_RADIUS
from barkgen.material.materialset import MaterialSet, derived_maps


def transfer_material(
    source: MaterialSet,
    references: np.ndarray,
    canvas: Canvas,
    *,
    ao_radius: int = AO_RADIUS,
    blend: str = "gradient",
) -> MaterialSet:
    r"""The material set of a texture synthesized from the source's photo.

    The source's albedo goes through the synthesis's reference map as the colour does (its
    seams blended in the gradient domain, :func:`barkgen.synth.blend_seams`, unless
    ``blend`` is ``"none"``: then exactly);
    its height, roughness and the AO's photo cavities through the same references in the
    gradient domain (:func:`barkgen.synth.resolve_continuous`: continuous across the
    borders of the copied pieces, tileable when the canvas tiles); normals and the height's AO
    are recomputed from that height (wrapping when it tiles).

    Parameters
    ----------
    source : MaterialSet
        The photo's set (:func:`make_material`).
    references : ndarray of int, shape (H, W, 2)
        The synthesis's reference map, exemplar ``(y, x)`` per output pixel.
    canvas : Canvas
        The texture's: ``tile`` (it tiles) and ``exemplar_wrap``, ``(rows, columns)``, the axes
        the photo tiles along (None: neither).
    ao_radius : int, default AO_RADIUS
        Reach of the recomputed occlusion in px.
    blend : {"gradient", "none"}, default "gradient"
        How the albedo is carried (as the texture's colour).

    Returns
    -------
    MaterialSet
        The output's set, of the reference map's size.

    References
    ----------
    .. [1] laitoch2018, §3.3.1 (maps resolved through the reference map).
    .. [2] perez2003 (gradient-domain re-integration).
    """
    from barkgen.synth import apply_references, blend_seams, check_blend, resolve_continuous

    check_blend(blend)
    tile = canvas.tile
    refs = np.asarray(references)

    def carry(image: np.ndarray | None) -> np.ndarray | None:
        return None if image is None else resolve_continuous(image, refs, canvas)

    def relief() -> tuple[np.ndarray, dict, np.ndarray | None, np.ndarray | None]:
        # the height's slopes too, so the normals recomputed from it have no creases at the borders
        height = resolve_continuous(source.height, refs, _own_canvas(source, "height", canvas), smooth_slopes=True)
        scanned = _carry_scanned(source, refs, canvas)
        if "normals" in scanned and "ao" in scanned:  # a scan's own: nothing to derive from the height
            return height, scanned, scanned["normals"], scanned["ao"]
        normals, ao = derived_maps(height, Boundary(tile), ao_radius=ao_radius)
        return height, scanned, normals, ao

    def colour() -> np.ndarray:
        return blend_seams(source.color, refs, canvas) if blend == "gradient" else apply_references(refs, source.color)

    # the maps are independent of each other but for the height's own: side by side
    def own(kind: str) -> bool:  # the scan's own map, carried as it is (:func:`_carry_scanned`)
        return getattr(source, kind) is not None and kind in source.scanned

    derived, carried_roughness = not (own("normals") and own("ao")), not own("roughness")
    (height, scanned, normals, ao), color, cavities, roughness, illumination = side_by_side(
        [
            relief,
            colour,
            functools.partial(carry, source.ao_cavities if derived else None),
            functools.partial(carry, source.roughness if carried_roughness else None),
            functools.partial(carry, source.illumination),
        ],
        pixels=refs.shape[0] * refs.shape[1],
    )
    if cavities is not None and not ("normals" in scanned and "ao" in scanned):
        ao = np.clip(ao + cavities, 0.0, 1.0)
    return MaterialSet(
        color=color,
        height=height,
        normals=scanned.get("normals", normals),
        ao=scanned.get("ao", ao),
        roughness=scanned["roughness"] if "roughness" in scanned else roughness,
        tile=tile,
        light=source.light,
        shading_strength=source.shading_strength,
        ao_cavities=cavities,
        metalness=scanned.get("metalness"),
        opacity=scanned.get("opacity"),
        scanned=source.scanned,
        bits=dict(source.bits),
        pixel_size_m=source.pixel_size_m,
        size_given=source.size_given,
        illumination=illumination,
        equalization=source.equalization,
        scan_info=dict(source.scan_info),
    )


def _own_canvas(source: MaterialSet, kind: str, canvas: Canvas) -> Canvas:
    """The ``canvas`` a map is carried on: the photo's wrap, less the axes a scan's map does
    not tile along itself (``source.map_wraps``: across them a piece takes the map's last step
    instead of its step from last row to first, which would draw a line)."""
    own = source.map_wraps.get(kind)
    if own is None or canvas.exemplar_wrap is None:
        return canvas
    wrap = (bool(canvas.exemplar_wrap[0] and own[0]), bool(canvas.exemplar_wrap[1] and own[1]))
    return canvas if wrap == tuple(canvas.exemplar_wrap) else canvas.replace(exemplar_wrap=wrap)


def _carry_scanned(source: MaterialSet, references: np.ndarray, canvas: Canvas) -> dict[str, np.ndarray]:
    """A scanned set's own local maps through the reference map as they are: exact inside the
    copied pieces, continuous across their borders (:func:`barkgen.synth.resolve_local`);
    normals as unit vectors (carried per component, renormalised); each map on its own
    wrap (:func:`_own_canvas`)."""
    kinds = [
        kind
        for kind in ("normals", "ao", "roughness", "metalness", "opacity")
        if getattr(source, kind) is not None and (kind in source.scanned or kind in ("metalness", "opacity"))
    ]
    if not kinds:
        return {}
    carried: dict[str, np.ndarray] = {}
    # one solve per group of maps (their channels side by side: one set of borders and
    # gradients); the levels (roughness, metalness, opacity) with their slopes run on across the
    # borders too: they vary little inside pieces, and a step between pieces stands out (the
    # scans' roughness: 1.63x the inside step without, 1.38x with)
    for group, smooth_slopes in ((("normals", "ao"), False), (("roughness", "metalness", "opacity"), True)):
        by_canvas: dict[tuple, list[str]] = {}  # maps that wrap alike are solved together
        for kind in kinds:
            if kind in group:
                by_canvas.setdefault(tuple(_own_canvas(source, kind, canvas).exemplar_wrap or ()), []).append(kind)
        for members in by_canvas.values():
            carried.update(
                _carry_group(source, members, references, _own_canvas(source, members[0], canvas), smooth_slopes)
            )
    return carried


def _carry_group(
    source: MaterialSet, members: list[str], references: np.ndarray, canvas: Canvas, smooth_slopes: bool
) -> dict[str, np.ndarray]:
    """:func:`_carry_scanned` of maps that wrap alike, their channels side by side."""
    from barkgen.synth import resolve_local

    carried: dict[str, np.ndarray] = {}
    if members:
        layers = [np.asarray(getattr(source, kind), np.float32).reshape(source.shape + (-1,)) for kind in members]
        stacked = resolve_local(np.concatenate(layers, axis=2), references, canvas, smooth_slopes=smooth_slopes)
        start = 0
        for kind, layer in zip(members, layers, strict=True):
            out = stacked[..., start : start + layer.shape[2]]
            start += layer.shape[2]
            if kind == "normals":
                out = out / np.maximum(np.linalg.norm(out, axis=2, keepdims=True), 1e-6)
            else:
                out = np.clip(out[..., 0], 0.0, 1.0)
            carried[kind] = np.ascontiguousarray(out, dtype=np.float32)
    return carried
