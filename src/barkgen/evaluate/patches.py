"""How much a result looks like its photo, patch by patch and in the whole: coherence,
completeness, sharpness and colour.

Coherence and completeness are the two halves of the bidirectional similarity that
example-based synthesis minimises (mazzolini2012 §3, the energy of Kwatra et al. that the
discrete solver descends; laitoch2018 §3.5 measures its results the same way): every patch of
the result should have a close patch in the photo (coherence: nothing the photo could not
have), and every patch of the photo a close patch in the result (completeness: nothing of the
photo left out). Distances are taken in CIELAB (laitoch2018 §3.5.1), so they read as colour
differences: about 1 is invisible, 2-3 is a just-noticeable difference.
"""

from __future__ import annotations

import numpy as np

from barkgen._shared.threads import thread_budget
from barkgen.color import rgb_to_lab
from barkgen.errors import InvalidInputError

#: queries measured at most (a deterministic grid over larger images)
MAX_QUERIES = 16384
#: patches searched at most (a deterministic grid over larger images)
MAX_DATABASE = 262144
#: principal components the candidates are found in, before the exact re-ranking
COMPONENTS = 24
#: candidates re-ranked exactly per query
CANDIDATES = 8
#: above this many patches the search is an inverted file (IVF), below it exact
_FLAT_LIMIT = 8192


def as_unit_image(image: np.ndarray, name: str = "image") -> np.ndarray:
    """``image`` as float64 ``(H, W, C)`` in [0, 1]: uint8 and uint16 scaled by their range,
    floats taken as they are, a 2-D array given one channel, alpha dropped.

    Raises
    ------
    InvalidInputError
        Not an image of at least 2 x 2 pixels with 1, 2, 3 or 4 channels, or not finite.
    """
    arr = np.asarray(image)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3 or arr.shape[2] not in (1, 2, 3, 4) or min(arr.shape[:2]) < 2:
        raise InvalidInputError(f"{name}: expected an (H, W) or (H, W, C) image, got shape {arr.shape}")
    if arr.shape[2] in (2, 4):
        arr = arr[:, :, :-1]
    if arr.dtype == np.uint8:
        return arr.astype(np.float64) / 255.0
    if arr.dtype == np.uint16:
        return arr.astype(np.float64) / 65535.0
    if arr.dtype.kind not in "fiub":
        raise InvalidInputError(f"{name}: pixels of type {arr.dtype} are not an image")
    out = arr.astype(np.float64)
    if not np.isfinite(out).all():
        raise InvalidInputError(f"{name}: has pixels that are not finite")
    return out


def as_lab(image: np.ndarray, name: str = "image") -> np.ndarray:
    """CIELAB (D65, float32) of an sRGB image; a grey image (one channel) as its lightness
    alone, ``a = b = 0``."""
    unit = np.clip(as_unit_image(image, name), 0.0, 1.0)
    if unit.shape[2] == 1:
        unit = np.repeat(unit, 3, axis=2)
    return rgb_to_lab(unit.astype(np.float32))


def _grid(shape: tuple[int, int], limit: int) -> tuple[np.ndarray, np.ndarray]:
    """Row and column of every position of a ``shape`` grid, or of a regular sub-grid of at most
    ``limit`` positions (the same every time: the measures are deterministic)."""
    h, w = shape
    step = max(1, int(np.ceil(np.sqrt(h * w / limit))))
    ys, xs = np.meshgrid(np.arange(0, h, step), np.arange(0, w, step), indexing="ij")
    return ys.ravel(), xs.ravel()


def _patches(lab: np.ndarray, ys: np.ndarray, xs: np.ndarray, patch: int) -> np.ndarray:
    """The ``patch`` x ``patch`` patches whose top-left corners are ``(ys, xs)``, as rows."""
    view = np.lib.stride_tricks.sliding_window_view(lab, (patch, patch), axis=(0, 1))
    return np.ascontiguousarray(view[ys, xs].reshape(len(ys), -1), dtype=np.float32)


def _wrapped(lab: np.ndarray, patch: int) -> np.ndarray:
    """An image that tiles, extended by ``patch - 1`` px of itself so that every pixel has a
    patch (those over its edges wrap round)."""
    return np.pad(lab, ((0, patch - 1), (0, patch - 1), (0, 0)), mode="wrap")


def _index(features: np.ndarray):
    """A faiss index over ``features``: exact below :data:`_FLAT_LIMIT` rows, else an inverted
    file trained on a fixed sub-grid of them (deterministic)."""
    import faiss

    n, d = features.shape
    index: faiss.Index
    if n <= _FLAT_LIMIT:
        index = faiss.IndexFlatL2(d)
    else:
        nlist = int(np.sqrt(n))
        inverted = faiss.IndexIVFFlat(faiss.IndexFlatL2(d), d, nlist)
        inverted.cp.seed = 1234
        inverted.train(features[:: max(1, n // (nlist * 40))])
        inverted.nprobe = 8
        index = inverted
    index.add(features)
    return index


def nearest_patch_distances(queries: np.ndarray, database: np.ndarray, patch: int, *, wrap: bool = False):
    """For patches of ``queries`` (a Lab image), the distance to the nearest patch of
    ``database`` (another): the RMS over the patch's pixels of the CIELAB difference.

    Both sides are cut into all their ``patch`` x ``patch`` patches (a regular sub-grid of at
    most :data:`MAX_QUERIES` and :data:`MAX_DATABASE` of them on large images; all patches of
    the query image when ``wrap``, those over its edges wrapping round). The candidates are
    found in the patches' first :data:`COMPONENTS` principal components by faiss and re-ranked
    by their exact distance.

    Returns
    -------
    ndarray of float64
        One distance per query patch measured.
    """
    q_img = _wrapped(queries, patch) if wrap else queries
    q_shape = (q_img.shape[0] - patch + 1, q_img.shape[1] - patch + 1)
    d_shape = (database.shape[0] - patch + 1, database.shape[1] - patch + 1)
    q = _patches(q_img, *_grid(q_shape, MAX_QUERIES), patch)
    db = _patches(database, *_grid(d_shape, MAX_DATABASE), patch)
    with thread_budget():
        mean = db.mean(axis=0, dtype=np.float64)
        fit = db[:: max(1, len(db) // 20000)].astype(np.float64) - mean
        _, vectors = np.linalg.eigh(fit.T @ fit)  # the principal axes, by increasing variance
        basis = np.ascontiguousarray(vectors[:, ::-1][:, :COMPONENTS], dtype=np.float32)
        mean = mean.astype(np.float32)
        index = _index(np.ascontiguousarray((db - mean) @ basis))
        k = min(CANDIDATES, len(db))
        _, cand = index.search(np.ascontiguousarray((q - mean) @ basis), k)
    best = np.full(len(q), np.inf)
    for j in range(k):
        ok = cand[:, j] >= 0
        diff = q[ok] - db[cand[ok, j]]
        best[ok] = np.minimum(best[ok], np.einsum("ij,ij->i", diff, diff, dtype=np.float64))
    return np.sqrt(best / (patch * patch))


def _check_patch(patch: int, *images: np.ndarray) -> None:
    if int(patch) != patch or patch < 1 or patch % 2 == 0:
        raise InvalidInputError(f"patch must be an odd whole number of pixels >= 1, got {patch}")
    for name, image in zip(("result", "photo"), images):
        if min(image.shape[:2]) < patch:
            raise InvalidInputError(f"{name}: {image.shape[1]}x{image.shape[0]} is smaller than a {patch} px patch")


def coherence(result: np.ndarray, photo: np.ndarray, *, patch: int = 7, wrap: bool = False) -> float:
    """Mean distance from each patch of ``result`` to its nearest patch of ``photo``.

    Lower is better: 0 when every part of the result is copied from some part of the photo; a
    few units when it is made of the photo's material; 10 and more when the result shows
    something the photo does not (smears, blends, invented colour). The coherence term of the
    bidirectional similarity (mazzolini2012 §3).

    Parameters
    ----------
    result, photo : ndarray
        sRGB images, ``(H, W, 3)`` (or grey), uint8, uint16 or float in [0, 1].
    patch : int, default 7
        The patch side, px (odd).
    wrap : bool, default False
        The result tiles: its patches over its edges (wrapping round) count too, so a seam at
        the tile border is measured.

    Returns
    -------
    float
        CIELAB units (the RMS over a patch's pixels of their colour difference, averaged over
        the result's patches; a regular sub-grid of them on large images).
    """
    res, ph = as_lab(result, "result"), as_lab(photo, "photo")
    _check_patch(patch, res, ph)
    return float(nearest_patch_distances(res, ph, patch, wrap=wrap).mean())


def completeness(result: np.ndarray, photo: np.ndarray, *, patch: int = 7, wrap: bool = False) -> float:
    """Mean distance from each patch of ``photo`` to its nearest patch of ``result``: the
    completeness term of the bidirectional similarity (mazzolini2012 §3).

    Lower is better: near 0 when the result shows all of the photo; high when it keeps
    repeating a few parts of it and leaves others out (a result smaller than the photo cannot
    show all of it, so compare like sizes). ``wrap``: the result tiles (its patches over its
    edges are there to be found). Parameters and units as :func:`coherence`.
    """
    res, ph = as_lab(result, "result"), as_lab(photo, "photo")
    _check_patch(patch, res, ph)
    database = _wrapped(res, patch) if wrap else res
    return float(nearest_patch_distances(ph, database, patch).mean())


def gradient_energy(image: np.ndarray) -> float:
    """Mean squared gradient of an image's CIELAB lightness (central differences), per px²."""
    lightness = as_lab(image)[:, :, 0].astype(np.float64)
    gy, gx = np.gradient(lightness)
    return float(np.mean(gy * gy + gx * gx))


def sharpness_ratio(result: np.ndarray, photo: np.ndarray) -> float:
    """The result's mean gradient energy over the photo's (:func:`gradient_energy`).

    1 means as sharp as the photo; below 1 blurred (averaging of overlapping patches, the usual
    failure of patch-based synthesis, mazzolini2012 §4.3: 0.6 and below is visibly soft); above
    1 harsher than the photo (noise, hard seams).
    """
    reference = gradient_energy(photo)
    if reference <= 0.0:
        raise InvalidInputError("photo: a flat image has no sharpness to compare with")
    return gradient_energy(result) / reference


#: quantiles the colour distributions are compared at
_QUANTILES = (np.arange(2048) + 0.5) / 2048


def colour_distance(result: np.ndarray, photo: np.ndarray) -> float:
    """How far the result's colours are from the photo's, as distributions (where they are
    does not matter): the mean over L, a and b of the 1-D Wasserstein (earth mover's)
    distance between the two images' values, in CIELAB units.

    0 for the same colours in any arrangement; a uniform shift of ``d`` in one channel gives
    ``d / 3``; below about 1 is invisible, 3 and more a visible change of tone.
    """
    res, ph = as_lab(result, "result"), as_lab(photo, "photo")
    total = 0.0
    for c in range(3):
        qa = np.quantile(res[:, :, c].astype(np.float64), _QUANTILES)
        qb = np.quantile(ph[:, :, c].astype(np.float64), _QUANTILES)
        total += float(np.mean(np.abs(qa - qb)))
    return total / 3.0
