"""Light direction of a photo, shape from its shading, and shading removal, T = I / (N·L)
(wang2003 §3.4).

Wang et al. have the user move a light until the rendered height field is lit like the photo.
barkgen automates that match in two ways:

* **Lambertian match** (:func:`estimate_light` without a height): the direction (azimuth x
  elevation grid) whose rendering ``N·L`` of the estimated normals correlates best with the
  photo's luminance.
* **Joint fit of light and shape** (with the height cue): under a directional light the
  luminance follows the slope *along the light*, not the height, so the "dark is deep" cues
  of :mod:`.height` are nearly blind to it. For each azimuth, the log-luminance's high-pass is
  integrated along that azimuth (:func:`shape_from_shading`: Fourier division by the
  directional derivative, Tikhonov-regularised); the azimuth whose integrated shading agrees
  best with the light-independent height cues (texture energy, occlusion darkness) is the
  light's. On renders of four scanned barks under known lights (``bench_relief.py``) this
  halves the median azimuth error of the Lambertian match. The integrated shading then joins
  the height (:func:`with_shading_height`), weighted by how well the two agreed.

The agreement is only a few hundredths on most bark photos (most bark textures are
photographed in diffuse light or delit), so the division is floored (:data:`SHADING_FLOOR`),
the estimate is reported with its correlation, and ``--light AZ,EL`` overrides it.

Angles: azimuth in degrees counter-clockwise from the image's +x (right) axis, +y up;
elevation in degrees above the surface (90 = from the viewer).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from barkgen._shared.arrays import Boundary
from barkgen.color import linear_to_srgb, srgb_to_linear
from barkgen.errors import InvalidInputError
from barkgen.material.height import luminance

#: the light directions tried by :func:`estimate_light` (degrees)
AZIMUTHS = tuple(range(0, 360, 15))
ELEVATIONS = (20.0, 30.0, 45.0, 60.0, 75.0, 90.0)
#: floor of N·L in the division, so grazing or back-facing pixels do not explode
SHADING_FLOOR = 0.2
#: the largest shading strength (exponent of N·L) fitted by :func:`shading_strength`, and the
#: bisection steps of the fit: 2 covers a Lambertian render whose light's elevation is
#: estimated 15 degrees off (the fit's 1.9-2.0); up to 8 was allowed while the relief was 2-3x
#: too shallow (issue 65), and with the relief at its real depth a larger exponent divides
#: out the albedo's own dark patches where the relief is low (a birch's lenticels)
MAX_STRENGTH = 2.0
STRENGTH_STEPS = 16
#: pixels sampled to fit the shading strength
FIT_PIXELS = 262_144
#: azimuths tried by the joint light fit (degrees)
FIT_AZIMUTHS = tuple(range(0, 360, 5))
#: the longest side the joint light fit works at (larger photos are reduced first)
FIT_SIDE = 512
#: the scale (px) above which the log-luminance is not read as shading (:func:`shape_from_shading`)
SHADING_BAND = 16.0
#: Tikhonov regulariser of the integration along the light (squared radians per pixel)
INTEGRATION_REGULARISER = 0.02
#: width (px) of the taper at borders that do not wrap (the Fourier integration wraps)
BORDER_TAPER = 16
#: the agreement of shading and height cues (:func:`estimate_light`) at which the integrated
#: shading starts to join the height, and at which it has its full weight
AGREEMENT_START = 0.04
AGREEMENT_FULL = 0.12


@dataclass(frozen=True)
class Light:
    """A directional light.

    Parameters
    ----------
    azimuth : float
        Degrees counter-clockwise from the image's right (+x), +y up; in [-360, 360].
    elevation : float
        Degrees above the surface, in (0, 90].
    correlation : float, optional
        How much of the photo's shading the estimate explains (``None`` when given by the user).

    Attributes
    ----------
    vector : ndarray of float32, shape (3,)
        Unit vector ``(x right, y up, z out)``.

    Raises
    ------
    InvalidInputError
        Angles that are not finite or out of range.

    Examples
    --------
    >>> Light(0.0, 90.0).vector.round(6).tolist()
    [0.0, 0.0, 1.0]
    """

    azimuth: float
    elevation: float
    correlation: float | None = None

    def __post_init__(self) -> None:
        if not (np.isfinite(self.azimuth) and np.isfinite(self.elevation)):
            raise InvalidInputError("light angles must be finite numbers")
        if not 0.0 < self.elevation <= 90.0:
            raise InvalidInputError(f"light elevation must be in (0, 90] degrees, not {self.elevation:g}")
        if not -360.0 <= self.azimuth <= 360.0:
            raise InvalidInputError(f"light azimuth must be in [-360, 360] degrees, not {self.azimuth:g}")

    @property
    def vector(self) -> np.ndarray:
        """Unit vector ``(x right, y up, z out)``."""
        az, el = np.radians(self.azimuth), np.radians(self.elevation)
        return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], np.float32)


def parse_light(text: str) -> Light:
    """Parse ``"AZ,EL"`` (degrees) into a :class:`Light`.

    Parameters
    ----------
    text : str
        Azimuth and elevation in degrees, comma separated.

    Returns
    -------
    Light

    Raises
    ------
    InvalidInputError
        Not two numbers, or angles out of range (one line).

    Examples
    --------
    >>> parse_light("135,35")
    Light(azimuth=135.0, elevation=35.0, correlation=None)
    """
    parts = text.replace(" ", "").split(",")
    try:
        az, el = (float(p) for p in parts)
    except ValueError:
        raise InvalidInputError(f"light must be AZ,EL in degrees (e.g. 135,45), not {text!r}") from None
    return Light(az, el)


def _taper(image: np.ndarray, boundary: Boundary) -> np.ndarray:
    """``image`` faded to 0 over :data:`BORDER_TAPER` px at the borders that do not wrap, so
    the Fourier transform sees no jump there."""
    out = np.asarray(image, np.float64).copy()
    for axis, wraps in enumerate(boundary.wrap):
        n = out.shape[axis]
        width = min(BORDER_TAPER, n // 4)
        if wraps or width < 1:
            continue
        ramp = np.ones(n)
        fade = 0.5 - 0.5 * np.cos(np.pi * (np.arange(width) + 0.5) / width)
        ramp[:width], ramp[n - width :] = fade, fade[::-1]
        out *= ramp[:, None] if axis == 0 else ramp[None, :]
    return out


def _shading_spectrum(photo: np.ndarray, boundary: Boundary) -> np.ndarray:
    """Fourier transform of the log-luminance's high-pass (what the shading modulates)."""
    log_lum = np.log(np.maximum(luminance(photo), 1e-3)).astype(np.float32)
    high = log_lum - boundary.blur(log_lum, SHADING_BAND)
    return np.fft.rfft2(_taper(high, boundary))


def _directional_derivative(shape: tuple[int, int], azimuth: float) -> np.ndarray:
    """The Fourier multiplier of ``d/ds``, ``s`` the unit vector at ``azimuth`` (+y up), on
    :func:`numpy.fft.rfft2`'s grid."""
    rows, cols = shape
    wx = np.fft.rfftfreq(cols)[None, :] * 2 * np.pi
    wy = np.fft.fftfreq(rows)[:, None] * 2 * np.pi
    turn = np.radians(azimuth)
    return 1j * (wx * np.cos(turn) - wy * np.sin(turn))  # rows run down, +y up


def _integrated(spectrum: np.ndarray, shape: tuple[int, int], azimuth: float) -> np.ndarray:
    derivative = _directional_derivative(shape, azimuth)
    out = -spectrum * np.conj(derivative) / (np.abs(derivative) ** 2 + INTEGRATION_REGULARISER)
    out[0, 0] = 0.0
    return out


def shape_from_shading(photo: np.ndarray, azimuth: float, *, boundary: Boundary | None = None) -> np.ndarray:
    """The height whose slopes towards a light at ``azimuth`` explain the photo's shading.

    A surface is brighter where it faces the light, i.e. where it falls towards it: for small
    slopes, ``log I = log albedo + c - k dh/ds`` with ``s`` the light's direction in the image
    plane. The log-luminance's high-pass (below :data:`SHADING_BAND` px) is integrated along
    ``s`` by Fourier division by the directional derivative, regularised where that is small
    (the frequencies across the light, which the shading does not see).

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        The photo, float in [0, 1].
    azimuth : float
        The light's azimuth, degrees counter-clockwise from the right, +y up.
    boundary : Boundary, optional
        Where the photo wraps (both axes, or ``(rows, columns)``); borders that do not are
        tapered (default: every border).

    Returns
    -------
    ndarray of float32, shape (h, w)
        Height up to scale (the light's elevation and strength are not known), mean 0.

    References
    ----------
    .. [1] wang2003, §3.4 (the photo's shading, under the matched light).

    Examples
    --------
    >>> import numpy as np
    >>> x = np.arange(64) * 2 * np.pi / 16
    >>> waves = np.tile(0.5 + 0.1 * np.cos(x), (64, 1))  # lit from the right (+x)
    >>> height = shape_from_shading(waves, 0.0, boundary=Boundary(True))  # bright where it falls to the right
    >>> bool(np.corrcoef(height[0], -np.sin(x))[0, 1] > 0.9)
    True
    """
    spectrum = _shading_spectrum(photo, boundary or Boundary())
    shape = np.shape(photo)[:2]
    height = np.fft.irfft2(_integrated(spectrum, shape, azimuth), s=shape)
    return (height - height.mean()).astype(np.float32)


def _reduced(image: np.ndarray) -> np.ndarray:
    rows, cols = image.shape[:2]
    scale = FIT_SIDE / max(rows, cols)
    if scale >= 1:
        return np.asarray(image, np.float32)
    size = (max(1, round(cols * scale)), max(1, round(rows * scale)))
    import cv2  # (here: the CLI's start-up imports this module, and a refusal needs no OpenCV)

    return cv2.resize(np.asarray(image, np.float32), size, interpolation=cv2.INTER_AREA)


def fit_light_azimuth(
    photo: np.ndarray, height: np.ndarray, *, boundary: Boundary | None = None
) -> tuple[float, float]:
    """The light azimuth whose integrated shading (:func:`shape_from_shading`) correlates best
    with ``height`` (the photo's light-independent height cues), and that correlation.

    Computed in the Fourier domain at most :data:`FIT_SIDE` px on a side, one multiply per
    azimuth of :data:`FIT_AZIMUTHS`; round the photo's ``boundary`` (default: no wrap)."""
    boundary = boundary or Boundary()
    small_photo, small_height = _reduced(photo), _reduced(height)
    shape = small_height.shape
    spectrum = _shading_spectrum(small_photo, boundary)
    cue = np.fft.rfft2(_taper(small_height - small_height.mean(), boundary))
    cue[0, 0] = 0.0
    # rfft2 holds each column but the first (and the Nyquist one) for two: weight them twice
    weight = np.full(cue.shape, 2.0)
    weight[:, 0] = 1.0
    if shape[1] % 2 == 0:
        weight[:, -1] = 1.0
    cue_norm = float(np.sqrt((weight * np.abs(cue) ** 2).sum()))
    best_azimuth, best = 0.0, -np.inf
    for azimuth in FIT_AZIMUTHS:
        integrated = _integrated(spectrum, shape, azimuth)
        norm = float(np.sqrt((weight * np.abs(integrated) ** 2).sum())) * cue_norm
        if norm <= 0:
            continue
        agreement = float((weight * np.real(integrated * np.conj(cue))).sum()) / norm
        if agreement > best:
            best_azimuth, best = float(azimuth), agreement
    return best_azimuth, (best if np.isfinite(best) else 0.0)


def with_shading_height(
    photo: np.ndarray, height: np.ndarray, light: Light, *, weight: float, boundary: Boundary | None = None
) -> np.ndarray:
    """``height`` plus the photo's shape from shading under ``light``
    (:func:`shape_from_shading`), its slopes scaled to ``weight`` times the height's.

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        The photo, float in [0, 1].
    height : ndarray, shape (h, w)
        The height from the photo's other cues (:func:`~barkgen.material.estimate_height`).
    light : Light
        The photo's light.
    weight : float
        Slope of the shading's height relative to ``height``'s (0: ``height`` as it is).
    boundary : Boundary, optional
        Where the photo wraps (default: nowhere).

    Returns
    -------
    ndarray of float32, shape (h, w)
        The joint height, mean 0.
    """
    height = np.asarray(height, np.float32)
    if weight <= 0:
        return height
    boundary = boundary or Boundary()
    from_shading = shape_from_shading(photo, light.azimuth, boundary=boundary)
    slope = float(np.std(np.hypot(*boundary.gradient(height))))
    slope_shading = float(np.std(np.hypot(*boundary.gradient(from_shading))))
    if slope <= 0 or slope_shading <= 0:
        return height
    joint = height + (weight * slope / slope_shading) * from_shading
    return (joint - joint.mean()).astype(np.float32)


def shading_confidence(light: Light, *, given: bool) -> float:
    """How much the integrated shading is trusted (0-1): fully for a light the user gave,
    else by how well the shading and the height cues agreed (:data:`AGREEMENT_START` to
    :data:`AGREEMENT_FULL`)."""
    if given:
        return 1.0
    agreement = light.correlation or 0.0
    return float(np.clip((agreement - AGREEMENT_START) / (AGREEMENT_FULL - AGREEMENT_START), 0.0, 1.0))


def estimate_light(
    photo: np.ndarray, normals: np.ndarray, *, height: np.ndarray | None = None, boundary: Boundary | None = None
) -> Light:
    """The photo's light: the direction under which the normals, rendered Lambertian, look most
    like the photo, or, given the height cues, the joint fit of light and shape.

    Without ``height``: the grid direction maximising the correlation of ``N·L`` with the
    luminance (wang2003 §3.4's manual light matching, automated), in closed form per direction
    from the covariances of the luminance with the three normal components. With ``height``:
    the azimuth whose integrated shading agrees best with the height
    (:func:`fit_light_azimuth`), the elevation the Lambertian match's at that azimuth.

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        The photo, float in [0, 1].
    normals : ndarray, shape (h, w, 3)
        Unit normals of its estimated height (OpenGL).
    height : ndarray, shape (h, w), optional
        The height those normals are of, from cues that do not depend on the light
        (:func:`~barkgen.material.estimate_height`): fits the azimuth jointly with the shape.
    boundary : Boundary, optional
        Where the photo wraps (the joint fit's filters wrap there; default: nowhere).

    Returns
    -------
    Light
        The best direction. Its ``correlation``: of ``N·L`` with the luminance, negative when
        no light makes the photo brighter where ``N·L`` is larger, 0 for a flat photo or flat
        normals; with ``height``, the agreement of the integrated shading with it.

    Raises
    ------
    InvalidInputError
        The normal map (or the height) and the photo differ in size.

    References
    ----------
    .. [1] wang2003, §3.4 (texture correction: the light matched by hand there).
    """
    lum = luminance(photo).astype(np.float64).ravel()
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    if n.shape[0] != lum.size or (height is not None and np.size(height) != lum.size):
        raise InvalidInputError("normal map and photo sizes differ")
    azimuths: tuple[float, ...] = tuple(float(a) for a in AZIMUTHS)
    agreement = None
    if height is not None:
        azimuth, agreement = fit_light_azimuth(photo, height, boundary=boundary)
        azimuths = (azimuth,)
    lum = lum - lum.mean()
    n = n - n.mean(axis=0)
    cov_ln = n.T @ lum / lum.size
    cov_nn = n.T @ n / lum.size
    var_l = float(lum @ lum) / lum.size
    best = Light(azimuths[0], 90.0, -np.inf)
    best_corr = -np.inf  # best.correlation, as a float
    for el in ELEVATIONS:
        for az in azimuths:
            v = Light(az, el).vector.astype(np.float64)
            var_s = float(v @ cov_nn @ v)
            if var_s <= 0 or var_l <= 0:
                continue
            corr = float(v @ cov_ln) / float(np.sqrt(var_s * var_l))
            if corr > best_corr:
                best, best_corr = Light(az, el, corr), corr
            if el == 90.0 and agreement is None:
                break  # every azimuth is the same light
    if not np.isfinite(best_corr):  # a flat photo or flat normals: nothing to match
        return Light(azimuths[0] if agreement is not None else 0.0, 90.0, 0.0)
    if agreement is not None:
        return Light(best.azimuth, best.elevation, agreement)
    return best


def shading(normals: np.ndarray, light: Light) -> np.ndarray:
    """Lambertian shading ``N·L`` of unit normals.

    Parameters
    ----------
    normals : ndarray, shape (h, w, 3)
        Unit normals (OpenGL convention).
    light : Light
        The light.

    Returns
    -------
    ndarray of float32, shape (h, w)
        ``N·L`` (negative where the surface faces away).
    """
    return np.tensordot(np.asarray(normals, np.float32), light.vector, axes=([2], [0])).astype(np.float32)


def _divide(linear: np.ndarray, log_shade: np.ndarray, strength: float) -> np.ndarray:
    relative = np.exp(strength * log_shade).astype(np.float32)
    return linear / (relative[..., None] if linear.ndim == 3 else relative)


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    a = a - a.mean()
    denom = float(np.sqrt((a * a).sum() * (b * b).sum()))
    return float((a * b).sum()) / denom if denom > 0 else 0.0


def shading_strength(linear: np.ndarray, log_shade: np.ndarray, n_dot_l: np.ndarray) -> float:
    """How strongly the shading modulates the photo: the exponent ``g`` of the model
    ``I = albedo * shade ** g`` for which the albedo's luminance is uncorrelated with ``N·L``
    (the albedo is independent of the lighting), by bisection in ``[0, MAX_STRENGTH]`` on a
    regular subsample of the pixels. It stands for what the estimated depth and the light's
    unknown intensity against the ambient light leave open (``g = 1`` is wang2003's plain
    division). 0 when the photo is not brighter where ``N·L`` is larger: nothing to remove.
    ``linear``: the photo in linear light; ``log_shade``: log of the floored ``N·L`` minus its
    mean (what is divided); ``n_dot_l``: ``N·L`` itself, not floored (what the albedo must not
    correlate with: the floor only keeps the division finite)."""
    step = max(1, int(np.sqrt(log_shade.size / FIT_PIXELS)))
    sub_linear = linear[::step, ::step]
    sub_log = log_shade[::step, ::step]
    shade = np.asarray(n_dot_l, np.float64)[::step, ::step].ravel()
    shade = shade - shade.mean()

    def corr(g: float) -> float:
        return _correlation(luminance(linear_to_srgb(_divide(sub_linear, sub_log, g))).ravel(), shade)

    if corr(0.0) <= 0.0:
        return 0.0
    if corr(MAX_STRENGTH) >= 0.0:
        return MAX_STRENGTH
    lo, hi = 0.0, MAX_STRENGTH
    for _ in range(STRENGTH_STEPS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if corr(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def remove_shading(
    photo: np.ndarray, normals: np.ndarray, light: Light, *, strength: float | None = None, floor: float = SHADING_FLOOR
) -> tuple[np.ndarray, float]:
    """The photo's albedo: its shading divided out, and the shading strength used.

    The photo is divided, in linear light, by ``max(N·L, floor) ** strength`` relative to its
    geometric mean (wang2003 §3.4's T = I / (N·L), keeping the photo's overall brightness).

    The correlation the fit removes is the one of the albedo's luminance with ``N·L``; on bark
    photos it is the dark cavities the height model put low that get lightened, as AO-based
    delighting does (Materialize, AwesomeBump): the AO map puts them back at render time.

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3)
        The photo, sRGB float in [0, 1].
    normals : ndarray, shape (h, w, 3)
        Unit normals of its height (OpenGL).
    light : Light
        The photo's light (:func:`estimate_light`).
    strength : float, optional
        ``None`` fits it (:func:`shading_strength`); 1 is the paper's division.
    floor : float, default SHADING_FLOOR
        Smallest ``N·L`` divided by, > 0 (keeps the division finite).

    Returns
    -------
    albedo : ndarray of float32, shape (h, w, 3)
        sRGB in [0, 1].
    strength : float
        The exponent used (0: nothing removed).

    Raises
    ------
    InvalidInputError
        A floor that is not > 0.

    References
    ----------
    .. [1] wang2003, §3.4 (texture correction, T = I / (N·L)).
    """
    if floor <= 0:
        raise InvalidInputError("the shading floor must be > 0")
    n_dot_l = shading(normals, light)
    log_shade = np.log(np.maximum(n_dot_l, floor))
    log_shade -= log_shade.mean()
    linear = srgb_to_linear(photo)
    if strength is None:
        strength = shading_strength(linear, log_shade, n_dot_l)
    return linear_to_srgb(_divide(linear, log_shade, strength)), float(strength)
