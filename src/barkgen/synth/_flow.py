"""Synthesis along orientation and scale fields: bark whose fissures follow a branch, swirl
round a knot or widen where the trunk is thick (mazzolini2012 §3.1.3: "make the direction of
the features of the texture follow the structure of the tree").

Each output pixel may carry an angle (degrees, counter-clockwise as seen on screen: the turn of
the exemplar there, 0 = as in the photo) and a scale (1 = the photo's). The exemplar is
matched in that local frame, as in anisometric synthesis (Lefebvre & Hoppe 2006 §5, whose
"precomputed rotated and scaled exemplar features" this follows): the photo is resampled into
turned and scaled copies, one per angle and scale the field uses (:data:`ANGLE_STEP` degrees and
:data:`SCALE_STEP` apart), laid one above the other in an atlas (:class:`OrientedExemplar`).
Each copy is a label, and each output pixel wants the copy of its angle and scale: the solver
runs as texture-by-numbers on the atlas (laitoch2018 §3.3), so its neighbourhoods, its
k-coherence shifts and its up-sampling are all in the copy's frame, the seams between copies
are cut and blended like any other, and a reference into the atlas still names one pixel of one
copy. With label maps (texture-by-numbers, ``generate``) the labels are the pairs (bark
label, copy).

Where a copy has to be sampled between photo pixels (any turn that is not a multiple of 90°,
any scale but 1) it is resampled bicubically; label maps are sampled at the nearest pixel; normal
maps are resampled as vectors, their tangent components turned with the copy, so lighting stays
right (a scaled copy keeps its slopes: its height is scaled with it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from barkgen.errors import InvalidInputError

#: degrees between the turned copies of the exemplar (the field is followed to within half)
ANGLE_STEP = 15.0
#: the coarser steps tried, in turn, when the fields need more copies than the labels leave
#: room for (a field of many scales, or many labels)
COARSER_ANGLE_STEPS = (20.0, 30.0, 45.0)
#: ratio between the scaled copies (the field's scale is followed to within its square root)
SCALE_STEP = math.sqrt(2.0)
#: the copies together hold at most this many times the exemplar's pixels (each at most the
#: exemplar's size): the analysis costs about this many times a plain one
ATLAS_BUDGET = 4.0
#: no copy is smaller than this a side (or the exemplar, when it is smaller)
MIN_COPY_SIDE = 96
#: rows sampled on above and below each copy in the atlas, never used (:class:`OrientedExemplar`)
COPY_MARGIN = 4
#: scales the field may ask for
FLOW_SCALE_RANGE = (0.25, 4.0)
#: the most copies (angle and scale pairs) one atlas holds: the labels of texture-by-numbers
#: (at most 64 with the void) shared with the bark's labels
MAX_COPIES = 63


def check_flow(
    flow: np.ndarray | None, flow_scale: np.ndarray | None, out_shape: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """The orientation field and the scale field of an output of ``out_shape``, checked.

    Parameters
    ----------
    flow : array_like or None
        ``(H, W)`` angles in degrees (counter-clockwise on screen); None: 0 everywhere.
    flow_scale : array_like or None
        ``(H, W)`` scales in ``FLOW_SCALE_RANGE``; None: 1 everywhere.
    out_shape : tuple of int

    Returns
    -------
    flow, flow_scale : ndarray of float32, shape (H, W)

    Raises
    ------
    InvalidInputError
        A field of another size, not finite, or a scale out of range.
    """
    fields = []
    for name, value, default in (("flow", flow, 0.0), ("flow scale", flow_scale, 1.0)):
        if value is None:
            fields.append(np.full(out_shape, default, np.float32))
            continue
        array = np.asarray(value)
        if array.ndim == 3 and array.shape[2] == 1:
            array = array[..., 0]
        if array.shape != tuple(out_shape):
            raise InvalidInputError(
                f"the {name} field is {_shape_text(array.shape)}; it must be the output's size, "
                f"{out_shape[1]}x{out_shape[0]} (width x height)"
            )
        if array.dtype.kind not in "fiu":
            raise InvalidInputError(f"the {name} field must hold numbers, not {array.dtype}")
        array = array.astype(np.float32)
        if not np.isfinite(array).all():
            bad = np.argwhere(~np.isfinite(array))[0]
            raise InvalidInputError(f"the {name} field is not a number at x={bad[1]}, y={bad[0]}")
        fields.append(array)
    scale = fields[1]
    low, high = FLOW_SCALE_RANGE
    if scale.min() < low or scale.max() > high:
        raise InvalidInputError(
            f"the flow scale field must lie between {low:g} and {high:g} (it holds {scale.min():g} to {scale.max():g})"
        )
    return fields[0], fields[1]


def _shape_text(shape: tuple[int, ...]) -> str:
    return f"{shape[1]}x{shape[0]}" if len(shape) == 2 else "x".join(map(str, shape))


def _bins(flow: np.ndarray, flow_scale: np.ndarray, angle_step: float) -> tuple[np.ndarray, np.ndarray]:
    """Each output pixel's angle bin (its angle is ``bin * angle_step``, in [-180, 180)) and
    scale bin (its scale is ``SCALE_STEP ** bin``)."""
    turns = int(round(360.0 / angle_step))
    angle_bin = np.round(flow / angle_step).astype(np.int64)
    angle_bin = np.mod(angle_bin + turns // 2, turns) - turns // 2
    scale_bin = np.round(np.log(flow_scale) / math.log(SCALE_STEP)).astype(np.int64)
    return angle_bin, scale_bin


def _bin_pairs(angle_bin: np.ndarray, scale_bin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct ``(angle bin, scale bin)`` pairs of the pixels, ``(n, 2)`` in
    ``np.unique(..., axis=0)``'s order, and each pixel's pair (flat), as ``np.unique``'s
    ``return_inverse`` gives it: one integer key per pixel, counted (``np.unique`` of a 4 MP
    field's rows: 0.8-3 s in one call, out of Ctrl-C's reach; this: 0.05 s)."""
    angles, scales = angle_bin.ravel(), scale_bin.ravel()
    first_angle, first_scale = int(angles.min()), int(scales.min())
    span = int(scales.max()) - first_scale + 1
    keys = (angles - first_angle) * span + (scales - first_scale)
    counts = np.bincount(keys)
    present = np.flatnonzero(counts)
    pair_of_key = np.cumsum(counts > 0) - 1
    return np.stack([present // span + first_angle, present % span + first_scale], axis=1), pair_of_key[keys]


@dataclass(frozen=True)
class OrientedExemplar:
    """The exemplar's turned and scaled copies, one above the other in an atlas.

    Attributes
    ----------
    exemplar_shape : tuple of int
        ``(h, w)`` of the exemplar.
    wrap : tuple of bool
        The exemplar tiles along (rows, columns): its copies are cut from its torus.
    angles, scales : tuple of float
        Each copy's turn (degrees, counter-clockwise on screen) and scale.
    centres : tuple of (float, float)
        The exemplar position (row, column) at each copy's centre.
    copy_shape : tuple of int
        ``(h_c, w_c)`` of every copy.
    angle_step : float
        Degrees between the copies' turns.
    margin : int
        Rows sampled on, above and below each copy, that no output pixel may use (they are
        labelled as the void): the atlas rows next to a copy's edge continue its own bark, so
        the seam treatments' gradients there are the copy's, and no piece runs from one copy
        into the next.
    """

    exemplar_shape: tuple[int, int]
    wrap: tuple[bool, bool]
    angles: tuple[float, ...]
    scales: tuple[float, ...]
    centres: tuple[tuple[float, float], ...]
    copy_shape: tuple[int, int]
    margin: int = COPY_MARGIN
    angle_step: float = ANGLE_STEP

    @property
    def n_copies(self) -> int:
        return len(self.angles)

    @property
    def pitch(self) -> int:
        """Atlas rows per copy, its margins included."""
        return self.copy_shape[0] + 2 * self.margin

    @property
    def atlas_shape(self) -> tuple[int, int]:
        """``(n_copies * pitch, w_c)``."""
        return (self.n_copies * self.pitch, self.copy_shape[1])

    def _sample_points(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """The exemplar (row, column) each atlas pixel of copy ``index`` (its margins included)
        samples (float32)."""
        hc, wc = self.copy_shape
        rows, cols = np.mgrid[-self.margin : hc + self.margin, 0:wc].astype(np.float64)
        x = cols - (wc - 1) / 2.0
        y = (hc - 1) / 2.0 - rows  # up the screen
        turn, scale = math.radians(self.angles[index]), self.scales[index]
        c, s = math.cos(turn), math.sin(turn)
        # the copy shows the exemplar turned by +turn: it samples the exemplar at R(-turn) p
        ex_x = (c * x + s * y) / scale
        ex_y = (-s * x + c * y) / scale
        row, col = self.centres[index]
        return (row - ex_y).astype(np.float32), (col + ex_x).astype(np.float32)

    def valid(self) -> np.ndarray:
        """``atlas_shape`` bool: the atlas pixels that sample inside the exemplar (all of them
        along an axis it wraps along)."""
        h, w = self.exemplar_shape
        parts = []
        for index in range(self.n_copies):
            rows, cols = self._sample_points(index)
            inside = np.ones(rows.shape, bool)
            if not self.wrap[0]:
                inside &= (rows >= -0.5) & (rows <= h - 0.5)
            if not self.wrap[1]:
                inside &= (cols >= -0.5) & (cols <= w - 0.5)
            inside[: self.margin] = False
            inside[self.margin + self.copy_shape[0] :] = False
            parts.append(inside)
        return np.concatenate(parts, axis=0)

    def copy_labels(self) -> np.ndarray:
        """``atlas_shape`` int32: each atlas pixel's copy, ``n_copies`` where it samples outside
        the exemplar (a label no output pixel wants)."""
        index = np.repeat(np.arange(self.n_copies, dtype=np.int32), self.pitch)[:, None]
        labels = np.broadcast_to(index, self.atlas_shape).copy()
        labels[~self.valid()] = self.n_copies
        return labels

    def atlas(self, image: np.ndarray, *, kind: str = "image") -> np.ndarray:
        """A map of the exemplar's size as the atlas of its copies.

        Parameters
        ----------
        image : ndarray
            ``(h, w)`` or ``(h, w, C)``.
        kind : {"image", "labels", "normals"}
            ``"image"``: resampled bicubically (clipped to the input's range); ``"labels"``: at
            the nearest pixel; ``"normals"``: ``(h, w, 3)`` unit vectors (OpenGL: +y up the
            screen; or encoded in an integer image), resampled and their tangent components
            turned with the copy, renormalised (a scaled copy keeps its slopes: its height is
            to be scaled with it, :meth:`barkgen.material.MaterialSet.oriented`).

        Returns
        -------
        ndarray
            ``atlas_shape`` (with the input's channels), the input's dtype.
        """
        import cv2

        if kind not in ("image", "labels", "normals"):
            raise InvalidInputError(f"kind must be image, labels or normals, not {kind!r}")
        src = np.asarray(image)
        if src.shape[:2] != tuple(self.exemplar_shape):
            raise InvalidInputError(
                f"a map of {_shape_text(src.shape[:2])} is not of the exemplar's size "
                f"({_shape_text(self.exemplar_shape)})"
            )
        work = src.astype(np.float32)
        integer = src.dtype.kind in "iub"
        top = float(np.iinfo(src.dtype).max) if src.dtype.kind in "iu" else 1.0
        if kind == "normals" and integer:  # encoded normals: to unit vectors and back
            work = work / top * 2.0 - 1.0
        interpolation = cv2.INTER_NEAREST if kind == "labels" else cv2.INTER_CUBIC
        h, w = self.exemplar_shape
        parts = []
        for index in range(self.n_copies):
            rows, cols = self._sample_points(index)
            if self.wrap[0]:
                rows = np.mod(rows, h).astype(np.float32)
            if self.wrap[1]:
                cols = np.mod(cols, w).astype(np.float32)
            border = cv2.BORDER_WRAP if all(self.wrap) else cv2.BORDER_REFLECT_101
            copy = _remap(work, cols, rows, interpolation, border)
            if kind == "normals":
                copy = _turn_normals(copy, self.angles[index])
            parts.append(copy)
        out = np.concatenate(parts, axis=0)
        if kind == "normals" and integer:
            out = (out + 1.0) / 2.0 * top
        elif kind == "image":
            out = np.clip(out, float(src.min()), float(src.max()))
        if integer:
            out = np.round(out)
        return out.astype(src.dtype)

    def target(self, flow: np.ndarray, flow_scale: np.ndarray) -> np.ndarray:
        """``(H, W)`` int32: the copy each output pixel wants (that of its angle and scale).

        Raises
        ------
        InvalidInputError
            The fields ask for an angle and scale this atlas has no copy of.
        """
        angle_bin, scale_bin = _bins(flow, flow_scale, self.angle_step)
        copies = {
            (round(a / self.angle_step), round(math.log(s) / math.log(SCALE_STEP))): i
            for i, (a, s) in enumerate(zip(self.angles, self.scales, strict=True))
        }
        pairs, inverse = _bin_pairs(angle_bin, scale_bin)
        try:
            index = np.array([copies[(int(a), int(s))] for a, s in pairs], np.int32)
        except KeyError:
            raise InvalidInputError(
                "the fields ask for a turn or scale this oriented exemplar has no copy of"
            ) from None
        return index[inverse.ravel()].reshape(flow.shape)

    def exemplar_coordinates(self, references: np.ndarray) -> np.ndarray:
        """``(H, W, 2)`` float32: the exemplar (row, column) each atlas reference samples (its
        position in the photo)."""
        refs = np.asarray(references)
        index = refs[..., 0] // self.pitch
        out = np.empty(refs.shape[:2] + (2,), np.float32)
        for i in np.unique(index):
            rows, cols = self._sample_points(int(i))
            where = index == i
            local = refs[where]
            out[where, 0] = rows[local[:, 0] - i * self.pitch, local[:, 1]]
            out[where, 1] = cols[local[:, 0] - i * self.pitch, local[:, 1]]
        h, w = self.exemplar_shape
        if self.wrap[0]:
            out[..., 0] = np.mod(out[..., 0], h)
        if self.wrap[1]:
            out[..., 1] = np.mod(out[..., 1], w)
        return out

    def turns(self, references: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(H, W)`` float32 angle and scale of the copy each atlas reference is in."""
        index = np.asarray(references)[..., 0] // self.pitch
        return (
            np.asarray(self.angles, np.float32)[index],
            np.asarray(self.scales, np.float32)[index],
        )

    def to_dict(self) -> dict:
        """The atlas as JSON values (what a reference map needs to be applied again)."""
        return {
            "exemplar_shape": list(self.exemplar_shape),
            "wrap": list(self.wrap),
            "angles": list(self.angles),
            "scales": list(self.scales),
            "centres": [list(c) for c in self.centres],
            "copy_shape": list(self.copy_shape),
            "margin": self.margin,
            "angle_step": self.angle_step,
        }

    @classmethod
    def from_dict(cls, data: Mapping) -> OrientedExemplar:
        """The atlas :meth:`to_dict` wrote.

        Raises
        ------
        InvalidInputError
            Not such a record.
        """
        try:
            return cls(
                exemplar_shape=(int(data["exemplar_shape"][0]), int(data["exemplar_shape"][1])),
                wrap=(bool(data["wrap"][0]), bool(data["wrap"][1])),
                angles=tuple(float(a) for a in data["angles"]),
                scales=tuple(float(s) for s in data["scales"]),
                centres=tuple((float(c[0]), float(c[1])) for c in data["centres"]),
                copy_shape=(int(data["copy_shape"][0]), int(data["copy_shape"][1])),
                margin=int(data.get("margin", COPY_MARGIN)),
                angle_step=float(data.get("angle_step", ANGLE_STEP)),
            )
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise InvalidInputError(f"not an oriented exemplar's record ({exc})") from None


def _remap(image: np.ndarray, cols: np.ndarray, rows: np.ndarray, interpolation: int, border: int) -> np.ndarray:
    """cv2.remap of any channel count (it takes at most 4 at once)."""
    import cv2

    if image.ndim == 2:
        return cv2.remap(image, cols, rows, interpolation, borderMode=border)
    parts = [
        cv2.remap(np.ascontiguousarray(image[..., c : c + 4]), cols, rows, interpolation, borderMode=border)
        for c in range(0, image.shape[2], 4)
    ]
    parts = [p[..., None] if p.ndim == 2 else p for p in parts]
    return np.concatenate(parts, axis=2)


def _turn_normals(normals: np.ndarray, angle: float) -> np.ndarray:
    """Unit normals of a copy turned by ``angle`` degrees."""
    turn = math.radians(angle)
    c, s = math.cos(turn), math.sin(turn)
    nx, ny, nz = normals[..., 0], normals[..., 1], normals[..., 2]
    out = np.stack([c * nx - s * ny, s * nx + c * ny, nz], axis=-1)
    return (out / np.maximum(np.linalg.norm(out, axis=-1, keepdims=True), 1e-6)).astype(np.float32)


def orient_exemplar(
    exemplar_shape: tuple[int, int],
    flow: np.ndarray,
    flow_scale: np.ndarray,
    *,
    wrap: tuple[bool, bool],
    max_copies: int = MAX_COPIES,
) -> OrientedExemplar:
    """The atlas of turned and scaled copies a flow field needs: one copy per angle and scale
    the field uses (:data:`ANGLE_STEP` apart, or the first of :data:`COARSER_ANGLE_STEPS` that
    keeps them within ``max_copies``), each cut round its own place of the exemplar, so that
    together they cover it (the places follow a low-discrepancy sequence: the same fields give the same atlas
    whatever the seed, so the analysis of one serves every seed).

    Parameters
    ----------
    exemplar_shape : tuple of int
    flow, flow_scale : ndarray
        The checked fields (:func:`check_flow`).
    wrap : tuple of bool
        The exemplar tiles along (rows, columns).
    max_copies : int
        At most this many copies.

    Returns
    -------
    OrientedExemplar

    Raises
    ------
    InvalidInputError
        The fields need more than ``max_copies`` copies.
    """
    for step in (ANGLE_STEP, *COARSER_ANGLE_STEPS):
        angle_bin, scale_bin = _bins(flow, flow_scale, step)
        pairs, _ = _bin_pairs(angle_bin, scale_bin)
        if len(pairs) <= max_copies:
            break
    else:
        raise InvalidInputError(
            f"the flow fields ask for {len(pairs)} turns and scales of the photo, even {step:g}° apart; at "
            f"most {max_copies} fit with these labels (fewer labels, or a field with fewer scales)"
        )
    h, w = (int(v) for v in exemplar_shape)
    shrink = min(1.0, math.sqrt(ATLAS_BUDGET / len(pairs)))
    copy_shape = (min(h, max(MIN_COPY_SIDE, round(h * shrink))), min(w, max(MIN_COPY_SIDE, round(w * shrink))))
    # a tiling exemplar: anywhere on its torus; else as far from its centre as the copy allows
    free = (
        float(h) if wrap[0] else max(0.0, (h - copy_shape[0]) / 2.0),
        float(w) if wrap[1] else max(0.0, (w - copy_shape[1]) / 2.0),
    )
    centres = []
    for index in range(len(pairs)):
        # the R2 sequence (Roberts 2018): evenly spread places, one per copy
        u, v = ((0.5 + (index + 1) * g) % 1.0 for g in (0.7548776662466927, 0.5698402909980532))
        # (on the pixel grid: a turn by a quarter, a half or none samples pixels, not between them)
        half = ((copy_shape[0] - 1) / 2.0, (copy_shape[1] - 1) / 2.0)
        row = math.floor((h - 1) / 2.0 + (u - 0.5) * free[0] - half[0] + 0.5) + half[0]
        col = math.floor((w - 1) / 2.0 + (v - 0.5) * free[1] - half[1] + 0.5) + half[1]
        centres.append((float(row), float(col)))
    return OrientedExemplar(
        exemplar_shape=(h, w),
        wrap=(bool(wrap[0]), bool(wrap[1])),
        angles=tuple(float(a * step) for a, _ in pairs),
        scales=tuple(float(SCALE_STEP**s) for _, s in pairs),
        centres=tuple(centres),
        copy_shape=copy_shape,
        angle_step=step,
    )


@dataclass
class OrientedInputs:
    """What texture-by-numbers is given to synthesize along a flow field (:func:`oriented_inputs`):
    the atlas of the exemplar and of its extra maps, and the label maps whose labels are the
    pairs (bark label, copy)."""

    oriented: OrientedExemplar
    exemplar: np.ndarray
    extras: dict[str, np.ndarray]
    exemplar_labels: np.ndarray
    target_labels: np.ndarray
    copies: np.ndarray  # (H, W) the copy each output pixel wants


def oriented_inputs(
    exemplar: np.ndarray,
    flow: np.ndarray,
    flow_scale: np.ndarray,
    *,
    wrap: tuple[bool, bool],
    extra: Mapping[str, np.ndarray] | None = None,
    labels: tuple[np.ndarray, np.ndarray] | None = None,
    oriented: OrientedExemplar | None = None,
) -> OrientedInputs:
    """The inputs of a synthesis along the checked fields ``flow`` and ``flow_scale``
    (:func:`check_flow`) from ``exemplar`` (of tiling ``wrap``): its copies (:func:`orient_exemplar`),
    its extra maps' (a map whose name holds ``normal`` turned as normals) and, with ``labels``
    (the exemplar's and the target's label maps, as texture-by-numbers takes them), the pair
    labels. ``oriented``: the atlas to use (one shared with another synthesis), else the one
    the fields need.

    Raises
    ------
    InvalidInputError
        Label maps that do not fit, or fields that need more copies than the labels leave room
        for.
    """
    from barkgen.synth.guides.channels import MAX_LABELS, encode_label_maps

    shape = np.shape(exemplar)[:2]
    if labels is not None:
        maps = encode_label_maps(labels[0], labels[1], shape)
        codes, target_codes, n_labels = maps.exemplar, maps.target, maps.n_labels
    else:
        codes, target_codes, n_labels = np.zeros(shape, np.int32), np.zeros(flow.shape, np.int32), 1
    # a pair (label, copy) per label of the solver, the void (outside the exemplar) included
    if oriented is None:
        oriented = orient_exemplar(shape, flow, flow_scale, wrap=wrap, max_copies=(MAX_LABELS - 1) // n_labels)
    elif oriented.n_copies * n_labels > MAX_LABELS - 1:
        raise InvalidInputError(f"an atlas of {oriented.n_copies} copies leaves no room for {n_labels} labels")
    copies = oriented.copy_labels()
    pairs = oriented.n_copies + 1
    ex_labels = oriented.atlas(codes, kind="labels") * pairs + copies
    ex_labels[copies == oriented.n_copies] = n_labels * pairs  # the void: one label
    copies_wanted = oriented.target(flow, flow_scale)
    target = target_codes * pairs + copies_wanted
    extras = {
        name: oriented.atlas(np.asarray(m), kind="normals" if _is_normal_map(name, m) else "image")
        for name, m in (extra or {}).items()
    }
    # (the pair labels as 16-bit grey values, as texture-by-numbers reads a label map)
    return OrientedInputs(
        oriented,
        oriented.atlas(exemplar),
        extras,
        ex_labels.astype(np.uint16),
        target.astype(np.uint16),
        copies_wanted,
    )


def _is_normal_map(name: str, array) -> bool:
    return "normal" in name.lower() and np.ndim(array) == 3 and np.shape(array)[2] == 3


def equivalent_points(
    oriented: OrientedExemplar, rows: np.ndarray, cols: np.ndarray, copies: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The atlas positions (level 0, float) in copies ``copies`` that show the same exemplar
    point as the atlas positions ``rows``, ``cols`` (in whatever copy they are): the point
    carried from one copy's frame to another's, on the exemplar's torus the nearest to the
    copy's centre, clamped into the copy."""
    hc, wc = oriented.copy_shape
    h, w = oriented.exemplar_shape
    angles = np.radians(np.asarray(oriented.angles))
    scales = np.asarray(oriented.scales)
    centres = np.asarray(oriented.centres, np.float64).reshape(-1, 2)
    rows = np.asarray(rows, np.float64)
    cols = np.asarray(cols, np.float64)
    src = np.clip(np.floor(rows / oriented.pitch).astype(np.int64), 0, oriented.n_copies - 1)
    x = cols - (wc - 1) / 2.0
    y = (hc - 1) / 2.0 - (rows - src * oriented.pitch - oriented.margin)
    c, s = np.cos(angles[src]), np.sin(angles[src])
    ex_x = (c * x + s * y) / scales[src]
    ex_y = (-s * x + c * y) / scales[src]
    # from the exemplar point to the wanted copy's centre, the nearest way round a torus
    dst = np.asarray(copies, np.int64)
    dx = centres[src, 1] + ex_x - centres[dst, 1]
    dy = (centres[dst, 0] - centres[src, 0]) + ex_y
    if oriented.wrap[1]:
        dx = np.mod(dx + w / 2.0, w) - w / 2.0
    if oriented.wrap[0]:
        dy = np.mod(dy + h / 2.0, h) - h / 2.0
    c, s = np.cos(angles[dst]), np.sin(angles[dst])
    x = scales[dst] * (c * dx - s * dy)
    y = scales[dst] * (s * dx + c * dy)
    local_rows = np.clip((hc - 1) / 2.0 - y, 0.0, hc - 1.0)
    local_cols = np.clip(x + (wc - 1) / 2.0, 0.0, wc - 1.0)
    return dst * oriented.pitch + oriented.margin + local_rows, local_cols
