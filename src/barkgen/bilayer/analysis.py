"""Analysis of an exemplar into the bi-layer model (guingo2017 §3.3, §5, §6).

``I = P + N``: the structure ``P`` is ``I`` filtered by a joint bilateral filter guided by the
local spectra (§5), ``N = I - P``; masks ``M_k`` come from K-means of the local spectra of
``I`` (§3.3); the global spectra ``S_k`` of the noise, one per cluster and per PCA colour
channel (§6), from the auto-correlation estimator with missing data (eq. 3-5).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from barkgen._shared.memory import check_memory_budget
from barkgen.bilayer.model import BilayerModel, NoiseStatistics
from barkgen.bilayer.options import AnalysisOptions, as_rgb, estimate_analysis_memory
from barkgen.bilayer.spectra import estimate_spectrum, local_spectra

#: quantiles kept per cluster and channel for the noise's histogram equalisation (§6)
N_QUANTILES = 257


def _reduce(features: np.ndarray, dims: int, rng: np.random.Generator) -> np.ndarray:
    """Project feature vectors on their first ``dims`` principal axes (distances kept up to
    the discarded variance), for a cheap bilateral range kernel."""
    h, w, d = features.shape
    flat = features.reshape(-1, d)
    if d <= dims:
        return np.ascontiguousarray(features)
    sample = flat[rng.choice(len(flat), min(len(flat), 20000), replace=False)]
    mean = sample.mean(axis=0)
    _, _, vt = np.linalg.svd(sample - mean, full_matrices=False)
    return np.ascontiguousarray(((flat - mean) @ vt[:dims].T).reshape(h, w, dims).astype(np.float32))


def extract_structure(
    image: np.ndarray, spectra: np.ndarray, options: AnalysisOptions, rng: np.random.Generator
) -> np.ndarray:
    """``P``: the image iterated through a joint bilateral filter whose range kernel compares
    local spectra (guingo2017 §5): pixels are averaged only with pixels of similar spectral
    content, so structure borders stay sharp while the noise inside each region is removed."""
    from barkgen._shared.bands import row_bands
    from barkgen.bilayer._kernels import joint_bilateral

    guide = _reduce(spectra, 8, rng)
    structure = np.ascontiguousarray(image, dtype=np.float32)
    height, width, channels = structure.shape
    taps = (2 * options.radius + 1) ** 2
    bands = row_bands(height, width * taps * (guide.shape[2] + channels))
    for _ in range(options.iterations):
        filtered = np.empty_like(structure)
        for start, stop in bands:  # Ctrl-C is heard between bands
            joint_bilateral(
                structure, guide, options.radius, options.radius / 2.0, options.sigma_range, filtered, start, stop
            )
        structure = filtered
    return structure


def barycentric_weights(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Convex barycentric coordinates of ``points`` (N, D) over ``centres`` (K, D) that keep
    the points' relative distances to the centres (guingo2017 §3.3).

    The coordinates ``w`` (summing to 1) of the point ``B = sum_k w_k c_k`` whose squared
    distances to the centres are the point's own times one factor ``s``:
    ``|B - c_k|^2 = s |x - c_k|^2`` for every ``k``. Differences of two such equations are
    linear in ``w`` (``B`` is in the centres' affine span), so ``w = u + s v`` solves a K x K
    system; the first equation is then a quadratic in ``s``. Of its roots, the one whose
    ``w`` has the least negative mass is kept, and ``w`` is made convex (negative parts
    dropped, renormalised). A point inside the centres' hull gets its exact coordinates
    (``s = 1``, ``B = x``); a point off their span gets the barycentre at its distance ratios.

    Parameters
    ----------
    points : ndarray, shape (N, D)
    centres : ndarray, shape (K, D)

    Returns
    -------
    ndarray of float32, shape (N, K)
        Non-negative, summing to 1 per point.

    References
    ----------
    .. [1] guingo2017, §3.3 ("a convex barycenter of {S_k^loc} that preserves the relative
       distances").
    """
    x = np.asarray(points, np.float64)
    c = np.asarray(centres, np.float64)
    k = c.shape[0]
    if k == 1:
        return np.ones((len(x), 1), np.float32)
    scale = max(float(np.abs(c).max()), 1e-30)  # unit-free: distances relative to the centres'
    x, c = x / scale, c / scale
    gram = c @ c.T
    d2 = np.maximum((x**2).sum(axis=1)[:, None] - 2.0 * x @ c.T + np.diag(gram)[None, :], 0.0)  # (N, K)
    system = np.vstack([-2.0 * (gram[1:] - gram[0]), np.ones((1, k))])
    inverse = np.linalg.pinv(system)  # centres that are not affinely independent: least squares
    fixed = np.concatenate([-(np.diag(gram)[1:] - gram[0, 0]), [1.0]])
    u = inverse @ fixed  # (K,)
    rhs = np.concatenate([d2[:, 1:] - d2[:, :1], np.zeros((len(x), 1))], axis=1)  # (N, K)
    v = rhs @ inverse.T
    u0 = u.copy()
    u0[0] -= 1.0  # w - e_0: B - c_0 in coordinates
    a = np.einsum("nk,kl,nl->n", v, gram, v)
    b = 2.0 * (v @ (gram @ u0)) - d2[:, 0]
    const = float(u0 @ gram @ u0)
    disc = b * b - 4.0 * a * const
    safe_a = np.where(np.abs(a) > 1e-12, a, 1.0)
    root = np.sqrt(np.maximum(disc, 0.0))
    candidates = np.stack([(-b + root) / (2.0 * safe_a), (-b - root) / (2.0 * safe_a)], axis=1)  # (N, 2)
    linear = np.abs(a) <= 1e-12  # one root: -const / b
    candidates[linear] = (-const / np.where(np.abs(b[linear]) > 1e-12, b[linear], 1.0))[:, None]
    weights = u[None, None, :] + candidates[:, :, None] * v[:, None, :]  # (N, 2, K)
    negative = np.minimum(weights, 0.0).sum(axis=2) - 1e-9 * (candidates < 0)  # prefer s >= 0 on ties
    best = np.argmax(negative, axis=1)
    w = np.maximum(weights[np.arange(len(x)), best], 0.0)
    total = w.sum(axis=1, keepdims=True)
    nearest = d2.argmin(axis=1)
    empty = total[:, 0] <= 1e-12
    w[empty] = 0.0
    w[empty, nearest[empty]] = 1.0
    total[empty] = 1.0
    return (w / total).astype(np.float32)


def cluster_spectra(spectra: np.ndarray, k: int, kind: str, rng: np.random.Generator):
    """K-means of the local spectra (guingo2017 §3.3): ``(labels, distances, masks)`` with the
    distance of every pixel to every centre, and masks binary or convex-barycentric
    (:func:`barycentric_weights`)."""
    from sklearn.cluster import KMeans

    h, w, d = spectra.shape
    flat = spectra.reshape(-1, d).astype(np.float32)
    sample = flat[rng.choice(len(flat), min(len(flat), 20000), replace=False)]
    km = KMeans(n_clusters=k, n_init=4, random_state=int(rng.integers(2**31 - 1))).fit(sample)
    centres = km.cluster_centers_.astype(np.float32)
    order = np.argsort(np.linalg.norm(centres, axis=1))  # clusters sorted by power: stable ids
    centres = centres[order]
    sq = (flat**2).sum(axis=1)[:, None] - 2 * flat @ centres.T + (centres**2).sum(axis=1)[None, :]
    distances = np.sqrt(np.maximum(sq, 0.0)).reshape(h, w, k)
    labels = distances.argmin(axis=2)
    if kind == "binary":
        masks = (labels[:, :, None] == np.arange(k)).astype(np.float32)
    else:  # the convex barycentre that keeps the relative distances to the centres
        masks = barycentric_weights(flat, centres).reshape(h, w, k)
    return labels, distances, masks


def border_band(labels: np.ndarray, width: int) -> np.ndarray:
    """Pixels within ``width`` px of a border between clusters (guingo2017 §6, Fig. 16)."""
    import cv2

    edge = np.zeros(labels.shape, bool)
    edge[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    edge[:, :-1] |= labels[:, 1:] != labels[:, :-1]
    edge[1:, :] |= labels[1:, :] != labels[:-1, :]
    edge[:-1, :] |= labels[1:, :] != labels[:-1, :]
    if width <= 0 or not edge.any():
        return np.zeros(labels.shape, bool)
    dist = cv2.distanceTransform((~edge).astype(np.uint8), cv2.DIST_L2, 3)
    return dist < width


def noise_statistics(
    noise: np.ndarray,
    labels: np.ndarray,
    distances: np.ndarray,
    options: AnalysisOptions,
    exclude: np.ndarray | None = None,
) -> NoiseStatistics:
    """Spectra, PCA colour bases and quantiles of each cluster's noise (§3.3, §6)."""
    h, w, _ = noise.shape
    k = options.k
    t = min(options.spectrum_size, (min(h, w) // 2) * 2)
    spectra = np.zeros((k, 3, t, t), np.float32)
    bases = np.tile(np.eye(3, dtype=np.float32), (k, 1, 1))
    means = np.zeros((k, 3), np.float32)
    sigmas = np.ones((k, 3), np.float32)
    n_q = N_QUANTILES if options.equalize else 1
    quantiles = np.zeros((k, 3, n_q), np.float32)
    probs = np.linspace(0.0, 1.0, n_q)
    for c in range(k):
        member = labels == c
        if exclude is not None:
            member &= ~exclude
        if member.sum() < 16:
            continue  # an empty cluster: no noise
        d = distances[:, :, c]
        core = member & (d <= np.quantile(d[member], options.core))
        vectors = noise[core].astype(np.float64)
        means[c] = vectors.mean(axis=0)
        cov = np.cov((vectors - means[c]).T)
        evals, evecs = np.linalg.eigh(cov)
        bases[c] = evecs[:, ::-1]
        for ch in range(3):
            projected = (noise - means[c]) @ bases[c][:, ch]
            spectrum = estimate_spectrum(projected, core, t).astype(np.float64)
            # the shape from the core, the energy from the whole cluster: the 10 % left out
            # are the most unusual pixels (often the strongest grain), and without them the
            # synthesized noise would be weaker than the photo's
            energy = float((spectrum**2).mean())
            target = float(projected[member].var())
            if energy > 0 and target > 0:
                spectrum *= np.sqrt(target / energy)
            spectra[c, ch] = spectrum
            sigmas[c, ch] = max(float(np.sqrt((spectrum**2).mean())), 1e-6)
            if options.equalize:
                quantiles[c, ch] = np.quantile(projected[core], probs)
    return NoiseStatistics(spectra, bases, means, sigmas, quantiles)


def analyze(
    exemplar: np.ndarray, options: AnalysisOptions | None = None, *, progress: Callable[[int, int], None] | None = None
):
    """Instantiate the bi-layer model from one exemplar (guingo2017 Fig. 4, left).

    The colour is analysed through its luminance (CIELAB L): local spectra, masks and the
    filter's guide come from it; ``P`` and ``N`` are colour layers (§6).

    Parameters
    ----------
    exemplar : ndarray, shape (h, w) or (h, w, C)
        The photo: uint8, uint16 or float in [0, 1], at least 32 px a side.
    options : AnalysisOptions, optional
        ``k``, ``tloc`` and the filter's parameters.
    progress : callable, optional
        ``progress(done, total)`` callback over the four steps.

    Returns
    -------
    BilayerModel
        Structure, masks, labels and noise statistics of the exemplar.

    Raises
    ------
    InvalidInputError
        An exemplar that is too small or not an image.
    MemoryBudgetError
        The analysis would not fit ``options.max_memory`` (checked before any work).

    References
    ----------
    .. [1] guingo2017, §3.3 (masks and spectra), §5 (the structure by a joint bilateral filter),
       §6 (colour, borders, equalisation).

    Examples
    --------
    >>> import barkgen
    >>> photo = barkgen.read_image(barkgen.sample_exemplar_path())[:64, :64]
    >>> analyze(photo, AnalysisOptions(k=2, tloc=4)).masks.shape
    (64, 64, 2)
    """
    from barkgen.color import rgb_to_lab

    options = options or AnalysisOptions()
    h, w = np.shape(exemplar)[:2]
    check_memory_budget(
        estimate_analysis_memory((h, w)), options.max_memory, f"the bi-layer analysis of a {w}x{h} photo"
    )
    image = as_rgb(exemplar)
    rng = np.random.default_rng(options.seed)
    steps = 4

    def step(i: int) -> None:
        if progress:
            progress(i, steps)

    luminance = rgb_to_lab(image)[:, :, 0] / 100.0
    spectra = local_spectra(luminance, options.tloc)
    step(1)
    structure = extract_structure(image, spectra, options, rng)
    step(2)
    labels, distances, masks = cluster_spectra(spectra, options.k, options.masks, rng)
    band = border_band(labels, options.border) if options.border else None
    if band is not None:
        structure[band] = image[band]
    noise = image - structure
    step(3)
    stats = noise_statistics(noise, labels, distances, options, exclude=band)
    step(4)
    return BilayerModel(
        exemplar=image, structure=structure, masks=masks, labels=labels.astype(np.uint8), noise=stats, options=options
    )
