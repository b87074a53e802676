"""Light direction of a photo and shading removal, T = I / (N·L) (wang2003 §3.4).

Wang et al. have the user move a light until the rendered height field is lit like the photo.
barkgen automates that match: the light is the direction (azimuth x elevation grid) whose
Lambertian rendering ``N·L`` of the estimated normals correlates best with the photo's
luminance. The correlation is only a few tenths at best on bark photos (most bark textures
are photographed in diffuse light or delit), so the division is floored (:data:`SHADING_FLOOR`)
and the estimate is reported with its correlation; ``--light AZ,EL`` overrides it.

Angles: azimuth in degrees counter-clockwise from the image's +x (right) axis, +y up;
elevation in degrees above the surface (90 = from the viewer).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from barkgen.color import linear_to_srgb, srgb_to_linear
from barkgen.errors import InvalidInputError
from barkgen.material.height import luminance

#: the light directions tried by :func:`estimate_light` (degrees)
AZIMUTHS = tuple(range(0, 360, 15))
ELEVATIONS = (20.0, 30.0, 45.0, 60.0, 75.0, 90.0)
#: floor of N·L in the division, so grazing or back-facing pixels do not explode
SHADING_FLOOR = 0.2
#: the largest shading strength (exponent of N·L) fitted by :func:`shading_strength`, and the
#: bisection steps of the fit
MAX_STRENGTH = 8.0
STRENGTH_STEPS = 16
#: pixels sampled to fit the shading strength
FIT_PIXELS = 262_144


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


def estimate_light(photo: np.ndarray, normals: np.ndarray) -> Light:
    """The light under which the normals, rendered Lambertian, look most like the photo.

    The grid direction maximising the correlation of ``N·L`` with the luminance (wang2003 §3.4's
    manual light matching, automated), in closed form per direction from the covariances of the
    luminance with the three normal components.

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        The photo, float in [0, 1].
    normals : ndarray, shape (h, w, 3)
        Unit normals of its estimated height (OpenGL).

    Returns
    -------
    Light
        The best direction; its ``correlation`` is negative when no light makes the photo
        brighter where ``N·L`` is larger, 0 for a flat photo or flat normals.

    Raises
    ------
    InvalidInputError
        The normal map and the photo differ in size.

    References
    ----------
    .. [1] wang2003, §3.4 (texture correction: the light matched by hand there).
    """
    lum = luminance(photo).astype(np.float64).ravel()
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    if n.shape[0] != lum.size:
        raise InvalidInputError("normal map and photo sizes differ")
    lum = lum - lum.mean()
    n = n - n.mean(axis=0)
    cov_ln = n.T @ lum / lum.size
    cov_nn = n.T @ n / lum.size
    var_l = float(lum @ lum) / lum.size
    best = Light(0.0, 90.0, -np.inf)
    best_corr = -np.inf  # best.correlation, as a float
    for el in ELEVATIONS:
        for az in AZIMUTHS:
            v = Light(float(az), el).vector.astype(np.float64)
            var_s = float(v @ cov_nn @ v)
            if var_s <= 0 or var_l <= 0:
                continue
            corr = float(v @ cov_ln) / float(np.sqrt(var_s * var_l))
            if corr > best_corr:
                best, best_corr = Light(float(az), el, corr), corr
            if el == 90.0:
                break  # every azimuth is the same light
    if not np.isfinite(best_corr):  # a flat photo or flat normals: nothing to match
        return Light(0.0, 90.0, 0.0)
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
