"""Spectra of the bi-layer model (guingo2017 §3): local spectra by Welch's method, global
spectra by the auto-correlation estimator with missing data, and stationary Gaussian noise
from a spectrum.

Conventions: a spectrum ``S`` is the magnitude of a ``T x T`` discrete spectrum with the
zero frequency at ``[0, 0]`` (numpy FFT order); its power ``S**2`` averages to the noise's
variance (``mean(S**2) == var``), whatever ``T``.

References:
    Guingo, Sauvage, Dischler, Cani (2017), Bi-Layer textures, §3.3, eq. 3-5.
    Welch (1967), the use of the FFT for the estimation of power spectra.
"""

from __future__ import annotations

import numpy as np

from barkgen.errors import InvalidInputError

#: the local-spectrum window sizes offered to the user (guingo2017 §5: T_loc = 2, 4, 8, 16)
TLOC_CHOICES = (2, 4, 8, 16)
#: size of the global spectra (guingo2017 §3.3: "we used T = 64 in all our examples")
SPECTRUM_SIZE = 64


def check_tloc(tloc: int) -> int:
    if int(tloc) != tloc or int(tloc) not in TLOC_CHOICES:
        raise InvalidInputError(f"T_loc must be one of {', '.join(map(str, TLOC_CHOICES))}, not {tloc}")
    return int(tloc)


def _window(t: int) -> np.ndarray:
    """A Hann taper of ``t`` samples without zero ends (so that t = 2 keeps both samples)."""
    return np.hanning(t + 2)[1:-1]


def local_spectra(luminance: np.ndarray, tloc: int) -> np.ndarray:
    """Local spectrum of every pixel (guingo2017 §3.3, Fig. 6a).

    Welch's method: the modified (Hann-tapered) periodograms of all ``tloc x tloc`` windows
    within a ``2 tloc`` neighbourhood of the pixel are averaged. Each of the ``tloc *
    (tloc // 2 + 1)`` frequencies of the half plane is one filter response, so the whole map
    costs ``D`` image filterings. The vector holds magnitudes scaled so that its squared norm
    is the local mean power (the mean intensity included, as in the paper, which clusters
    ``I`` and not ``N``); Euclidean distances between vectors are distances between full
    spectra.

    Parameters
    ----------
    luminance : ndarray, shape (H, W)
        The image's luminance in [0, 1].
    tloc : {2, 4, 8, 16}
        Window size.

    Returns
    -------
    ndarray of float32, shape (H, W, D)
        ``D = tloc * (tloc // 2 + 1)``.

    References
    ----------
    .. [1] guingo2017, §3.3 and Fig. 6a (local spectra).
    .. [2] welch1967 (averaged modified periodograms).

    Examples
    --------
    >>> import numpy as np
    >>> local_spectra(np.zeros((32, 32)), 4).shape
    (32, 32, 12)
    """
    import cv2

    t = check_tloc(tloc)
    image = np.ascontiguousarray(luminance, dtype=np.float32)
    w1 = _window(t)
    taper = np.outer(w1, w1)
    norm = float((taper**2).sum())
    u = np.arange(t)
    features = []
    for fy in range(t):
        for fx in range(t // 2 + 1):
            phase = -2.0 * np.pi * (fy * u[:, None] + fx * u[None, :]) / t
            re = cv2.filter2D(image, -1, (taper * np.cos(phase)).astype(np.float32), borderType=cv2.BORDER_REFLECT)
            im = cv2.filter2D(image, -1, (taper * np.sin(phase)).astype(np.float32), borderType=cv2.BORDER_REFLECT)
            power: np.ndarray = (re * re + im * im) / norm
            power = cv2.blur(power, (t + 1, t + 1), borderType=cv2.BORDER_REFLECT)  # Welch average
            twin = 2.0 if 0 < fx < t - fx else 1.0  # the conjugate twin of the other half plane
            features.append(np.sqrt(np.maximum(power, 0.0) * (twin / (t * t))))
    return np.stack(features, axis=-1).astype(np.float32)


def welch_power(image: np.ndarray, size: int) -> np.ndarray:
    """Power spectrum (``size x size``, numpy FFT order) of an image's stationary part, summed
    over its channels: Welch's method with Hann-tapered windows overlapping by half, each
    window's mean removed. Same convention as the model's spectra: the power averages to the
    variance (summed over channels)."""
    image = np.asarray(image, np.float64)
    if image.ndim == 2:
        image = image[:, :, None]
    t = int(size)
    if image.shape[0] < t or image.shape[1] < t:
        raise InvalidInputError(f"the image ({image.shape[1]}x{image.shape[0]}) is smaller than one {t}x{t} window")
    step = max(1, t // 2)
    windows = np.lib.stride_tricks.sliding_window_view(image, (t, t), axis=(0, 1))[::step, ::step]
    w1 = _window(t)
    taper = np.outer(w1, w1)
    power = np.zeros((t, t))
    for row in windows:  # one row of windows at a time: memory stays small for large images
        row = row - row.mean(axis=(-2, -1), keepdims=True)
        power += (np.abs(np.fft.fft2(row * taper)) ** 2).sum(axis=(0, 1))  # over windows, channels
    return power / (windows.shape[0] * windows.shape[1] * float((taper**2).mean() * t * t))


def _parzen(n_lags: int) -> np.ndarray:
    """Parzen lag window over lags ``0..n_lags`` (its transform is non-negative)."""
    r = np.arange(n_lags + 1) / (n_lags + 1)
    return np.where(r <= 0.5, 1 - 6 * r**2 + 6 * r**3, 2 * (1 - r) ** 3)


def estimate_spectrum(signal: np.ndarray, mask: np.ndarray, size: int = SPECTRUM_SIZE) -> np.ndarray:
    """Spectrum ``S`` (``size x size``) of a stationary noise seen only where ``mask`` is set.

    guingo2017 §3.3, eq. 3-5: the image is paved with ``size x size`` windows ``Y`` (here
    overlapping by half); in each, the auto-correlation is summed over the pixel pairs whose
    both ends lie in ``M ∩ Y`` (eq. 4), and the windows are pooled weighted by their data
    (eq. 5). Two refinements over the paper: lags are linear (each window zero-padded to
    ``2 size``) rather than modulo ``size``, and each lag is divided by its own pair count
    instead of ``|M ∩ Y|``, so holes in the mask do not bias long lags towards zero; a Parzen
    lag window (non-negative transform) over lags ``< size / 2`` turns the correlation into a
    smooth, non-negative power spectrum.

    Parameters
    ----------
    signal : ndarray, shape (H, W)
        The noise (one channel).
    mask : ndarray of bool, shape (H, W)
        Where the noise is seen.
    size : int, default SPECTRUM_SIZE
        Side T of the spectrum.

    Returns
    -------
    ndarray, shape (size, size)
        Magnitudes, zero frequency at ``[0, 0]``; ``mean(S**2)`` is the noise's variance.

    Raises
    ------
    InvalidInputError
        A signal that is not 2-D or a mask of another shape.

    References
    ----------
    .. [1] guingo2017, §3.3, eq. 3-5 (spectrum estimation with missing data).
    """
    signal = np.asarray(signal, np.float64)
    mask = np.asarray(mask, bool)
    if signal.shape != mask.shape or signal.ndim != 2:
        raise InvalidInputError("estimate_spectrum needs a 2-D signal and a mask of the same shape")
    t = int(size)
    if t < 8 or t % 2:
        raise InvalidInputError(f"spectrum size must be even and at least 8, not {size}")
    h, w = signal.shape
    if h < t or w < t:
        raise InvalidInputError(f"the signal ({w}x{h}) is smaller than one {t}x{t} window")
    if not mask.any():
        raise InvalidInputError("the mask is empty: no data to estimate a spectrum from")
    values = np.where(mask, signal, 0.0)
    weights = mask.astype(np.float64)

    def starts(n: int) -> list[int]:
        s = list(range(0, n - t + 1, t // 2))
        return s if s[-1] == n - t else s + [n - t]

    ys, xs = starts(h), starts(w)
    a = np.stack([values[y : y + t, x : x + t] for y in ys for x in xs])
    m = np.stack([weights[y : y + t, x : x + t] for y in ys for x in xs])
    keep = m.reshape(len(m), -1).sum(axis=1) > 0
    a, m = a[keep], m[keep]
    pad = (2 * t, 2 * t)
    sums = np.fft.irfft2(np.abs(np.fft.rfft2(a, s=pad)) ** 2, s=pad).sum(axis=0)
    pairs = np.fft.irfft2(np.abs(np.fft.rfft2(m, s=pad)) ** 2, s=pad).sum(axis=0)
    pairs = np.rint(pairs)
    half = t // 2
    lags = np.r_[0:half, -half:0]  # the lags kept, in FFT order of a size-t grid
    sums, pairs = sums[np.ix_(lags % (2 * t), lags % (2 * t))], pairs[np.ix_(lags % (2 * t), lags % (2 * t))]
    enough = pairs >= max(1.0, 0.01 * pairs[0, 0])
    correlation = np.where(enough, sums / np.maximum(pairs, 1.0), 0.0)
    taper = _parzen(half)[np.abs(lags)]
    correlation *= np.outer(taper, taper)
    correlation[half, :] = 0.0  # the Nyquist lag row / column: not estimated (lag -half only)
    correlation[:, half] = 0.0
    power = np.fft.fft2(correlation).real
    floor = 1e-6 * max(float(power.max()), 1e-20)
    return np.sqrt(np.maximum(power, floor)).astype(np.float32)


def noise_kernel(spectrum: np.ndarray) -> np.ndarray:
    """The zero-phase convolution kernel of a spectrum, centred in its array: white noise of
    unit variance convolved with it is Gaussian noise of power spectrum ``spectrum**2``."""
    kernel = np.fft.ifft2(np.asarray(spectrum, np.float64)).real
    return np.fft.fftshift(kernel)


def noise_from_white(white: np.ndarray, spectrum: np.ndarray) -> np.ndarray:
    """Periodic Gaussian noise of spectrum ``spectrum`` from white noise of the output's size
    (random phase, guingo2017 eq. 1; sharing ``white`` between spectra shares the phases,
    §3.2). A kernel larger than the output wraps round it: the noise of a torus smaller than
    the spectrum."""
    n_y, n_x = white.shape
    t = spectrum.shape[0]
    kernel = np.zeros((n_y, n_x))
    rows = (np.arange(t) - t // 2) % n_y  # centred at the origin
    cols = (np.arange(t) - t // 2) % n_x
    np.add.at(kernel, (rows[:, None], cols[None, :]), noise_kernel(spectrum))
    return np.fft.irfft2(np.fft.rfft2(white) * np.fft.rfft2(kernel), s=white.shape).astype(np.float32)
