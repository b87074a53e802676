"""Height of the bark from its colour photo alone (wang2003 §3.3, made automatic).

Wang et al. 2003 build the height field by hand, texton channel by texton channel. barkgen
starts from an automatic estimate built from what the photo gives, which the self-similarity
editor (:mod:`barkgen.material.editor`) can then refine:

* **luminance bands** (band-pass differences of Gaussians an octave apart): in bark photos,
  and even more in the delit photogrammetry scans artists use, the dark is what light does not
  reach — fissures, furrows, the gaps between plates — so, band by band, dark is low. The band
  weights :data:`BAND_WEIGHTS` weigh the octaves where this holds, most of all 8 px (the
  photo's broad light is out before, :mod:`barkgen.material.illumination`).
* **texture energy** (local mean of the luminance gradient's magnitude, band by band): bark
  plates and ridges carry fine cracks and fibre, fissure floors are smooth — the texton idea of
  wang2003 §3.2 reduced to the one channel that tells high from low; on the plated pine it
  predicts relief better than luminance does.
* **the label map** (laitoch2018 §3.5, labels sorted darkest first): a coarse, non-linear cue
  "fissure labels are low, plate labels are high", smoothed so its steps do not make cliffs
  (the fit gives it little weight next to the bands: they already carry what it says).

The luminance cues are taken of the log-luminance (``log(luma + LOG_FLOOR)``): a fissure is as
dark against its ridges in the shade as in the sun, in ratio. The cues' sum sets the relief's
*shape*; its *depth* is set apart, per photo: the median slope of the height is :data:`STRENGTH`
times the median slope of the photo's luminance (Gaussian of :data:`REFERENCE_BLUR` px, luma in
[0, 1]). On the four scanned barks that luminance slope predicts the scans' own median tilt to
within +-5 % (the Sobel of the luminance at one strength has 0.31-0.34 of each scan's median
tilt), where the cues' sum, made of features in units of their own spread, does not.

Heights are in pixels: a unit slope is 45°. The weights were chosen by least squares of the
height's gradient against the gradients of four scanned normal maps (the team's data folder,
``BARKGEN_SHARED``), each scan weighed by its own slopes' spread, and :data:`STRENGTH` so that
the tilt distribution (median and 90th percentile) of ``make_material``'s normals matches the
scans' (issue 65: a strength that minimised the mean angle to the scans made the relief 2-3x
too shallow, as a timid normal map errs least where its direction is uncertain).
``benchmarks/bench_material.py`` reports only leave-one-out figures for them.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen._shared.threads import side_by_side
from barkgen.errors import InvalidInputError

#: (octave scale in px, weight) of the luminance bands; luminance in units of its std
BAND_WEIGHTS: tuple[tuple[float, float], ...] = ((2, 0.18), (4, 0.48), (8, 1.28), (16, 0.24), (32, 0.4))
#: (octave scale in px, weight) of the texture-energy bands (energy in units of its std)
ENERGY_WEIGHTS: tuple[tuple[float, float], ...] = ((4, 0.26), (8, -0.1), (16, 1.75))
#: weight of the label cue (the smoothed label rank in units of its std, like the bands)
LABEL_WEIGHT = -0.01
#: the height's median slope over the luminance's (:func:`reference_slope`): the strength whose
#: tilt distribution matches the four scans' (the median and 90th percentile of their tilts)
STRENGTH = 24.7
#: blur of the label cue, in px
LABEL_BLUR = 1.5
#: floor under the luminance before its logarithm (of luma in [0, 1])
LOG_FLOOR = 0.05
#: blur (px) of the luminance whose median slope sets the relief's depth
REFERENCE_BLUR = 2.0
#: slope of the shape from shading joined to the height, relative to the cues' height, when
#: the light is trusted (:func:`barkgen.material.shading.with_shading_height`)
SHADING_WEIGHT = 0.5


@dataclass(frozen=True)
class HeightConfig:
    """Parameters of :func:`estimate_height`.

    Parameters
    ----------
    bands : tuple of (float, float), default BAND_WEIGHTS
        ``(scale, weight)`` of the luminance octaves (dark is low).
    energy_bands : tuple of (float, float), default ENERGY_WEIGHTS
        ``(scale, weight)`` of the texture-energy octaves.
    label_weight : float, default LABEL_WEIGHT
        Weight of the label cue (dark labels are fissures).
    strength : float, default STRENGTH
        The height's median slope as a multiple of the luminance's (:func:`reference_slope`;
        the default is as fitted on scanned bark; 2 doubles the depth).
    shading_weight : float, default SHADING_WEIGHT
        Slope of the photo's shape from shading (integrated along the light) joined to the
        cues' height, relative to its slope, at full confidence in the light; 0 leaves it out.

    Raises
    ------
    InvalidInputError
        A band with a scale <= 0 or a strength that is not > 0.
    """

    bands: tuple[tuple[float, float], ...] = BAND_WEIGHTS
    energy_bands: tuple[tuple[float, float], ...] = ENERGY_WEIGHTS
    label_weight: float = LABEL_WEIGHT
    strength: float = STRENGTH
    shading_weight: float = SHADING_WEIGHT

    def __post_init__(self) -> None:
        if not self.bands or any(s <= 0 for s, _ in self.bands + self.energy_bands):
            raise InvalidInputError("height bands need positive scales")
        if not np.isfinite(self.strength) or self.strength <= 0:
            raise InvalidInputError(f"height strength must be > 0, not {self.strength}")
        if not (np.isfinite(self.shading_weight) and 0 <= self.shading_weight <= 10):
            raise InvalidInputError(f"the shading's weight in the height must be in [0, 10], not {self.shading_weight}")


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Rec. 709 luma of an ``(h, w, 3)`` float image (or the image itself when grey)."""
    rgb = np.asarray(rgb, np.float32)
    if rgb.ndim == 2:
        return rgb
    return rgb[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def band(
    image: np.ndarray, scale: float, boundary: Boundary, blurs: dict[float, np.ndarray] | None = None
) -> np.ndarray:
    """The band-pass octave of ``image`` around ``scale`` px: Gaussian(scale/2) - Gaussian(2 scale).

    ``blurs``: this image's blurs by sigma, filled and reused (bands two octaves apart share
    one: the five luminance bands need seven blurs, not ten)."""
    blurs = {} if blurs is None else blurs
    for sigma in (scale / 2, scale * 2):
        if sigma not in blurs:
            blurs[sigma] = boundary.blur(image, sigma)
    return blurs[scale / 2] - blurs[scale * 2]


def reference_slope(photo: np.ndarray, boundary: Boundary) -> float:
    """The median slope (per px) of the photo's luminance (luma in [0, 1], Gaussian of
    :data:`REFERENCE_BLUR` px): the scale the relief's depth is a multiple of."""
    gx, gy = boundary.gradient(boundary.blur(luminance(photo), REFERENCE_BLUR))
    return float(np.median(np.hypot(gx, gy)))


def texture_energy(lum: np.ndarray, scale: float, boundary: Boundary) -> np.ndarray:
    """Local mean (Gaussian, ``scale / 2``) of the gradient magnitude, in units of its std."""
    gx, gy = boundary.gradient(lum)
    energy = boundary.blur(np.hypot(gx, gy), scale / 2)
    return (energy - energy.mean()) / max(float(energy.std()), 1e-9)


def _energy_band(lum: np.ndarray, scale: float, boundary: Boundary) -> np.ndarray:
    """The band-pass octave around ``scale`` of the luminance's texture energy."""
    return band(texture_energy(lum, scale, boundary), scale, boundary)


def height_features(
    photo: np.ndarray, label_map: np.ndarray | None, config: HeightConfig, boundary: Boundary
) -> list[tuple[float, np.ndarray]]:
    """The weighted cues of :func:`estimate_height` as ``(weight, feature)`` pairs (each feature
    in units of its own std), so that fitting and estimating use one code path."""
    lum = np.log(luminance(photo).astype(np.float32) + np.float32(LOG_FLOOR))
    std = float(lum.std())
    if std < 1e-6:
        return []
    lum = (lum - lum.mean()) / std
    # the luminance's blurs (bands two octaves apart share one) and the energy bands, side by
    # side (the wide blurs run on one thread each: :func:`barkgen._shared.arrays.Boundary.blur`)
    sigmas = sorted({sigma for s, _ in config.bands for sigma in (s / 2, s * 2)}, reverse=True)
    blurs = dict(zip(sigmas, side_by_side([functools.partial(boundary.blur, lum, sigma) for sigma in sigmas])))
    cues = [(w, band(lum, s, boundary, blurs)) for s, w in config.bands]
    energies = side_by_side([functools.partial(_energy_band, lum, s, boundary) for s, _ in config.energy_bands])
    cues += [(w, energy) for (_, w), energy in zip(config.energy_bands, energies)]
    if label_map is not None:
        codes = np.asarray(label_map)
        if codes.shape != lum.shape:
            raise InvalidInputError(
                f"label map is {codes.shape[1]}x{codes.shape[0]} px but the photo is {lum.shape[1]}x{lum.shape[0]} px"
            )
        rank = codes.astype(np.float64) / max(int(codes.max()), 1)
        cue = boundary.blur(rank, LABEL_BLUR)
        cues.append((config.label_weight, (cue - cue.mean()) / max(float(cue.std()), 1e-6)))
    return cues


def estimate_height(
    photo: np.ndarray,
    label_map: np.ndarray | None = None,
    *,
    config: HeightConfig | None = None,
    boundary: Boundary | None = None,
) -> np.ndarray:
    """Height field estimated from a photo alone.

    A weighted sum of log-luminance octaves, texture-energy octaves and the label map, weights
    as fitted on scanned bark, its median slope ``config.strength`` times the luminance's
    (:func:`reference_slope`).

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        Float RGB (or grey) in [0, 1].
    label_map : ndarray, shape (h, w), optional
        Label codes sorted darkest first (e.g. of :func:`barkgen.labels.color_regions`); dark
        labels are fissures, hence low.
    config : HeightConfig, optional
        The cues' scales and weights.
    boundary : Boundary, optional
        Where the photo wraps (a photo that tiles, a synthesized tileable texture): the filters
        wrap around there, along both axes or along ``(rows, columns)`` (default: nowhere).

    Returns
    -------
    ndarray of float32, shape (h, w)
        Height in pixels, mean 0.

    References
    ----------
    .. [1] wang2003, §3.3 (height field assignment).

    Examples
    --------
    >>> import numpy as np
    >>> height = estimate_height(np.random.default_rng(0).random((64, 64, 3)))
    >>> height.shape, abs(float(height.mean())) < 1e-4
    ((64, 64), True)
    """
    config = config or HeightConfig()
    boundary = boundary or Boundary()
    cues = height_features(photo, label_map, config, boundary)
    if not cues:
        return np.zeros(np.asarray(photo).shape[:2], np.float32)
    height = np.zeros(cues[0][1].shape)
    for weight, feature in cues:
        if weight:
            height += weight * feature
    gx, gy = boundary.gradient(height)
    slope = float(np.median(np.hypot(gx, gy)))
    if slope <= 1e-12:
        return np.zeros(height.shape, np.float32)
    height *= config.strength * reference_slope(photo, boundary) / slope
    return (height - height.mean()).astype(np.float32)
