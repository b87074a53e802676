"""The public face of example-based synthesis: :func:`synthesize`, :func:`apply_references`, and
the checks made before any work starts (inputs, memory budget).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from barkgen._shared.arrays import ProgressCallback, as_hw_c
from barkgen._shared.checks import parse_output_shape
from barkgen._shared.memory import check_memory_budget
from barkgen.errors import InvalidInputError
from barkgen.pyramid import count_levels
from barkgen.synth.analysis import matching_features
from barkgen.synth.config import SynthesisConfig
from barkgen.synth.edges import resolve_exemplar_wrap
from barkgen.synth.solver import SynthesisResult, solve

#: smallest exemplar side accepted
MIN_EXEMPLAR_SIDE = 16


def validate_inputs(exemplar: np.ndarray, size: int | tuple[int, int], seed: int,
                    extra: Mapping[str, np.ndarray] | None) -> tuple[np.ndarray, tuple[int, int], dict]:
    """Check the exemplar, output size, seed and extra maps; return them normalised."""
    ex = as_hw_c("exemplar", exemplar)
    if ex.shape[2] not in (1, 3):
        raise InvalidInputError(f"exemplar must have 1 or 3 channels, not {ex.shape[2]}")
    if min(ex.shape[:2]) < MIN_EXEMPLAR_SIDE:
        raise InvalidInputError(
            f"exemplar is {ex.shape[1]}x{ex.shape[0]} px; it must be at least "
            f"{MIN_EXEMPLAR_SIDE} px on each side")
    out_shape = parse_output_shape(size)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise InvalidInputError(f"seed must be a non-negative integer, not {seed!r}")
    extras = {}
    for name, arr in (extra or {}).items():
        e = as_hw_c(f"extra map {name!r}", arr)
        if e.shape[:2] != ex.shape[:2]:
            raise InvalidInputError(
                f"extra map {name!r} is {e.shape[1]}x{e.shape[0]} px but the exemplar is "
                f"{ex.shape[1]}x{ex.shape[0]} px; they must match")
        extras[name] = e
    return ex, out_shape, extras


def check_memory(ex: np.ndarray, extras: Mapping[str, np.ndarray], out_shape: tuple[int, int],
                 feature_channels: int, config: SynthesisConfig, guided: bool = False) -> None:
    """Raise :class:`MemoryBudgetError` before any work if the job would not fit the budget."""
    need = estimate_memory(ex.shape[:2], out_shape,
                           ex.shape[2] + sum(e.shape[2] for e in extras.values()),
                           max([ex.dtype.itemsize] + [e.dtype.itemsize for e in extras.values()]),
                           feature_channels, config)
    if guided:  # label pyramids and tables
        need += 24 * out_shape[0] * out_shape[1] + 24 * ex.shape[0] * ex.shape[1]
    check_memory_budget(need, config.max_memory, f"output {out_shape[1]}x{out_shape[0]}")


def estimate_memory(exemplar_shape: tuple[int, int], output_shape: tuple[int, int],
                    channels: int, bytes_per_channel: int, feature_channels: int,
                    config: SynthesisConfig) -> int:
    """Estimated peak memory of a synthesis, in bytes (made before any work starts)."""
    n_ex = exemplar_shape[0] * exemplar_shape[1]
    n_out = output_shape[0] * output_shape[1]
    sizes = {s for sched in (config.schedule_coarsest, config.schedule_middle,
                             config.schedule_finest) for s, _ in sched}
    per_ex = (feature_channels * 4 * 3 + config.pca_components * 4 * len(sizes) * 1.4
              + config.k * 4 * 1.4 + 8)
    per_out = 100 + 3 * channels * bytes_per_channel
    if config.blend == "gradient":  # one channel's screened Poisson solve at a time (float64)
        per_out += 80
    search = min(n_ex, 262_144) * max(4 * config.k + 8, 32) * 12
    return int(200e6 + n_ex * per_ex + n_out * per_out + search)


def synthesize(
    exemplar: np.ndarray,
    size: int | tuple[int, int],
    *,
    tile: bool = False,
    seed: int = 0,
    extra: Mapping[str, np.ndarray] | None = None,
    config: SynthesisConfig | None = None,
    progress: ProgressCallback | None = None,
    exemplar_wrap: str | bool | tuple[bool, bool] = "auto",
) -> SynthesisResult:
    """Synthesize a new texture of ``size`` = ``(height, width)`` from ``exemplar``.

    The k-coherence discrete solver (Han et al. 2006) as mazzolini2012 §4.1 and laitoch2018
    §3.3 describe it, coarse to fine, in appearance space, with an occurrence cost, copy-size
    control and seam optimisation (see :mod:`barkgen.synth.solver`). The output is an image of
    references into the exemplar, so it is exactly as sharp as the exemplar.

    Parameters
    ----------
    exemplar : ndarray
        ``(h, w)`` or ``(h, w, C)`` array (uint8, uint16 or float), C = 1 or 3.
    size : int or tuple of int
        Output ``(height, width)`` (numpy order), or an int for a square.
    tile : bool, optional
        Make the output wrap seamlessly in x and y (toroidal neighbourhoods).
    seed : int, optional
        Seeds the one ``numpy.random.Generator`` behind every random choice.
    extra : mapping of str to ndarray, optional
        Named maps aligned with the exemplar (height, normal, ...); they take part in the
        matching (weight ``config.extra_weight``) and are returned resolved.
    config : SynthesisConfig, optional
        Solver parameters (:class:`SynthesisConfig`); the defaults when None.
    progress : callable, optional
        ``progress(done, total)``, called after each unit of work.
    exemplar_wrap : {"auto", "yes", "no"} or tuple of bool, optional
        ``"auto"``: the exemplar is used as a torus along each axis along which it tiles itself
        (:func:`barkgen.synth.edges.exemplar_wraps`); ``"yes"``, ``"no"``, or a
        ``(rows, columns)`` pair of bools.

    Returns
    -------
    SynthesisResult
        The image (same dtype and channels as the exemplar), the ``(H, W, 2)`` references and
        the extra maps, resolved in the gradient domain.

    Raises
    ------
    InvalidInputError
        Bad shapes, sizes or parameters.
    MemoryBudgetError
        The estimated memory exceeds ``config.max_memory``.

    References
    ----------
    .. [1] mazzolini2012, §4.1 (the discrete solver of han2006).
    .. [2] laitoch2018, §3.3 (image of references, extra channels, exact up-sampling).
    .. [3] lefebvre2006 (appearance space); kaspar2015 §5 (occurrence map); kwatra2003 (seams).

    Examples
    --------
    >>> import numpy as np
    >>> import barkgen
    >>> exemplar = np.random.default_rng(0).integers(0, 256, (64, 64, 3), dtype=np.uint8)
    >>> result = barkgen.synthesize(exemplar, (96, 128), tile=True, seed=1)
    >>> result.image.shape, result.references.shape
    ((96, 128, 3), (96, 128, 2))
    """
    config = config or SynthesisConfig()
    ex, out_shape, extras = validate_inputs(exemplar, size, seed, extra)
    n_feat = (3 if ex.shape[2] == 3 else 1) + sum(e.shape[2] for e in extras.values())
    check_memory(ex, extras, out_shape, n_feat, config)
    wrap = resolve_exemplar_wrap(exemplar_wrap, ex)
    feats = matching_features(ex, extras, config.extra_weight)
    n_levels = count_levels(ex.shape[:2], out_shape, config.coarsest_exemplar)
    result = solve(ex, extras, feats, out_shape, n_levels=n_levels, config=config, seed=seed,
                   tile=tile, progress=progress, exemplar_wrap=wrap,
                   seam_channels=3 if ex.shape[2] == 3 else 1)
    if np.asarray(exemplar).ndim == 2:
        result.image = result.image[:, :, 0]
    return result


def apply_references(references: np.ndarray, image: np.ndarray) -> np.ndarray:
    """Resolve a reference map against any map of the exemplar's size.

    ``out[y, x] = image[references[y, x, 0], references[y, x, 1]]``: the exact copy of any
    aligned map (height, normals, labels) through a synthesis's references.

    Parameters
    ----------
    references : ndarray
        ``(H, W, 2)`` exemplar ``(row, column)`` per output pixel (``SynthesisResult.references``).
    image : ndarray
        ``(h, w)`` or ``(h, w, C)`` map of the exemplar's size.

    Returns
    -------
    ndarray
        ``(H, W)`` or ``(H, W, C)``, the dtype of ``image``.

    Raises
    ------
    InvalidInputError
        Wrong shapes, or references that point outside ``image``.

    References
    ----------
    .. [1] laitoch2018, §3.3.1 (the image of references).

    Examples
    --------
    >>> import numpy as np
    >>> from barkgen import apply_references
    >>> refs = np.zeros((2, 3, 2), np.int32)
    >>> apply_references(refs, np.arange(4).reshape(2, 2)).tolist()
    [[0, 0, 0], [0, 0, 0]]
    """
    refs = np.asarray(references)
    img = np.asarray(image)
    if refs.ndim != 3 or refs.shape[2] != 2:
        raise InvalidInputError(f"references must have shape (H, W, 2), not {refs.shape}")
    if img.ndim not in (2, 3):
        raise InvalidInputError(f"image must be (H, W) or (H, W, C), not {img.shape}")
    if refs.size and (refs.min() < 0 or refs[:, :, 0].max() >= img.shape[0]
                      or refs[:, :, 1].max() >= img.shape[1]):
        raise InvalidInputError(
            f"the reference map points outside a {img.shape[1]}x{img.shape[0]} image; "
            "apply it to a map of the exemplar's size")
    return img[refs[:, :, 0], refs[:, :, 1]]
