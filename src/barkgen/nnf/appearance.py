"""Appearance-space neighbourhood features (Lefebvre & Hoppe 2006, "Appearance-space texture
synthesis", §3): every pixel's Gaussian-weighted ``s x s`` neighbourhood of feature channels is
projected onto its first ``D`` principal components, so that a neighbourhood distance costs ``D``
multiply-adds instead of ``s * s * C``.

The projection is linear, ``a(p) = P · (n(p) - mu)``, so the same ``P`` turns any output
neighbourhood into a vector comparable with the exemplar's (laitoch2018 §3.3.4: the L2 distance of
square neighbourhoods, here in a reduced space).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class NeighbourhoodProjection:
    """PCA projection of ``size x size`` neighbourhoods.

    ``weights[d, dy, dx, c]`` maps the centred neighbourhood to component ``d``;
    ``mean[dy, dx, c]`` is the mean neighbourhood; ``features`` is ``(h * w, D)`` float32, the
    projected exemplar neighbourhoods (reflected at the exemplar border).
    """

    size: int
    weights: np.ndarray
    mean: np.ndarray
    features: np.ndarray
    scale: float  # mean squared distance to the nearest other neighbourhood (typical cost)


def _gaussian_window(size: int) -> np.ndarray:
    r = size // 2
    sigma = max(size / 3.0, 0.8)
    g = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    return np.sqrt(np.outer(g, g)).astype(np.float32)  # sqrt: the distance uses its square


def _sample_neighbourhoods(image: np.ndarray, size: int, max_samples: int) -> np.ndarray:
    """Neighbourhood vectors at a regular grid of at most ``max_samples`` pixels (deterministic)."""
    h, w, c = image.shape
    r = size // 2
    pad = np.pad(image, ((r, r), (r, r), (0, 0)), mode="reflect")
    step = max(1, int(np.ceil(np.sqrt(h * w / max_samples))))
    ys = np.arange(0, h, step)
    xs = np.arange(0, w, step)
    win = np.lib.stride_tricks.sliding_window_view(pad, (size, size), axis=(0, 1))
    # win: (h, w, c, size, size) -> (n, size, size, c)
    sel = win[ys[:, None], xs[None, :]].reshape(-1, c, size, size)
    return np.ascontiguousarray(sel.transpose(0, 2, 3, 1)).reshape(len(ys) * len(xs), -1)


def neighbourhood_pca(
    image: np.ndarray, size: int, n_components: int, max_samples: int = 8192, wrap: bool | tuple[bool, bool] = False
) -> NeighbourhoodProjection:
    """Fit the neighbourhood PCA of an ``(h, w, C)`` float32 feature image and project it.

    The principal axes are fitted on a regular grid of neighbourhoods (so the fit is independent of
    any seed) and the full projection is computed with one correlation filter per (component,
    channel) pair; ``wrap`` (per axis ``(rows, columns)``): the image tiles itself, so its
    neighbourhoods run round its edges.
    """
    image = np.ascontiguousarray(image, dtype=np.float32)
    h, w, c = image.shape
    win = _gaussian_window(size)
    samples = _sample_neighbourhoods(image, size, max_samples).astype(np.float64)
    samples *= np.repeat(win.reshape(-1), c)[None, :]
    mean = samples.mean(axis=0)
    centred = samples - mean
    cov = centred.T @ centred / max(len(centred) - 1, 1)
    evals, evecs = np.linalg.eigh(cov)
    order = np.argsort(evals)[::-1][:n_components]
    basis = evecs[:, order]
    # fix the sign of each axis so the projection is reproducible across LAPACK builds
    signs = np.sign(basis[np.argmax(np.abs(basis), axis=0), np.arange(basis.shape[1])])
    basis = basis * np.where(signs == 0, 1.0, signs)
    d = basis.shape[1]
    weights = (basis.T.reshape(d, size, size, c) * win[None, :, :, None]).astype(np.float32)
    mean_nb = (mean.reshape(size, size, c) / np.maximum(win[:, :, None], 1e-12)).astype(np.float32)

    features = project_neighbourhoods(image, weights, mean_nb, wrap=wrap)
    return NeighbourhoodProjection(size=size, weights=weights, mean=mean_nb, features=features, scale=1.0)


def project_neighbourhoods(
    image: np.ndarray, weights: np.ndarray, mean: np.ndarray, wrap: bool | tuple[bool, bool] = False
) -> np.ndarray:
    """Project every ``size x size`` neighbourhood of ``image`` ``(h, w, C)``:
    ``a(p) = sum weights[d, dy, dx, c] * (image[p + (dy, dx), c] - mean[dy, dx, c])``, one
    correlation filter per (component, channel) pair. Borders are reflected, or wrapped around
    when ``wrap`` (tileable outputs, exemplars that tile; a pair ``(rows, columns)`` wraps each
    axis on its own). Returns ``(h * w, D)`` float32."""
    import cv2

    image = np.ascontiguousarray(image, dtype=np.float32)
    h, w, c = image.shape
    d, size = weights.shape[0], weights.shape[1]
    r = size // 2
    wrap_y, wrap_x = (wrap, wrap) if isinstance(wrap, (bool, np.bool_)) else wrap
    wrap = bool(wrap_y or wrap_x)
    if wrap:  # the axis that does not wrap is reflected like the filter's own border
        image = np.pad(image, ((r, r), (0, 0), (0, 0)), mode="wrap" if wrap_y else "reflect")
        image = np.pad(image, ((0, 0), (r, r), (0, 0)), mode="wrap" if wrap_x else "reflect")
    features = np.empty((h, w, d), np.float32)
    offset = np.einsum("dyxc,yxc->d", weights, mean)
    channels = [np.ascontiguousarray(image[:, :, ch]) for ch in range(c)]
    for k in range(d):
        acc = np.zeros(image.shape[:2], np.float32)
        for ch in range(c):
            kern = np.ascontiguousarray(weights[k, :, :, ch])
            acc += cv2.filter2D(channels[ch], cv2.CV_32F, kern, anchor=(r, r), borderType=cv2.BORDER_REFLECT_101)
        features[:, :, k] = (acc[r : r + h, r : r + w] if wrap else acc) - offset[k]
    return np.ascontiguousarray(features.reshape(h * w, d))
