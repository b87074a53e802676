"""Texton channels of a bark photo and their merging into labels (wang2003 §3.2).

A bank of 36 Gaussian-derivative filters (2 phases x 3 scales separated by half-octaves x 6
orientations, as the paper's) gives every pixel a 36-d response vector; k-means clusters the
responses into ``K`` textons (25 in the paper). Each texton is a raw channel; the user merges
raw channels into a few feature channels (fractures, lenticels, ...) with
:func:`merge_channels`, or :func:`auto_merge` groups them by agglomerative clustering of their
textons (their mean filter responses: what the channel's structure is) or of their colours, so
the pipeline needs no user step. :func:`channel_previews` shows each channel over the photo.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.arrays import Boundary, Wrap
from barkgen._shared.checks import check_image, check_k, check_seed
from barkgen.errors import InvalidInputError
from barkgen.labels.regions import (
    clean_regions,
    default_min_region,
    finish_label_map,
    order_by_luminance,
    to_codes,
    to_label_image,
)

#: scales (Gaussian sigma across the orientation, px) and orientations of the filter bank: three
#: scales separated by half-octaves (wang2003 §3.2, after Malik et al. 2001)
FILTER_SCALES = (float(np.sqrt(2.0)), 2.0, float(2.0 * np.sqrt(2.0)))
N_ORIENTATIONS = 6
#: most textons
MAX_TEXTONS = 64
#: responses sampled to fit k-means (all pixels are then assigned)
TEXTON_SAMPLES = 50_000
#: what :func:`auto_merge` groups textons by
MERGE_BY = ("texture", "colour")
#: textons merged by texture are scattered pixel by pixel (a texton is a local structure, not a
#: region): :func:`texton_regions` lets each pixel take the label most of its neighbourhood
#: (a Gaussian of this sigma, px) has before the small regions are cleaned up
TEXTURE_VOTE_SIGMA = 4.0


def filter_bank(scales=FILTER_SCALES, n_orientations: int = N_ORIENTATIONS) -> list[np.ndarray]:
    """The oriented filter bank of wang2003 §3.2.

    For every scale and orientation, the even (second derivative of an elongated Gaussian,
    aspect 3:1) and the odd (first derivative) filter across the orientation; zero mean, unit
    L1 norm.

    Parameters
    ----------
    scales : sequence of float, default FILTER_SCALES
        Gaussian sigmas across the orientation, in pixels.
    n_orientations : int, default N_ORIENTATIONS
        Orientations, evenly spaced over 180 degrees.

    Returns
    -------
    list of ndarray of float32
        ``2 * len(scales) * n_orientations`` square kernels, ordered phase-major: even filters
        first, then odd.

    References
    ----------
    .. [1] wang2003, §3.2 (texton channels).

    Examples
    --------
    >>> len(filter_bank())
    36
    """
    bank: dict[str, list[np.ndarray]] = {"even": [], "odd": []}
    for sigma in scales:
        half = int(np.ceil(3 * 3 * sigma))
        y, x = np.mgrid[-half : half + 1, -half : half + 1].astype(np.float64)
        for i in range(n_orientations):
            theta = np.pi * i / n_orientations
            u = x * np.cos(theta) + y * np.sin(theta)  # across the orientation
            v = -x * np.sin(theta) + y * np.cos(theta)  # along it
            g = np.exp(-(u**2) / (2 * sigma**2) - (v**2) / (2 * (3 * sigma) ** 2))
            for phase, f in (("even", (u**2 / sigma**4 - 1 / sigma**2) * g), ("odd", -u / sigma**2 * g)):
                f = f - f.mean()
                bank[phase].append((f / np.abs(f).sum()).astype(np.float32))
    return bank["even"] + bank["odd"]


def filter_responses(image: np.ndarray, *, wrap: Wrap = False) -> np.ndarray:
    """``(h, w, 36)`` float32 responses of the photo's luminance (CIELAB L / 100) to
    :func:`filter_bank`; across the photo's edge along the axes it wraps along (``wrap``: a
    bool or ``(rows, columns)``), mirrored at the others."""
    import cv2

    from barkgen.color import rgb_to_lab

    lum = rgb_to_lab(check_image(image))[..., 0] / np.float32(100.0)
    bank = filter_bank()
    reach = max(f.shape[0] for f in bank) // 2

    def respond(lum: np.ndarray) -> np.ndarray:
        out = np.empty(lum.shape + (len(bank),), np.float32)
        for i, f in enumerate(bank):
            out[..., i] = cv2.filter2D(lum, cv2.CV_32F, f, borderType=cv2.BORDER_REFLECT_101)
        return out

    return np.ascontiguousarray(Boundary(wrap).torus(respond, lum, reach))


def texton_channels(
    image: np.ndarray, n_textons: int = 25, *, seed: int = 0, wrap: Wrap = False
) -> tuple[np.ndarray, np.ndarray]:
    """The photo's texton map and its filter responses (wang2003 §3.2).

    Parameters
    ----------
    image : ndarray, shape (h, w) or (h, w, C)
        The photo: uint8, uint16 or float in [0, 1].
    n_textons : int, default 25
        Number of textons (k-means clusters of the filter responses), 2 to :data:`MAX_TEXTONS`.
    seed : int, default 0
        Seeds the k-means sampling and initialisation.
    wrap : bool or (bool, bool), default False
        The photo tiles along both axes (or ``(rows, columns)``): the filters run across its
        edge there (:func:`filter_responses`).

    Returns
    -------
    texton_map : ndarray of uint8, shape (h, w)
        Texton index per pixel, textons numbered from the darkest to the lightest mean luminance.
    responses : ndarray of float32, shape (h, w, 36)
        The responses to :func:`filter_bank`'s filters.

    Raises
    ------
    InvalidInputError
        A bad image, texton count or seed.

    References
    ----------
    .. [1] wang2003, §3.2 (texton channel analysis).
    """
    from sklearn.cluster import MiniBatchKMeans

    from barkgen.color import rgb_to_lab

    if (
        isinstance(n_textons, bool)
        or not isinstance(n_textons, (int, np.integer))
        or not (2 <= n_textons <= MAX_TEXTONS)
    ):
        raise InvalidInputError(f"n_textons must be an integer from 2 to {MAX_TEXTONS}, not {n_textons!r}")
    check_seed(seed)
    rgb = check_image(image)
    responses = filter_responses(rgb, wrap=wrap)
    h, w, d = responses.shape
    flat = responses.reshape(-1, d)
    rng = np.random.default_rng(seed)
    sample = flat[rng.choice(len(flat), min(len(flat), TEXTON_SAMPLES), replace=False)]
    km = MiniBatchKMeans(
        n_clusters=int(n_textons), n_init=3, batch_size=4096, random_state=int(rng.integers(0, 2**31 - 1))
    ).fit(sample)
    codes = _nearest_centre(flat, km.cluster_centers_.astype(np.float32)).reshape(h, w)
    codes = order_by_luminance(codes, rgb_to_lab(rgb)[..., 0], int(n_textons))
    return codes.astype(np.uint8), responses


def _nearest_centre(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Index of the nearest centre of every point (faiss exact search)."""
    import faiss

    index = faiss.IndexFlatL2(centres.shape[1])
    index.add(np.ascontiguousarray(centres))
    _, idx = index.search(np.ascontiguousarray(points), 1)
    return idx[:, 0].astype(np.int32)


def parse_groups(text: str) -> list[list[int]]:
    """Parse texton groups: ``"0,3,7;1,2;4"`` -> ``[[0, 3, 7], [1, 2], [4]]``.

    Parameters
    ----------
    text : str
        Groups separated by ``;``, texton numbers by ``,``.

    Returns
    -------
    list of list of int
        One list of texton numbers per label.

    Raises
    ------
    InvalidInputError
        An empty group or a number that is not an integer (one clear line).

    Examples
    --------
    >>> parse_groups("0,3,7;1,2;4")
    [[0, 3, 7], [1, 2], [4]]
    """
    groups: list[list[int]] = []
    for part in (text or "").split(";"):
        part = part.strip()
        if not part:
            raise InvalidInputError(f'invalid --groups {text!r}: empty group (write e.g. "0,3,7;1,2;4")')
        try:
            groups.append([int(v) for v in part.split(",")])
        except ValueError:
            raise InvalidInputError(
                f"invalid --groups {text!r}: {part!r} is not a comma-separated list of texton numbers"
            ) from None
    return groups


def merge_channels(texton_map: np.ndarray, groups) -> np.ndarray:
    """Merge texton channels into labels, as the user does in wang2003 §3.2.

    Parameters
    ----------
    texton_map : ndarray of int, shape (h, w)
        Texton numbers (:func:`texton_channels`).
    groups : list of list of int, or str
        ``groups[i]`` lists the raw texton channels that form label ``i`` (or their text form,
        :func:`parse_groups`); every texton of the map must be in exactly one group.

    Returns
    -------
    ndarray of uint8, shape (h, w)
        The label map, evenly spaced grey values in group order.

    Raises
    ------
    InvalidInputError
        Not 1-16 groups, a texton in two groups, or a texton of the map in none.

    References
    ----------
    .. [1] wang2003, §3.2 (merging texton channels into feature masks).

    Examples
    --------
    >>> import numpy as np
    >>> merge_channels(np.array([[0, 1], [2, 3]]), "0,3;1,2").tolist()
    [[0, 255], [255, 0]]
    """
    tm = np.asarray(texton_map)
    if tm.ndim == 3 and tm.shape[2] == 1:
        tm = tm[..., 0]
    if tm.ndim != 2 or tm.dtype.kind not in "ui":
        raise InvalidInputError("texton map must be a grey integer image of texton numbers")
    if isinstance(groups, str):
        groups = parse_groups(groups)
    if not 1 <= len(groups) <= 16:
        raise InvalidInputError(f"groups must form 1 to 16 labels, not {len(groups)}")
    lookup = np.full(int(tm.max()) + 1, -1, np.int32)
    for i, group in enumerate(groups):
        for t in group:
            if not isinstance(t, (int, np.integer)) or t < 0:
                raise InvalidInputError(f"texton number {t!r} in the groups is not valid")
            if t < len(lookup) and lookup[t] >= 0:
                raise InvalidInputError(f"texton {t} is in two groups")
            if t < len(lookup):
                lookup[t] = i
    present = np.unique(tm)
    missing = present[lookup[present] < 0]
    if len(missing):
        raise InvalidInputError(
            "the groups leave out texton(s) "
            + ", ".join(str(int(t)) for t in missing[:8])
            + " of the map; every texton needs a group"
        )
    return to_label_image(lookup[tm], len(groups))


def auto_merge(
    texton_map: np.ndarray,
    image: np.ndarray,
    k: int,
    *,
    by: str = "texture",
    responses: np.ndarray | None = None,
) -> list[list[int]]:
    """Groups of textons for ``k`` labels, so that the pipeline needs no user step.

    Agglomerative clustering of the textons, with Ward's criterion weighted by pixel counts
    (merging groups of ``n_a`` and ``n_b`` pixels costs ``n_a n_b / (n_a + n_b)`` times their
    squared distance), so rare textons join their nearest group before common ones merge. What
    is compared (standardised per dimension):

    * ``by="texture"`` (default): what the textons' pixels are, their mean oriented energy
      (``sqrt(even² + odd²)`` of each scale and orientation of the bank: the structure, whatever
      the phase: both sides of a fracture, light and dark, are one fracture; wang2003 §3.2,
      Fig. 5's merge by feature);
    * ``by="colour"``: the mean CIELAB colour of their pixels (e.g. the dark fissure textons of
      every orientation form one label).

    Parameters
    ----------
    texton_map : ndarray of int, shape (h, w)
        Texton numbers (:func:`texton_channels`).
    image : ndarray, shape (h, w) or (h, w, C)
        The photo the textons belong to.
    k : int
        Number of labels wanted, 1-16 and at most the number of textons present.
    by : {"texture", "colour"}, default "texture"
        What the textons are grouped by.
    responses : ndarray, shape (h, w, 36), optional
        The photo's filter responses (:func:`texton_channels`' second value); made when not
        given and ``by="texture"``.

    Returns
    -------
    list of list of int
        ``k`` groups of texton numbers, ordered from the darkest to the lightest; pass them to
        :func:`merge_channels`.

    Raises
    ------
    InvalidInputError
        ``k`` out of range or larger than the number of textons, or an unknown ``by``.

    References
    ----------
    .. [1] wang2003, §3.2 (the merge the user makes by hand there, Fig. 5).
    """
    from barkgen.color import rgb_to_lab

    k = check_k(k)
    if by not in MERGE_BY:
        raise InvalidInputError(f"textons are merged by {' or '.join(MERGE_BY)}, not {by!r}")
    tm = np.asarray(texton_map).astype(np.int64)
    rgb = check_image(image)
    lab = rgb_to_lab(rgb).reshape(-1, 3)
    present = np.unique(tm)
    if k > len(present):
        raise InvalidInputError(f"the texton map has {len(present)} textons; cannot merge them into {k} labels")
    flat = tm.ravel()
    size = int(present.max()) + 1
    counts = np.bincount(flat, minlength=size)[present].astype(np.float64)

    def means_of(values: np.ndarray) -> np.ndarray:
        return (
            np.stack(
                [np.bincount(flat, weights=values[:, c], minlength=size)[present] for c in range(values.shape[1])], 1
            )
            / counts[:, None]
        )

    colours = means_of(lab)
    if by == "texture":
        if responses is None:
            responses = filter_responses(rgb)
        flat_responses = np.asarray(responses, np.float32).reshape(flat.size, -1)
        half = flat_responses.shape[1] // 2  # even filters, then the odd ones in the same order
        energy = np.hypot(flat_responses[:, :half], flat_responses[:, half:])
        described = means_of(energy.astype(np.float64))
    else:
        described = colours
    feats = (described - described.mean(axis=0)) / (described.std(axis=0) + 1e-6)
    groups = [[int(t)] for t in present]
    n = list(counts)
    centre = [f for f in feats]
    while len(groups) > k:  # at most 64 textons: a plain loop over the pairs is enough
        best, pair = np.inf, (0, 1)
        for a in range(len(groups)):
            for b in range(a + 1, len(groups)):
                cost = n[a] * n[b] / (n[a] + n[b]) * float(((centre[a] - centre[b]) ** 2).sum())
                if cost < best:
                    best, pair = cost, (a, b)
        a, b = pair
        centre[a] = (n[a] * centre[a] + n[b] * centre[b]) / (n[a] + n[b])
        n[a] += n[b]
        groups[a] += groups[b]
        del groups[b], n[b], centre[b]
    lookup = {int(t): i for i, t in enumerate(present)}
    lum = [np.average([colours[lookup[t], 0] for t in g], weights=[counts[lookup[t]] for t in g]) for g in groups]
    return [sorted(groups[i]) for i in np.argsort(lum, kind="stable")]


def channel_previews(image: np.ndarray, texton_map: np.ndarray) -> list[np.ndarray]:
    """Each texton channel over the photo (wang2003 Fig. 4 (c)-(d)): the photo dimmed to a
    third, the channel's pixels at full brightness with an orange edge around them, one RGB
    uint8 image per texton present, in texton order."""
    import cv2

    from barkgen._shared.arrays import as_uint8

    rgb = as_uint8(check_image(image))
    if rgb.ndim == 2 or rgb.shape[2] == 1:
        rgb = np.repeat(rgb.reshape(rgb.shape[0], rgb.shape[1], 1), 3, axis=2)
    rgb = rgb[..., :3]
    dim = (rgb.astype(np.float32) / 3.0).astype(np.uint8)
    tm = np.asarray(texton_map)
    out = []
    for t in np.unique(tm):
        channel = (tm == t).astype(np.uint8)
        tile = np.where(channel[..., None] > 0, rgb, dim)
        edge = cv2.morphologyEx(channel, cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8)) > 0
        tile[edge & (channel == 0)] = (255, 140, 0)
        out.append(np.ascontiguousarray(tile))
    return out


def _neighbourhood_vote(codes: np.ndarray, sigma: float, wrap: Wrap) -> np.ndarray:
    """Each pixel's label: the one with the most Gaussian-weighted votes around it (across the
    edges that wrap)."""
    import cv2

    n = int(codes.max()) + 1
    reach = int(np.ceil(4 * sigma))

    def votes(indicator: np.ndarray) -> np.ndarray:
        return cv2.GaussianBlur(indicator, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)

    stacked = np.stack([Boundary(wrap).torus(votes, (codes == i).astype(np.float32), reach) for i in range(n)], axis=-1)
    return stacked.argmax(axis=-1).astype(np.int32)


def texton_regions(
    image: np.ndarray,
    k: int,
    *,
    n_textons: int = 25,
    min_region: int | None = None,
    seed: int = 0,
    wrap: Wrap = False,
    merge_by: str = "texture",
) -> np.ndarray:
    """A ``k``-label map from texton channels with no user step.

    :func:`texton_channels`, :func:`auto_merge`, :func:`merge_channels` (merged by texture, each
    pixel then takes the label of most of its neighbourhood, :data:`TEXTURE_VOTE_SIGMA`), then
    the clean-up of the colour-region maps (small labels grown, regions under ``min_region`` px dissolved;
    laitoch2018 §3.5.4).

    Parameters
    ----------
    image : ndarray, shape (h, w) or (h, w, C)
        The photo: uint8, uint16 or float in [0, 1].
    k : int
        Number of labels, 1-16.
    n_textons : int, default 25
        Textons before the merge.
    min_region : int, optional
        Smallest region kept, in pixels (default: 0.05 % of the photo, >= 16 px).
    seed : int, default 0
        Seeds the texton k-means.
    wrap : bool or (bool, bool), default False
        The photo tiles (both axes, or ``(rows, columns)``): filters and regions run across its
        edge there.
    merge_by : {"texture", "colour"}, default "texture"
        What the textons are grouped by (:func:`auto_merge`).

    Returns
    -------
    ndarray of uint8, shape (h, w)
        Label map with ``k`` evenly spaced grey values, the darkest label first.

    References
    ----------
    .. [1] wang2003, §3.2 (texton channels).
    .. [2] laitoch2018, §3.5.4 (removing small regions).
    """
    k = check_k(k)
    textons, responses = texton_channels(image, n_textons, seed=seed, wrap=wrap)
    merged = merge_channels(textons, auto_merge(textons, image, k, by=merge_by, responses=responses))
    codes, _ = to_codes(merged)
    if merge_by == "texture":
        codes = _neighbourhood_vote(codes, TEXTURE_VOTE_SIGMA, wrap)
    if min_region is None:
        min_region = default_min_region(codes.shape)
    return finish_label_map(clean_regions(codes, k, int(min_region), wrap), k)
