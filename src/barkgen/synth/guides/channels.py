"""Label maps as synthesis guides (texture-by-numbers, laitoch2018 §3.1 and §3.3).

A label map is an image whose distinct values (grey levels or colours) are the labels. The
exemplar's label map ``A`` and the target label map ``B`` are encoded to small integer codes over
one shared palette, reduced level by level alongside the image pyramids, and turned into the
per-level tables the solver's label term uses (:class:`LevelGuide`).

The feature-distance map (Lefebvre & Hoppe 2006 §5, used by Fan et al. 2012 and laitoch2018
§3.3.4) is the distance of every pixel to the nearest label boundary; it is added to the exemplar
as an extra matching channel so that matched neighbourhoods agree on where the edges are.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from barkgen._shared.arrays import Boundary, Wrap
from barkgen.errors import InvalidInputError

#: most labels a label map may have (more usually means a lossy JPEG or a photo, not labels)
MAX_LABELS = 64


@dataclass(frozen=True)
class LabelMaps:
    """Exemplar and target label maps encoded over one palette.

    Attributes:
        exemplar: ``(h, w)`` int32 label code of every exemplar pixel.
        target: ``(H, W)`` int32 label code of every output pixel.
        palette: ``(n_labels, C)`` the label values, code ``i`` is ``palette[i]``.
    """

    exemplar: np.ndarray
    target: np.ndarray
    palette: np.ndarray

    @property
    def n_labels(self) -> int:
        return len(self.palette)


def _label_rows(name: str, label_map: np.ndarray) -> np.ndarray:
    arr = np.asarray(label_map)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3 or not 1 <= arr.shape[2] <= 4:
        raise InvalidInputError(f"{name} must be an (H, W) or (H, W, C) image, not shape {arr.shape}")
    if arr.dtype.kind not in "uifb":
        raise InvalidInputError(f"{name} has unsupported dtype {arr.dtype}")
    if arr.shape[2] in (2, 4):  # drop alpha: labels are the colours
        arr = arr[:, :, :-1]
    if arr.shape[2] == 3 and (arr[:, :, 0] == arr[:, :, 1]).all() and (arr[:, :, 0] == arr[:, :, 2]).all():
        arr = arr[:, :, :1]  # a grey label map saved as RGB is the same labels
    return arr


def _unique_values(arr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct pixel values of ``(H, W, C)`` and the index of each pixel's value."""
    flat = arr.reshape(-1, arr.shape[2])
    if flat.shape[1] == 1 and flat.dtype.kind in "ub" and flat.dtype.itemsize <= 2:
        # grey 8/16-bit: a histogram instead of a sort
        v = flat[:, 0].astype(np.int64)
        present = np.flatnonzero(np.bincount(v))
        lookup = np.zeros(int(present[-1]) + 1, np.int64)
        lookup[present] = np.arange(len(present))
        return present.astype(flat.dtype)[:, None], lookup[v].reshape(arr.shape[:2])
    if flat.dtype.kind in "ub" and flat.dtype.itemsize <= 2:
        key = np.zeros(len(flat), np.int64)
        for c in range(flat.shape[1]):
            key = (key << 16) | flat[:, c].astype(np.int64)
        keys, inverse = np.unique(key, return_inverse=True)
        first = np.zeros(len(keys), np.int64)
        first[inverse[::-1]] = np.arange(len(flat))[::-1]
        return flat[first], inverse.reshape(arr.shape[:2])
    values, inverse = np.unique(flat, axis=0, return_inverse=True)
    return values, inverse.reshape(arr.shape[:2])


def _describe(value: np.ndarray) -> str:
    v = [int(x) if float(x).is_integer() else float(x) for x in np.ravel(value)]
    return str(v[0]) if len(v) == 1 else "(" + ", ".join(map(str, v)) + ")"


def encode_label_maps(
    exemplar_labels: np.ndarray, target_labels: np.ndarray, exemplar_shape: tuple[int, int] | None = None
) -> LabelMaps:
    """Encode the exemplar's and the target's label maps to integer codes over one palette.

    Raises:
        InvalidInputError: the exemplar label map does not match ``exemplar_shape``, a map has
            more than :data:`MAX_LABELS` labels, the two maps use different kinds of values
            (grey vs colour), or the target uses a label that the exemplar lacks.
    """
    a = _label_rows("exemplar label map", exemplar_labels)
    b = _label_rows("target label map", target_labels)
    if exemplar_shape is not None and a.shape[:2] != tuple(exemplar_shape):
        raise InvalidInputError(
            f"the exemplar label map is {a.shape[1]}x{a.shape[0]} px but the exemplar is "
            f"{exemplar_shape[1]}x{exemplar_shape[0]} px; they must match"
        )
    values_a, codes_a = _unique_values(a)
    values_b, codes_b = _unique_values(b)
    for name, values in (("exemplar", values_a), ("target", values_b)):
        if len(values) > MAX_LABELS:
            raise InvalidInputError(
                f"the {name} label map has {len(values)} distinct values; at most {MAX_LABELS} "
                "labels are supported (label maps must be lossless: PNG, not JPEG)"
            )
    if a.shape[2] != b.shape[2]:
        kinds = {1: "grey", 3: "colour"}
        raise InvalidInputError(
            f"the exemplar label map is {kinds[a.shape[2]]} but the target label map is "
            f"{kinds[b.shape[2]]}; both must use the same label values"
        )
    # every target value must be one of the exemplar's
    va = values_a.astype(np.float64)
    vb = values_b.astype(np.float64)
    eq = (vb[:, None, :] == va[None, :, :]).all(axis=2)
    missing = ~eq.any(axis=1)
    if missing.any():
        shown = ", ".join(_describe(v) for v in values_b[missing][:5])
        raise InvalidInputError(
            f"the target label map uses label(s) {shown} that the exemplar label map does not "
            "have; every target label needs exemplar pixels to copy"
        )
    to_a = eq.argmax(axis=1)
    return LabelMaps(exemplar=codes_a.astype(np.int32), target=to_a[codes_b].astype(np.int32), palette=values_a)


def label_pyramid(codes: np.ndarray, n_labels: int, n_levels: int) -> list[np.ndarray]:
    """Labels of every pyramid level, finest first: each level's label is the one whose indicator
    image, reduced by the same Gaussian pyramid as the exemplar (:mod:`barkgen.pyramid`), is
    largest there (a soft majority vote, consistent with the image pyramid)."""
    import cv2

    levels = [np.ascontiguousarray(codes, dtype=np.int32)]
    if n_levels == 1:
        return levels
    # each level's arrays, from its first label present on
    best: list[Any] = [None] * n_levels
    score: list[Any] = [None] * n_levels
    for label in range(n_labels):
        ind = (codes == label).astype(np.float32)
        if not ind.any():
            continue
        for lvl in range(1, n_levels):
            h, w = ind.shape
            ind = cv2.pyrDown(ind, dstsize=((w + 1) // 2, (h + 1) // 2), borderType=cv2.BORDER_REFLECT_101)
            if best[lvl] is None:
                best[lvl] = np.full(ind.shape, label, np.int32)
                score[lvl] = ind.copy()
            else:
                better = ind > score[lvl]
                best[lvl][better] = label
                score[lvl][better] = ind[better]
    return levels + best[1:]


def boundary_distance(codes: np.ndarray, clip: float | None = None, *, wrap: Wrap = False) -> np.ndarray:
    """Distance, in pixels, from every pixel to the nearest label boundary (a pixel with a
    4-neighbour of another label), by the 3x3 chamfer distance transform with Borgefors'
    weights (the 3-4 DT of laitoch2018 §3.4.2, as computed by OpenCV). ``clip`` caps it.
    ``wrap`` (a bool or ``(rows, columns)``): the map wraps round along that axis, so a
    boundary across its edge is near (:meth:`barkgen._shared.arrays.Boundary.torus`)."""
    if any(Boundary(wrap).wrap):
        reach = int(np.ceil(clip)) + 2 if clip is not None else max(np.shape(codes)[:2])
        return Boundary(wrap).torus(lambda c: boundary_distance(c, clip), np.asarray(codes), reach)
    import cv2

    c = np.asarray(codes)
    edge = np.zeros(c.shape, bool)
    dy = c[1:, :] != c[:-1, :]
    dx = c[:, 1:] != c[:, :-1]
    edge[1:, :] |= dy
    edge[:-1, :] |= dy
    edge[:, 1:] |= dx
    edge[:, :-1] |= dx
    if not edge.any():
        far = float(clip) if clip is not None else float(max(c.shape))
        return np.full(c.shape, far, np.float32)
    src = np.where(edge, 0, 255).astype(np.uint8)
    dist = cv2.distanceTransform(src, cv2.DIST_L2, cv2.DIST_MASK_3)
    if clip is not None:
        np.minimum(dist, np.float32(clip), out=dist)
    return dist.astype(np.float32)


@dataclass
class LevelGuide:
    """Label tables of one pyramid level, as the solver's kernels use them.

    Attributes:
        exemplar_labels: ``(h * w,)`` int32 label of each exemplar pixel of the level.
        target_labels: ``(H, W)`` int32 wanted label of each output pixel of the level.
        pool, pool_start: exemplar pixels grouped by label (CSR layout): the pixels of label
            ``l`` are ``pool[pool_start[l]:pool_start[l + 1]]``; a label absent from this level of
            the exemplar (lost to down-sampling) gets the whole exemplar.
        expected_use: ``(h * w,)`` float32 how many output pixels each exemplar pixel would serve
            if every label's output area were spread evenly over that label's exemplar pixels
            (the occurrence cost's uniform reference).
    """

    exemplar_labels: np.ndarray
    target_labels: np.ndarray
    pool: np.ndarray
    pool_start: np.ndarray
    expected_use: np.ndarray


def level_guide(exemplar_labels: np.ndarray, target_labels: np.ndarray, n_labels: int) -> LevelGuide:
    """Build the :class:`LevelGuide` of one level from its exemplar and target label codes."""
    ea = np.ascontiguousarray(exemplar_labels, dtype=np.int32).ravel()
    tb = np.ascontiguousarray(target_labels, dtype=np.int32)
    count_a = np.bincount(ea, minlength=n_labels)
    count_b = np.bincount(tb.ravel(), minlength=n_labels)
    order = np.argsort(ea, kind="stable").astype(np.int32)
    pools = []
    start = [0]
    offsets = np.concatenate([[0], np.cumsum(count_a)])
    everything = np.arange(ea.size, dtype=np.int32)
    for lab in range(n_labels):
        members = order[offsets[lab] : offsets[lab + 1]] if count_a[lab] else everything
        pools.append(members)
        start.append(start[-1] + len(members))
    expected = (count_b / np.maximum(count_a, 1)).astype(np.float32)[ea]
    return LevelGuide(
        exemplar_labels=ea,
        target_labels=tb,
        pool=np.ascontiguousarray(np.concatenate(pools), dtype=np.int32),
        pool_start=np.asarray(start, np.int32),
        expected_use=np.ascontiguousarray(expected),
    )


#: px of Gaussian blur of the label indicators that make the guide channels
GUIDE_BLUR = 1.0
#: a label covering a fraction f of the exemplar weighs up to 1 / sqrt(f * n_labels) more
RARE_LABEL_BOOST = 16.0
#: more labels than this are compressed to this many guide channels (PCA)
MAX_GUIDE_CHANNELS = 8


@dataclass(frozen=True)
class SoftLabels:
    """How a label map becomes guide channels (:func:`guide_channels`): each label's indicator
    blurred by :data:`GUIDE_BLUR` px, times its rarity ``boost``; projected on ``basis`` (after
    taking ``mean`` off) when there are more than :data:`MAX_GUIDE_CHANNELS` labels; times
    ``scale``. Made from the exemplar's map, applied alike to the target's, whole or a
    rectangle at a time (:class:`barkgen.synth.guides.target.TargetGuideLevel`)."""

    n_labels: int
    boost: np.ndarray
    scale: float
    mean: np.ndarray | None = None
    basis: np.ndarray | None = None

    #: px the blur reads beyond a pixel
    reach: ClassVar[int] = int(np.ceil(4 * GUIDE_BLUR)) + 1

    @property
    def channels(self) -> int:
        """How many guide channels a pixel has."""
        return self.n_labels if self.basis is None else int(self.basis.shape[1])

    def unscaled(self, codes: np.ndarray, wrap: Wrap) -> np.ndarray:
        """The blurred, boosted indicators ``(H, W, n_labels)`` of ``codes``, round ``wrap``."""
        import cv2

        def blurred(indicator: np.ndarray) -> np.ndarray:
            return cv2.GaussianBlur(indicator, (0, 0), GUIDE_BLUR, borderType=cv2.BORDER_REFLECT_101)

        chans = [
            Boundary(wrap).torus(blurred, (codes == lab).astype(np.float32), self.reach) * np.float32(self.boost[lab])
            for lab in range(self.n_labels)
        ]
        return np.stack(chans, axis=-1)

    def finished(self, unscaled: np.ndarray) -> np.ndarray:
        """:meth:`unscaled` channels projected (with many labels) and scaled, float32."""
        if self.basis is not None and self.mean is not None:
            unscaled = _project(unscaled, self.mean, self.basis)
        return np.ascontiguousarray(unscaled * np.float32(self.scale), dtype=np.float32)

    def __call__(self, codes: np.ndarray, wrap: Wrap = False) -> np.ndarray:
        """The guide channels ``(H, W, channels)`` of the label ``codes``, blurred round ``wrap``."""
        return self.finished(self.unscaled(codes, wrap))


def soft_labels(exemplar_codes: np.ndarray, n_labels: int, scale: float, *, exemplar_wrap: Wrap = False):
    """``(recipe, exemplar channels)``: the :class:`SoftLabels` of the exemplar's label codes
    (rare labels weighed up to :data:`RARE_LABEL_BOOST` more, so that small features such as
    lenticels are not traded away, the mean cost per pixel staying ``scale ** 2``; with more than
    :data:`MAX_GUIDE_CHANNELS` labels, the exemplar's first principal axes) and the exemplar's
    own guide channels."""
    freq = np.bincount(exemplar_codes.ravel(), minlength=n_labels) / exemplar_codes.size
    boost = np.clip(1.0 / np.sqrt(np.maximum(freq, 1e-9) * n_labels), 1.0, RARE_LABEL_BOOST)
    boost /= np.sqrt(np.sum(freq * boost**2))
    recipe = SoftLabels(n_labels, boost, float(scale))
    ga = recipe.unscaled(exemplar_codes, exemplar_wrap)
    if n_labels > MAX_GUIDE_CHANNELS:
        flat = ga.reshape(-1, n_labels)
        mean = flat.mean(axis=0)
        _, _, vt = np.linalg.svd((flat - mean)[:: max(1, len(flat) // 20000)], full_matrices=False)
        recipe = SoftLabels(n_labels, boost, float(scale), mean, vt[:MAX_GUIDE_CHANNELS].T.astype(np.float32))
    return recipe, recipe.finished(ga)


def guide_channels(
    exemplar_codes: np.ndarray,
    target_codes: np.ndarray,
    n_labels: int,
    scale: float,
    *,
    exemplar_wrap: Wrap = False,
    target_wrap: Wrap = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Soft-label guide channels of the exemplar (``A``) and the target (``B``): each label's
    indicator, blurred by a Gaussian of :data:`GUIDE_BLUR` px (a boundary one pixel off then costs
    little), weighted up when the label is rare and multiplied by ``scale``; with more than
    :data:`MAX_GUIDE_CHANNELS` labels, both are projected on the exemplar's first principal
    axes (:func:`soft_labels`). Each map is blurred round its own wrap (``exemplar_wrap``: the
    photo tiles; ``target_wrap``: the output does)."""
    recipe, ga = soft_labels(exemplar_codes, n_labels, scale, exemplar_wrap=exemplar_wrap)
    return ga, recipe(target_codes, target_wrap)


def _project(channels: np.ndarray, mean: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """``(channels - mean) @ basis``, a band of rows at a time: BLAS holds the interpreter for
    its whole call (a 2048² target's 0.5 s), and Ctrl-C is heard between bands."""
    from barkgen._shared.bands import row_bands

    out = np.empty(channels.shape[:-1] + basis.shape[1:], np.result_type(channels, basis))
    for start, stop in row_bands(channels.shape[0], channels[0].size * basis.shape[1]):
        out[start:stop] = (channels[start:stop] - mean) @ basis
    return out


#: px: a thin label's proximity channel falls to 1/e this far from the label
THIN_PROXIMITY = 2.0
#: px: the Gaussian window of the structure tensor that gives a thin label's direction
THIN_DIRECTION_WINDOW = 2.0
#: weight of a thin label's proximity and direction channels beside its indicator channel
#: (measured on the six crack images of the variants benchmark, tiled: at 1024² the crack share
#: rises from 80-97 % to 83-97 % for a coherence 0-3 % higher; at 1.0, at 512², to 86-98 % for
#: 1-9 % more)
THIN_LABEL_WEIGHT = 0.5


def thin_label_channels(codes: np.ndarray, thin: np.ndarray, *, wrap: Wrap = False) -> np.ndarray:
    """Soft guide channels of labels drawn as thin lines (a crack network's 1-3 px raster):
    the proximity ``exp(-d / THIN_PROXIMITY)`` of each pixel to the nearest pixel of a ``thin``
    code (distance ``d`` in px), and the lines' direction as the doubled angle of the
    proximity's structure tensor, ``((Jxx - Jyy), 2 Jxy) / (Jxx + Jyy)``, times the proximity.

    A 1-2 px label is lost by the pyramid's down-sampling (its indicator falls below the other
    label's, :func:`label_pyramid`), so the coarse levels would lay the output out unguided; a
    proximity some pixels wide survives it, and the direction channels fade where directions
    disagree, so a coarse level keeps where the lines run and how (the orientation field
    mazzolini2012 §4.2.1 reduces through its pyramid). Computed round the map's ``wrap``.

    Returns
    -------
    ndarray
        ``(H, W, 3)`` float32: proximity in [0, 1], then the direction pair in [-1, 1].
    """
    import cv2

    window = int(np.ceil(4 * THIN_DIRECTION_WINDOW)) + 2
    reach = int(np.ceil(8 * THIN_PROXIMITY)) + window

    def channels(code_map: np.ndarray) -> np.ndarray:
        line = np.isin(code_map, thin)
        if not line.any():
            return np.zeros(code_map.shape + (3,), np.float32)
        dist = cv2.distanceTransform(np.where(line, 0, 255).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_5)
        near = np.exp(-dist / np.float32(THIN_PROXIMITY)).astype(np.float32)
        gy, gx = np.gradient(cv2.GaussianBlur(near, (0, 0), 1.0))

        def smooth(a: np.ndarray) -> np.ndarray:
            return cv2.GaussianBlur(a, (0, 0), THIN_DIRECTION_WINDOW)

        jxx, jyy, jxy = smooth(gx * gx), smooth(gy * gy), smooth(gx * gy)
        trace = jxx + jyy + np.float32(1e-6)
        return np.stack([near, (jxx - jyy) / trace * near, 2.0 * jxy / trace * near], axis=-1).astype(np.float32)

    return Boundary(wrap).torus(channels, np.asarray(codes), reach)


def thin_codes(palette: np.ndarray, values) -> np.ndarray:
    """The codes of the label ``values`` (grey values or colours, as in the label maps) in
    ``palette`` (:attr:`LabelMaps.palette`).

    Raises:
        InvalidInputError: a value is not a label of the exemplar label map.
    """
    rows = np.asarray(palette, np.float64).reshape(len(palette), -1)
    codes = []
    for value in values:
        v = np.ravel(np.asarray(value, np.float64))
        if v.size == 1 and rows.shape[1] > 1:
            v = np.repeat(v, rows.shape[1])
        match = np.flatnonzero((rows == v[None, :]).all(axis=1)) if v.size == rows.shape[1] else np.zeros(0, int)
        if match.size == 0:
            raise InvalidInputError(f"thin label {_describe(v)} is not a label of the exemplar label map")
        codes.append(int(match[0]))
    return np.asarray(codes, np.int32)
