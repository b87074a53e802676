"""Colour-region label maps of a bark photo (laitoch2018 §3.5).

The photo is converted to CIELAB (§3.5.1), denoised by non-local means (§3.5.2), quantized into
``k`` colour regions by mini-batch k-means (§3.5.3), and cleaned of tiny regions, every pixel of
a tiny region taking the most common label of its neighbours (§3.5.4). Labels are numbered from
the darkest to the lightest region (mean luminance), so maps are stable across runs, and written
as evenly spaced grey values (§3.5.5). :func:`add_edge_label` adds the optional label of region
edges (§3.5.5) to input and output maps alike, once both are made.
"""

from __future__ import annotations

import importlib
import warnings

import numpy as np

from barkgen._shared.arrays import Boundary, Wrap
from barkgen._shared.bands import row_bands
from barkgen._shared.checks import MAX_K, check_image, check_k, check_seed
from barkgen._shared.threads import worker_pool
from barkgen.errors import InvalidInputError

#: a label covering less of the photo than this is grown to it (then tiny regions go)
MIN_LABEL_FRACTION = 0.06
#: default smallest region, as a fraction of the photo's area (at least MIN_REGION_PX pixels)
MIN_REGION_FRACTION = 0.0005
MIN_REGION_PX = 16
#: filter strength h of the non-local means denoising
DENOISE_STRENGTH = 10.0
#: pixels sampled to fit k-means (all are then assigned)
KMEANS_SAMPLES = 60_000
#: how far (px) the non-local means denoising looks: half its template plus half its search window
NL_MEANS_REACH = 3 + 10
#: pixels in each band :func:`nl_means` denoises in one call (about 0.2 s on 2 cores; smaller
#: bands spend more on the rows they share than they gain)
NL_MEANS_BAND_PIXELS = 256 * 1024


def grey_values(n_labels: int) -> np.ndarray:
    """The grey values of ``n_labels`` labels: evenly spaced over 0-255 (code 0 -> 0)."""
    if n_labels == 1:
        return np.zeros(1, np.uint8)
    return np.round(np.linspace(0, 255, n_labels)).astype(np.uint8)


def to_label_image(codes: np.ndarray, n_labels: int) -> np.ndarray:
    """Integer codes ``0..n_labels-1`` -> the 8-bit grey label map."""
    return grey_values(n_labels)[codes]


def to_codes(label_map: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A grey label map -> ``(codes, values)``: codes ``0..n-1`` in the order of the sorted grey
    values (darkest label first)."""
    arr = np.asarray(label_map)
    if (
        arr.ndim == 3
        and arr.shape[2] >= 3
        and (arr[..., 0] == arr[..., 1]).all()
        and (arr[..., 0] == arr[..., 2]).all()
    ):
        arr = arr[..., 0]
    elif arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[..., 0]
    if arr.ndim != 2:
        raise InvalidInputError("label map must be a grey image (one grey value per label)")
    values, codes = np.unique(arr, return_inverse=True)
    if len(values) > 64:
        raise InvalidInputError(f"label map has {len(values)} distinct values; at most 64 labels")
    return codes.reshape(arr.shape).astype(np.int32), values


def grey_label_map(label_map: np.ndarray) -> np.ndarray:
    """A label map with one grey value per label, as every stage takes it: a grey map as it
    is, a colour one (one RGB colour per label, as ``tbn --labels`` accepts) renumbered from
    its darkest colour to its lightest (Rec. 709 luma) onto evenly spaced grey values."""
    arr = np.asarray(label_map)
    if arr.ndim == 3 and arr.shape[2] in (2, 4):
        arr = arr[:, :, :-1]
    if (
        arr.ndim != 3
        or arr.shape[2] != 3
        or ((arr[..., 0] == arr[..., 1]).all() and (arr[..., 0] == arr[..., 2]).all())
    ):
        return arr
    values, codes = np.unique(arr.reshape(-1, 3), axis=0, return_inverse=True)
    if len(values) > MAX_K:
        raise InvalidInputError(
            f"the colour label map has {len(values)} distinct colours; at "
            f"most {MAX_K} labels (label maps must be lossless: PNG, not JPEG)"
        )
    order = np.argsort(values.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722]), kind="stable")
    rank = np.empty(len(values), np.int64)
    rank[order] = np.arange(len(values))
    return to_label_image(rank[codes.reshape(arr.shape[:2])], len(values))


def nl_means(rgb: np.ndarray, strength: float = 10.0) -> np.ndarray:
    """Non-local means denoising (laitoch2018 §3.5.2; OpenCV's ``fastNlMeansDenoisingColored``,
    7 px template, 21 px search window) of float RGB in [0, 1]; returns float RGB."""
    import cv2

    u8 = (rgb * 255.0 + 0.5).astype(np.uint8)
    out = np.empty_like(u8)
    height = u8.shape[0]
    # in bands of rows, each with the rows it reaches on either side: the same bytes as one
    # call, and Ctrl-C is heard between bands (a 1024² photo: 0.9 s in one call, out of reach)
    for top, bottom in row_bands(height, u8.shape[1], NL_MEANS_BAND_PIXELS):
        start, stop = max(0, top - NL_MEANS_REACH), min(height, bottom + NL_MEANS_REACH)
        band = cv2.fastNlMeansDenoisingColored(
            u8[start:stop], None, h=strength, hColor=strength, templateWindowSize=7, searchWindowSize=21
        )
        out[top:bottom] = band[top - start : bottom - start]
    return out.astype(np.float32) / 255.0


def order_by_luminance(codes: np.ndarray, luminance: np.ndarray, n_labels: int) -> np.ndarray:
    """Renumber labels from the darkest to the lightest mean ``luminance`` (absent labels last)."""
    counts = np.bincount(codes.ravel(), minlength=n_labels)
    sums = np.bincount(codes.ravel(), weights=luminance.ravel(), minlength=n_labels)
    means = np.where(counts > 0, sums / np.maximum(counts, 1), np.inf)
    rank = np.empty(n_labels, np.int32)
    rank[np.argsort(means, kind="stable")] = np.arange(n_labels)
    return rank[codes]


def grow_small_labels(codes: np.ndarray, fraction: float, n_labels: int, wrap: Wrap = False) -> np.ndarray:
    """Grow every label that covers less than ``fraction`` of the pixels by rings of one pixel
    around its regions (3x3 dilation, across the map's edge where it wraps: ``wrap``), taking
    pixels only from labels that stay above the fraction, until it reaches the fraction: a label
    of small features (lenticels, specks) keeps its places and becomes large enough to be learnt
    from. A label absent from the map stays absent."""
    import cv2

    out = np.asarray(codes, np.int32).copy()
    need = int(np.ceil(fraction * out.size))
    kernel = np.ones((3, 3), np.uint8)
    for lab in range(n_labels):
        for _ in range(max(out.shape)):
            counts = np.bincount(out.ravel(), minlength=n_labels)
            if counts[lab] >= need or counts[lab] == 0:
                break
            mask = (out == lab).astype(np.uint8)
            ring = (Boundary(wrap).torus(lambda m: cv2.dilate(m, kernel), mask, 1) > 0) & (mask == 0)
            ring &= counts[out] > need  # donors stay above the fraction
            if not ring.any():
                break
            idx = np.flatnonzero(ring)
            out.ravel()[idx[: need - counts[lab]]] = lab
    return out


def _components(mask: np.ndarray, wrap: Wrap) -> tuple[np.ndarray, np.ndarray]:
    """The 8-connected components of ``mask`` on the map's torus along the axes it wraps
    along: ``(component per pixel, 0 off the mask; pixels per component)``. A region that runs
    across the map's edge is one component, as it is in the texture that tiles."""
    import cv2
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n, comp, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    sizes = stats[:, cv2.CC_STAT_AREA].astype(np.int64)
    wy, wx = Boundary(wrap).wrap
    if not (wy or wx) or n <= 2:
        return comp, sizes
    pairs = []
    for axis, wraps in ((0, wy), (1, wx)):
        if not wraps:
            continue
        last, first = (comp[-1], comp[0]) if axis == 0 else (comp[:, -1], comp[:, 0])
        across = wx if axis == 0 else wy  # the edge's own axis wraps: its diagonals go round
        for shift in (-1, 0, 1):
            other = np.roll(first, shift) if across else np.pad(first, 1)[1 + shift : 1 + shift + first.size]
            both = (last > 0) & (other > 0)
            pairs.append(np.stack([last[both], other[both]]))
    ij = np.concatenate(pairs, axis=1)
    graph = coo_matrix((np.ones(ij.shape[1]), (ij[0], ij[1])), shape=(n, n))
    _, group = connected_components(graph, directed=False)
    group = group.astype(np.int64) + 1
    group[0] = 0  # the mask's background stays apart
    merged = np.bincount(group, weights=sizes, minlength=group.max() + 1).astype(np.int64)
    merged[0] = sizes[0]
    return group[comp], merged


def remove_small_regions(codes: np.ndarray, min_region: int, wrap: Wrap = False) -> np.ndarray:
    """Dissolve every region smaller than ``min_region`` pixels (laitoch2018 §3.5.4).

    Regions are 8-connected, across the map's edge along the axes it wraps along (``wrap``: a
    bool or ``(rows, columns)``). A dissolved region's pixels take, layer by layer from the
    outside, the most common label among their 8 neighbours that are already decided.

    Parameters
    ----------
    codes : ndarray of int, shape (h, w)
        Label codes ``0 .. n - 1``.
    min_region : int
        Smallest region kept, in pixels.

    Returns
    -------
    ndarray of int32, shape (h, w)
        The codes with no region under ``min_region`` pixels (if every region is that small,
        the largest region of the commonest label is kept and fills the map).

    References
    ----------
    .. [1] laitoch2018, §3.5.4 (removing small regions).

    Examples
    --------
    >>> import numpy as np
    >>> codes = np.zeros((32, 32), np.int32)
    >>> codes[10, 10] = 1                      # a one-pixel speck
    >>> int(remove_small_regions(codes, 16).max())
    0
    """
    import cv2

    codes = np.asarray(codes, np.int32)
    n_labels = int(codes.max()) + 1
    keep = np.zeros(codes.shape, bool)
    for lab in range(n_labels):
        comp, sizes = _components(codes == lab, wrap)
        big = sizes >= min_region
        big[0] = False  # background of the mask
        keep |= big[comp]
    if not keep.any():  # everything tiny: keep the largest region of the commonest label
        commonest = np.bincount(codes.ravel()).argmax()
        mask = (codes == commonest).astype(np.uint8)
        _, comp, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        keep = comp == 1 + np.argmax(stats[1:, cv2.CC_STAT_AREA])
    out = np.where(keep, codes, -1)
    kernel = np.ones((3, 3), np.float32)
    while (out < 0).any():
        votes = np.stack(
            [
                Boundary(wrap).torus(
                    lambda m: cv2.filter2D(m, -1, kernel, borderType=cv2.BORDER_CONSTANT),
                    (out == lab).astype(np.float32),
                    1,
                )
                for lab in range(n_labels)
            ]
        )
        undecided = out < 0
        has_vote = votes.max(axis=0) > 0
        fill = undecided & has_vote
        out[fill] = votes.argmax(axis=0)[fill]
    return out


def clean_regions(codes: np.ndarray, n_labels: int, min_region: int, wrap: Wrap = False) -> np.ndarray:
    """Small labels grown to :data:`MIN_LABEL_FRACTION` of the map, then regions smaller than
    ``min_region`` dissolved (§3.5.4); growing the survivors once more restores labels the
    removal shrank, and a last removal tidies what that split. All on the map's torus along
    the axes it wraps along (``wrap``)."""
    codes = grow_small_labels(codes, MIN_LABEL_FRACTION, n_labels, wrap)
    codes = remove_small_regions(codes, min_region, wrap)
    return remove_small_regions(grow_small_labels(codes, MIN_LABEL_FRACTION, n_labels, wrap), min_region, wrap)


def finish_label_map(codes: np.ndarray, k: int) -> np.ndarray:
    """Label codes (in label order) -> the grey label map; labels that vanished (a photo with
    too little variation for ``k`` regions) are dropped with a warning, the others keep their
    order."""
    present = np.flatnonzero(np.bincount(codes.ravel(), minlength=k))
    if len(present) < k:
        warnings.warn(
            f"the photo gives only {len(present)} distinct regions, not {k}; the label map has {len(present)} labels",
            stacklevel=2,
        )
    compact = np.zeros(k, np.int32)
    compact[present] = np.arange(len(present))
    return to_label_image(compact[codes], len(present))


def default_min_region(shape: tuple[int, int]) -> int:
    """0.05 % of the photo's area, at least 16 px."""
    return max(MIN_REGION_PX, int(round(MIN_REGION_FRACTION * shape[0] * shape[1])))


def color_regions(
    image: np.ndarray,
    k: int,
    *,
    denoise: bool | float = True,
    min_region: int | None = None,
    edges: bool | int = False,
    seed: int = 0,
    wrap: Wrap = False,
) -> np.ndarray:
    """The photo's label map of ``k`` colour regions (laitoch2018 §3.5).

    Non-local means denoising, k-means of the CIELAB colours, small regions dissolved, labels
    ordered from the darkest to the lightest.

    Parameters
    ----------
    image : ndarray, shape (h, w) or (h, w, C)
        The photo: uint8, uint16 or float in [0, 1].
    k : int
        Number of labels, 1-16.
    denoise : bool or float, default True
        Non-local means denoising first (§3.5.2): ``True`` (filter strength
        :data:`DENOISE_STRENGTH`), ``False``, or the strength ``h`` itself.
    min_region : int, optional
        Smallest region kept, in pixels (default: 0.05 % of the photo, >= 16 px).
    edges : bool or int, default False
        Add the label of region edges (§3.5.5): ``True`` for a 3 px band, or its width.
    seed : int, default 0
        Seeds the k-means sampling and initialisation.
    wrap : bool or (bool, bool), default False
        The photo tiles (both axes, or ``(rows, columns)``,
        :func:`barkgen.synth.exemplar_wraps`): the denoising and the regions run across its
        edge there, so the label map tiles as the photo does.

    Returns
    -------
    ndarray of uint8, shape (h, w)
        Label map with ``k`` (``k + 1`` with ``edges``) evenly spaced grey values, the darkest
        region first (grey 0). Labels covering less than 6 % of the photo are grown to it
        (:func:`grow_small_labels`), and no region is smaller than ``min_region``.

    Raises
    ------
    InvalidInputError
        A bad image, ``k``, ``min_region``, ``denoise`` or seed.

    References
    ----------
    .. [1] laitoch2018, §3.5 (input label maps: §3.5.2 denoising, §3.5.4 small regions, §3.5.5
       grey values and the edge label).
    .. [2] buades2011 (non-local means denoising).

    Examples
    --------
    >>> import barkgen
    >>> photo = barkgen.read_image(barkgen.sample_exemplar_path())[:128, :128]
    >>> labels = color_regions(photo, 3)
    >>> labels.shape, sorted(set(labels.ravel().tolist()))
    ((128, 128), [0, 128, 255])
    """
    from barkgen.color import rgb_to_lab

    k = check_k(k)
    rgb = check_image(image)
    check_seed(seed)
    h, w = rgb.shape[:2]
    if min_region is None:
        min_region = default_min_region((h, w))
    if not isinstance(min_region, (int, np.integer)) or min_region < 1:
        raise InvalidInputError(f"min_region must be a positive number of pixels, not {min_region!r}")
    if not isinstance(denoise, (bool, int, float, np.number)) or denoise < 0:
        raise InvalidInputError(f"denoise must be True, False or a strength >= 0, not {denoise!r}")
    # scikit-learn's import (a second, the first time) runs while OpenCV denoises: OpenCV lets
    # go of the interpreter while it works
    with worker_pool(1) as pool:
        loading = pool.submit(importlib.import_module, "sklearn.cluster")
        if denoise is not False and denoise != 0:
            strength = DENOISE_STRENGTH if denoise is True else float(denoise)
            rgb = Boundary(wrap).torus(lambda im: nl_means(im, strength), rgb, NL_MEANS_REACH)
        MiniBatchKMeans = loading.result().MiniBatchKMeans
    lab = rgb_to_lab(rgb).reshape(-1, 3)
    if k == 1:
        codes = np.zeros((h, w), np.int32)
    else:
        rng = np.random.default_rng(seed)
        sample = lab[rng.choice(len(lab), min(len(lab), KMEANS_SAMPLES), replace=False)]
        km = MiniBatchKMeans(n_clusters=k, n_init=3, batch_size=4096, random_state=int(rng.integers(0, 2**31 - 1))).fit(
            sample
        )
        dist = ((lab[:, None, :] - km.cluster_centers_[None].astype(np.float32)) ** 2).sum(-1)
        codes = dist.argmin(axis=1).reshape(h, w).astype(np.int32)
        codes = clean_regions(codes, k, int(min_region), wrap)
        codes = order_by_luminance(codes, lab[:, 0].reshape(h, w), k)
    label_map = finish_label_map(codes, k)
    if edges:
        label_map = add_edge_label(label_map, 3 if edges is True else int(edges))
    return label_map


def add_edge_label(
    label_map: np.ndarray, width: int = 3, *, wrap: Wrap = False, values: np.ndarray | None = None
) -> np.ndarray:
    """Add one more label for the band along the region edges (laitoch2018 §3.5.5).

    The paper adds it "on both input and output label maps after they are both generated": the
    same label values give the same result, so the photo's map and a map synthesized from it
    get the same edge label (give the output the photo's ``values``). Every pixel within
    ``max(1, width // 2)`` px (chessboard distance) of a pixel of another label, a band about
    ``width`` px wide, takes the new label.

    Parameters
    ----------
    label_map : ndarray, shape (h, w)
        A grey label map (every distinct value a label, darkest first).
    width : int, default 3
        Width of the edge band in pixels.
    wrap : bool or (bool, bool), default False
        The map wraps (a tileable output, a photo that tiles: both axes, or ``(rows,
        columns)``): edges across its border count.
    values : ndarray, optional
        The label values to number against (the photo's, for a map synthesized from it, whose
        labels are some of them); default: the map's own.

    Returns
    -------
    ndarray of uint8, shape (h, w)
        The ``n`` labels (of ``values``) become the first ``n`` of ``n + 1`` evenly spaced grey
        values; the edge label is the last (255).

    Raises
    ------
    InvalidInputError
        A width that is not a positive integer, too many labels, or a label not in ``values``.

    References
    ----------
    .. [1] laitoch2018, §3.5.5 (grayscale and edge detection: the edge label).

    Examples
    --------
    >>> import numpy as np
    >>> halves = np.zeros((8, 8), np.uint8)
    >>> halves[:, 4:] = 255
    >>> sorted(set(add_edge_label(halves, 2).ravel().tolist()))
    [0, 128, 255]
    """
    import cv2

    if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 1:
        raise InvalidInputError(f"edge width must be a positive number of pixels, not {width!r}")
    codes, own = to_codes(label_map)
    if values is not None:
        values = np.unique(np.asarray(values))
        if not np.isin(own, values).all():
            raise InvalidInputError(
                "the label map has labels that are not the photo's; they cannot share an edge label"
            )
        codes = np.searchsorted(values, own)[codes].astype(np.int32)
        own = values
    n = len(own)
    if n + 1 > MAX_K + 1:
        raise InvalidInputError(f"label map has {n} labels; at most {MAX_K} before the edge label")
    # a band wider than the map is the same band as one as wide as it (and cheap to find)
    r = max(1, min(int(width) // 2, max(codes.shape)))
    kernel = np.ones((2 * r + 1, 2 * r + 1), np.uint8)

    def near_another(c16: np.ndarray) -> np.ndarray:
        # a pixel is near another label when the largest and smallest codes around it differ
        return cv2.dilate(c16, kernel, borderType=cv2.BORDER_REPLICATE) != cv2.erode(
            c16, kernel, borderType=cv2.BORDER_REPLICATE
        )

    near = Boundary(wrap).torus(near_another, codes.astype(np.uint16), r)
    if n > 1 and near.all():
        raise InvalidInputError(
            f"an edge band {width} px wide covers the whole "
            f"{codes.shape[1]}x{codes.shape[0]} label map; give a narrower "
            "edge width"
        )
    return to_label_image(np.where(near, n, codes), n + 1)
