"""Options of the bi-layer model (guingo2017): of its analysis (§3.3, §5, §6) and of its
synthesis (§4), validated once when made; and the exemplar check both share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from barkgen._shared.memory import BASE_BYTES, check_budget_value, parse_memory
from barkgen._shared.options import check_options, option
from barkgen.bilayer.spectra import SPECTRUM_SIZE, check_tloc
from barkgen.bilayer.tiles import Deformation
from barkgen.errors import InvalidInputError

#: smallest exemplar side the analysis accepts (the global spectra need 16 px windows)
MIN_SIDE = 32
MASK_KINDS = ("binary", "barycentric")


@dataclass(frozen=True)
class AnalysisOptions:
    """Parameters of the analysis (guingo2017 §5: only ``k`` and ``tloc`` are the user's).

    Parameters
    ----------
    k : int, default 2
        Number of stationary noises (clusters of local spectra), 1-8.
    tloc : {2, 4, 8, 16}, default 4
        Local spectrum window (``barkgen bilayer tune`` shows them).
    masks : {"binary", "barycentric"}, default "binary"
        ``"binary"``: a pixel belongs to its nearest cluster (sharp noise transitions, the
        paper's choice for its results); ``"barycentric"``: the convex barycentre of the cluster
        centres that keeps the pixel's relative distances to them (§3.3; smooth transitions).
    spectrum_size : int, default SPECTRUM_SIZE
        Size T of the global spectra (64 in the paper).
    equalize : bool, default False
        Store per-cluster, per-channel noise quantiles and equalise the synthesized noise's
        histogram to them (§6, for non-Gaussian noise).
    border : int, default 0
        Width in px of the band along mask borders where ``N`` is forced to 0, so sharp borders
        stay in ``P`` (§6, Fig. 16); 0 disables it.
    iterations, radius : int, default 5, 8
        The joint bilateral filter (§5: 5 iterations, 16 px neighbourhoods).
    sigma_range : float, default 0.001
        The filter's range sigma, in the units of :func:`~barkgen.bilayer.local_spectra` (a
        spectrum's norm is the local RMS of the luminance in [0, 1]); the paper's 0.01 is in
        units it does not give. 0.001 keeps bark's cracks, fissures and the sharp edges of its
        plates in ``P`` and leaves the fine grain to ``N`` (at 0.002 the filter softens the
        edges and their remainder goes into ``N``, where fresh noise cannot line up with them
        again: fir's finest band loses 12 % of its energy); raise it to move more into the noise.
    core : float, default 0.9
        Fraction of each cluster, closest to its centre, used to estimate its spectrum (§3.3:
        90 %).
    seed : int, default 0
        Seed of the K-means initialisation.
    max_memory : int, optional
        Refuse a photo whose analysis is estimated (:func:`estimate_analysis_memory`) to need
        more than this many bytes, before any work (None: what the machine has free).

    Raises
    ------
    InvalidInputError
        Any value out of range.

    References
    ----------
    .. [1] guingo2017, §3.3, §5, §6.
    """

    k: int = option(2, "Number of stationary noises (clusters), 1-8.", kind=int, minimum=1, maximum=8)
    tloc: int = option(
        4,
        "Local spectrum window: 2, 4, 8 or 16 px (larger: more goes into the noise; see `barkgen bilayer tune`).",
        kind=int,
        minimum=2,
        maximum=16,
    )
    masks: str = option("binary", "binary or barycentric.", choices=MASK_KINDS)
    spectrum_size: int = option(
        SPECTRUM_SIZE, "Size T of the global spectra (64 in the paper), even.", kind=int, minimum=16, fronts=()
    )
    equalize: bool = option(False, "Equalise the noise's histogram per cluster (non-Gaussian noise, §6).", kind=bool)
    border: int = option(
        0, "Band (px) along mask borders kept sharp in the structure (§6); 0: none.", kind=int, minimum=0
    )
    iterations: int = option(5, "Iterations of the joint bilateral filter (§5).", kind=int, minimum=0, fronts=())
    radius: int = option(8, "Radius of the joint bilateral filter (§5), px.", kind=int, minimum=1, fronts=())
    sigma_range: float = option(
        0.001,
        "Range sigma of the structure filter (larger: more of the grain goes into the noise).",
        kind=float,
        flag="--sigma",
        minimum=0,
        maximum=1,
    )
    core: float = option(
        0.9,
        "Fraction of each cluster, nearest its centre, that estimates its spectrum (§3.3).",
        kind=float,
        minimum=0,
        maximum=1,
        fronts=(),
    )
    seed: int = option(0, "Random seed (same seed, same bytes).", kind=int, minimum=0)
    max_memory: int | None = option(
        None,
        "Refuse jobs estimated to need more memory than this, e.g. 8G (default: what the machine has free).",
        parse=parse_memory,
    )

    def __post_init__(self) -> None:
        check_tloc(self.tloc)
        if not (isinstance(self.k, (int, np.integer)) and 1 <= self.k <= 8):
            raise InvalidInputError(f"K (number of noises) must be between 1 and 8, not {self.k}")
        if self.masks not in MASK_KINDS:
            raise InvalidInputError(f"masks must be one of {', '.join(MASK_KINDS)}, not {self.masks!r}")
        if self.spectrum_size < 16 or self.spectrum_size % 2:
            raise InvalidInputError(f"spectrum size must be even and at least 16, not {self.spectrum_size}")
        if self.border < 0 or self.iterations < 0 or self.radius < 1 or not (0 < self.sigma_range <= 1):
            raise InvalidInputError("border and iterations must be >= 0, radius >= 1, the range sigma in (0, 1]")
        if not (0 < self.core <= 1):
            raise InvalidInputError(f"core must be in (0, 1], not {self.core}")
        if self.seed < 0:
            raise InvalidInputError(f"seed must be >= 0, not {self.seed}")
        check_budget_value(self.max_memory)
        check_options(self)


@dataclass(frozen=True)
class SynthesisOptions:
    """How the structure is tiled (guingo2017 §4).

    Parameters
    ----------
    tile_size : int, optional
        Wang tile side in px, even and >= 8 (default: about a quarter of the exemplar's side).
    colours : int, default 3
        Edge colours per direction (``colours**4`` tiles), 1-4.
    variants : int, default 4
        Exchanged contents per tile, 1-16.
    deformation : Deformation, default Deformation()
        Rotations and zooms of the structure's samples.
    warp : float, default 0.1
        Turbulence of the structure (Fig. 10): a smooth random displacement of up to ``warp``
        tile sizes that bends the straight seams of the tile grid (0: none). It also bends each
        tile's content, so that no large piece of the output is a pixel-exact copy of the
        exemplar (texeval's largest copy on four barks, default tile size: 0.038-0.043 of the
        exemplar at 0.1, 0.050-0.056 at 0).
    compensate : bool, default True
        With a deformation, give the noise the power the deformed structure lost (see
        :func:`compensated_noise`), so fine detail keeps the photo's scale; ``False`` is the
        paper's synthesis, the noise exactly as analysed.
    blend : bool, default True
        Blend the structure's seams inside each tile in the gradient domain (sibbing2010 §5), so
        a graph cut across a furrow leaves no step; ``False`` keeps the graph cuts alone.
    max_memory : int, optional
        Refuse a window whose synthesis is estimated (:func:`estimate_window_memory`) to need
        more than this many bytes, before any work (None: what the machine has free).

    Raises
    ------
    InvalidInputError
        Any value out of range.

    References
    ----------
    .. [1] guingo2017, §4 (synthesis and deformation).
    .. [2] cohen2003 (Wang tiles); vanhoey2013 (content exchange).
    .. [3] sibbing2010, §5 (seams blended in the gradient domain, after perez2003).
    """

    tile_size: int | None = option(
        None, "Wang tile size in px (default: a quarter of the exemplar).", kind=int, minimum=8
    )
    colours: int = option(
        3, "Edge colours per direction (colours**4 tiles), 1-4.", kind=int, minimum=1, maximum=4, fronts=()
    )
    variants: int = option(4, "Exchanged contents per tile, 1-16.", kind=int, minimum=1, maximum=16, fronts=())
    deformation: Deformation = option(Deformation(), "Rotations and zooms of the structure's samples.", fronts=())
    warp: float = option(
        0.1, "Turbulence bending the tile grid, in tile sizes (0-1; 0: none).", kind=float, minimum=0, maximum=1
    )
    compensate: bool = option(
        True,
        "With --rotate or --scale, give the noise the fine detail the deformed "
        "structure lost (--no-compensate: the paper's noise).",
        kind=bool,
        flag="--compensate/--no-compensate",
    )
    blend: bool = option(
        True,
        "Blend the tiles' seams in the gradient domain (--no-blend: graph cuts only).",
        kind=bool,
        flag="--blend/--no-blend",
    )
    max_memory: int | None = option(
        None,
        "Refuse jobs estimated to need more memory than this, e.g. 8G (default: what the machine has free).",
        parse=parse_memory,
    )

    def __post_init__(self) -> None:
        if self.tile_size is not None and (self.tile_size < 8 or self.tile_size % 2):
            raise InvalidInputError(f"tile size must be even and at least 8, not {self.tile_size}")
        if not (1 <= self.colours <= 4) or not (1 <= self.variants <= 16):
            raise InvalidInputError("colours must be 1-4 and variants 1-16")
        if not (0 <= self.warp <= 1):
            raise InvalidInputError(f"warp must be between 0 and 1 tile size, not {self.warp}")
        check_budget_value(self.max_memory)
        check_options(self)


#: bytes per photo pixel of the analysis: local spectra (T_loc² values a pixel), the joint
#: bilateral filter's stacks, K-means (measured peaks: 0.85 GiB for a 1024x1024 photo, 2.4 GiB
#: for 2048x2048, 520 bytes a pixel over the interpreter's base)
ANALYSIS_BYTES_PER_PIXEL = 600
#: bytes per exemplar pixel of a window's synthesizer (its tiles and their seams; measured
#: when the tile set was still built from 8 deformed copies: 1.0 GiB for a 1024x1024 model's
#: windows of 1024x1024 and 2048x2048 alike, 3.8 GiB for a 2048x2048 model's 2048x2048
#: window: 950 bytes a pixel, an upper bound since deformations moved into the window), and
#: per window pixel (the texture and, with ``layers``, its layers)
WINDOW_MODEL_BYTES_PER_PIXEL = 1000
WINDOW_BYTES_PER_PIXEL = 64


def estimate_analysis_memory(photo_shape: tuple[int, int]) -> int:
    """Estimated peak memory (bytes) of :func:`~barkgen.bilayer.analyze` for a ``(h, w)`` photo."""
    return BASE_BYTES + ANALYSIS_BYTES_PER_PIXEL * photo_shape[0] * photo_shape[1]


def estimate_window_memory(exemplar_shape: tuple[int, int], window_shape: tuple[int, int], variants: int = 4) -> int:
    """Estimated peak memory (bytes) of one :meth:`~barkgen.bilayer.BilayerModel.window` of
    ``(height, width)`` from a model of a ``(h, w)`` exemplar with ``variants`` contents per tile."""
    n_ex = exemplar_shape[0] * exemplar_shape[1]
    return int(
        BASE_BYTES
        + WINDOW_MODEL_BYTES_PER_PIXEL * n_ex * max(variants, 4) / 4
        + WINDOW_BYTES_PER_PIXEL * window_shape[0] * window_shape[1]
    )


def as_rgb(image: np.ndarray) -> np.ndarray:
    """An ``(H, W)`` or ``(H, W, C)`` image (uint8, uint16 or float in [0, 1]) as float32 RGB."""
    from barkgen._shared.checks import check_image

    return check_image(image, min_side=MIN_SIDE, what="exemplar", purpose="the bi-layer analysis needs")
