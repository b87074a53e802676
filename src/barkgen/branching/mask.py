"""The crack mask of a photo (sibbing2010 §3, automated): cracks are thin structures darker
than their surroundings.

A multi-scale Hessian "dark valley" response on the CIELAB luminance (scale-normalised, so it is
about half the depth of a crack of matching width, in L* units) is thresholded with hysteresis
(low threshold: Otsu of the response, high: twice that, both with an absolute floor, so a flat
or smooth image has no cracks). The candidate regions are then cut to the crack itself: pixels
at least half as deep (black top-hat) as the deepest crack pixel near them, so the mask's width
is the crack's full width at half depth whatever its contrast. With a label map, the mask is
the label that is darkest in the photo.

The Otsu threshold is scikit-image's (:func:`skimage.filters.threshold_otsu`, on barkgen's own
256-bin histogram of the response) and small specks go with
:func:`skimage.morphology.remove_small_objects`. The Hessian, its eigenvalues and the
hysteresis stay OpenCV + numba: scikit-image's differ (other derivative stencils and Gaussian
truncation; float32 rounding of the eigenvalues; 4-connected hysteresis where the cracks need
8-connectivity), and the extraction's output is kept exactly as it was.
"""

from __future__ import annotations

from typing import cast

import numpy as np

from barkgen.errors import InvalidInputError

#: Gaussian scales (px) of the dark-valley filter: cracks of half-width ~1..5 px respond best
SIGMAS = (1.0, 1.5, 2.0, 3.0, 4.0, 6.0)
#: absolute floors of the hysteresis thresholds (response units ~ half the crack depth in L*)
LOW_FLOOR = 1.0
HIGH_FLOOR = 2.5
#: the high threshold is this multiple of the low (Otsu) threshold
HIGH_FACTOR = 2.0
#: how much a second positive curvature (a dark blob, not a line) takes off the response
BLOB_DAMPING = 0.5
#: the background of a crack is the median luminance within BG_RADIUS * max(SIGMAS) px
BG_RADIUS = 4.0
#: before measuring depths the luminance is smoothed by DEPTH_BLUR times the median best scale
#: of the strong crack pixels, clipped to DEPTH_BLUR_RANGE (px)
DEPTH_BLUR = 0.3
DEPTH_BLUR_RANGE = (0.5, 1.5)
#: the depth of the crack next to a pixel is the deepest candidate pixel within this radius (px)
DEPTH_RADIUS = 4
#: a mask pixel is at least this fraction of the depth of the crack next to it
HALF_DEPTH = 0.5
#: holes of the mask no wider than 2 * SLIVER px are filled (specks inside a broad crack)
SLIVER = 2.5
#: connected pieces of the mask smaller than this (px) are specks, not cracks
MIN_PIECE = 12
#: smallest image side accepted
MIN_SIDE = 16


# --------------------------------------------------------------------------- input checks


def check_crack_image(image: np.ndarray, what: str = "image") -> np.ndarray:
    """An ``(H, W)`` / ``(H, W, C)`` uint8, uint16, float [0, 1] or boolean image as float32 RGB
    in [0, 1] (:func:`barkgen._shared.checks.check_image`, which words the errors)."""
    from barkgen._shared.checks import check_image

    img = np.asarray(image)
    if img.dtype == np.bool_:
        img = img.astype(np.float32)
    return check_image(img, min_side=MIN_SIDE, what=what, purpose="crack extraction needs")


def luminance(image: np.ndarray) -> np.ndarray:
    """CIELAB L* (0..100) of an image, float32 ``(H, W)``."""
    from barkgen.color import rgb_to_lab

    return np.ascontiguousarray(rgb_to_lab(check_crack_image(image))[..., 0])


def _label_ids(labels: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Integer id per pixel of an ``(H, W)`` or ``(H, W, C)`` label map (each value/colour one label)."""
    lab = np.asarray(labels)
    if lab.ndim == 3 and lab.shape[2] == 1:
        lab = lab[:, :, 0]
    if lab.ndim not in (2, 3) or lab.shape[:2] != tuple(shape):
        raise InvalidInputError(f"label map must be {shape[1]}x{shape[0]} px like the image, not shape {lab.shape}")
    if lab.ndim == 2:
        _, ids = np.unique(lab.ravel(), return_inverse=True)
    else:
        flat = np.ascontiguousarray(lab.reshape(-1, lab.shape[2]))
        _, ids = np.unique(flat, axis=0, return_inverse=True)
    return ids.reshape(shape).astype(np.int32)


# --------------------------------------------------------------------------- filters


def valley_response(lum: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Multi-scale dark-valley response: ``max_s s^2 * (l1 - max(l2, 0) / 2)^+`` of the Hessian
    eigenvalues ``l1 >= l2`` of the luminance smoothed at scale ``s`` (large across a dark line,
    small along it; dark blobs, where both are large, are damped), and the index in
    :data:`SIGMAS` of the best scale per pixel (about the half-width of the crack there)."""
    import cv2

    from barkgen.branching._kernels import valley_update

    kxy = np.array([[1, 0, -1], [0, 0, 0], [-1, 0, 1]], np.float32) / 4.0
    out = np.zeros_like(lum)
    scale = np.zeros(lum.shape, np.uint8)
    for si, s in enumerate(SIGMAS):
        g = cv2.GaussianBlur(lum, (0, 0), s, borderType=cv2.BORDER_REFLECT)
        gxx = cv2.Sobel(g, cv2.CV_32F, 2, 0, ksize=1, borderType=cv2.BORDER_REFLECT)
        gyy = cv2.Sobel(g, cv2.CV_32F, 0, 2, ksize=1, borderType=cv2.BORDER_REFLECT)
        gxy = cv2.filter2D(g, cv2.CV_32F, kxy, borderType=cv2.BORDER_REFLECT)
        valley_update(gxx, gyy, gxy, s * s, BLOB_DAMPING, si, out, scale)
    return out, scale


def otsu_threshold(values: np.ndarray, bins: int = 256) -> float:
    """Otsu's threshold of ``values`` on a ``bins``-bin histogram over their range
    (:func:`skimage.filters.threshold_otsu`); the value itself when they (nearly) all agree."""
    from skimage.filters import threshold_otsu

    lo, hi = float(values.min()), float(values.max())
    if hi - lo < 1e-6:
        return hi
    hist, edges = np.histogram(values, bins=bins, range=(lo, hi))
    centres = 0.5 * (edges[:-1] + edges[1:])
    return float(threshold_otsu(hist=(hist, centres)))


def hysteresis(resp: np.ndarray, low: float, high: float) -> np.ndarray:
    """The 8-connected regions above ``low`` that reach above ``high`` somewhere."""
    import cv2

    weak = (resp > low).astype(np.uint8)
    n, lab = cv2.connectedComponents(weak, connectivity=8)
    keep = np.zeros(n, bool)
    keep[np.unique(lab[resp > high])] = True
    keep[0] = False
    return keep[lab]


def disk(radius: int) -> np.ndarray:
    """OpenCV's elliptic structuring element of ``2 radius + 1`` px (not skimage's disk)."""
    import cv2

    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


def remove_small(mask: np.ndarray, min_area: int) -> np.ndarray:
    """The 8-connected pieces of ``mask`` of at least ``min_area`` px."""
    from skimage.morphology import remove_small_objects

    mask = np.asarray(mask, bool)
    try:
        return remove_small_objects(mask, max_size=min_area - 1, connectivity=2)
    except TypeError:  # scikit-image < 0.26 (min_size: the smallest size kept)
        return remove_small_objects(mask, min_size=min_area, connectivity=2)


def fill_slivers(mask: np.ndarray, max_inradius: float) -> np.ndarray:
    """Fill the holes of the mask that are thin slivers (no point farther than
    ``max_inradius`` px from the mask): bright specks inside a broad crack, not the cells
    between cracks."""
    import cv2

    holes = (~mask).astype(np.uint8)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(holes, connectivity=4)
    dist = cv2.distanceTransform(holes, cv2.DIST_L2, 3)
    inr = np.zeros(n, np.float32)
    np.maximum.at(inr, cast(np.ndarray, lab).ravel(), dist.ravel())  # cv2's stubs: any MatLike
    h, w = mask.shape
    x0, y0 = stats[:, cv2.CC_STAT_LEFT], stats[:, cv2.CC_STAT_TOP]
    x1, y1 = x0 + stats[:, cv2.CC_STAT_WIDTH], y0 + stats[:, cv2.CC_STAT_HEIGHT]
    fill = (inr <= max_inradius) & (x0 > 0) & (y0 > 0) & (x1 < w) & (y1 < h)  # enclosed
    fill[0] = False  # label 0: the mask itself
    return mask | fill[lab]


# --------------------------------------------------------------------------- the masks


def _half_depth_cut(lum: np.ndarray, cand: np.ndarray, resp: np.ndarray, best: np.ndarray, high: float) -> np.ndarray:
    """The candidate regions cut to the crack: pixels at least half as deep as the crack next
    to them (near a candidate), closed, slivers filled, specks removed."""
    import cv2

    k = 2 * int(np.ceil(BG_RADIUS * max(SIGMAS))) + 1
    lum8 = np.clip(lum * 2.55 + 0.5, 0, 255).astype(np.uint8)
    background = cv2.medianBlur(lum8, k).astype(np.float32) / 2.55
    # the typical crack scale: broad fissures in textured bark want smoother edges
    sigma = float(np.median(np.asarray(SIGMAS)[best[resp > high]]))
    blur = float(np.clip(DEPTH_BLUR * sigma, *DEPTH_BLUR_RANGE))
    depth = background - cv2.GaussianBlur(lum, (0, 0), blur)  # smooth, not ragged, edges
    local = cv2.dilate(np.where(cand, depth, 0).astype(np.float32), disk(int(DEPTH_RADIUS)))
    near = cv2.dilate(cand.astype(np.uint8), disk(2)).astype(bool)
    mask = near & (depth >= HALF_DEPTH * local) & (depth > 0)
    mask = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_CLOSE, disk(1)).astype(bool)
    mask = fill_slivers(mask, SLIVER)
    return remove_small(mask, MIN_PIECE)


def auto_mask(lum: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(mask, valley response, high threshold) of a luminance image."""
    resp, best = valley_response(lum)
    t = otsu_threshold(resp[resp > 0]) if (resp > 0).any() else 0.0
    low = max(t, LOW_FLOOR)
    high = max(HIGH_FACTOR * t, HIGH_FLOOR)
    cand = hysteresis(resp, low, high)
    if not cand.any():
        return cand, resp, high
    return _half_depth_cut(lum, cand, resp, best, high), resp, high


def label_mask(lum: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """The label of ``labels`` whose pixels are darkest in ``lum`` on average."""
    ids = _label_ids(labels, lum.shape)
    n = int(ids.max()) + 1
    if n < 2:
        raise InvalidInputError(
            "label map: no cracks found (it has a single label; the cracks must be a label of their own)"
        )
    count = np.bincount(ids.ravel(), minlength=n)
    total = np.bincount(ids.ravel(), weights=lum.ravel().astype(np.float64), minlength=n)
    mean = total / np.maximum(count, 1)
    return ids == int(np.argmin(mean))


def crack_mask(image: np.ndarray, labels: np.ndarray | None = None) -> np.ndarray:
    """Boolean ``(H, W)`` mask of the cracks (dark thin structures) of ``image``.

    ``image`` is ``(H, W)`` or ``(H, W, C)``, uint8, uint16 or float in [0, 1]. Without
    ``labels`` the cracks are found automatically (see the module docs); with an ``(H, W)`` or
    ``(H, W, 3)`` label map (each distinct value or colour one label) the mask is the label
    whose pixels are darkest in the photo on average.
    """
    lum = luminance(image)
    if labels is not None:
        return label_mask(lum, labels)
    return auto_mask(lum)[0]
