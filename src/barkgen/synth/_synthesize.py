"""Example-based synthesis from an exemplar: :func:`synthesize` (the k-coherence discrete
solver, mazzolini2012 §4.1, through the set-up of :mod:`barkgen.synth._setup`) and
:func:`apply_references` (laitoch2018 §3.3.1: any map of the exemplar through a reference map).
Re-exported by :mod:`barkgen.synth`.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from barkgen._shared.arrays import ProgressCallback
from barkgen._shared.canvas import Budget, Canvas
from barkgen._shared.checks import parse_output_shape
from barkgen.errors import InvalidInputError
from barkgen.synth._config import SynthesisConfig
from barkgen.synth._setup import set_up
from barkgen.synth._solver import SynthesisResult


def synthesize(
    exemplar: np.ndarray,
    size: int | tuple[int, int] | None = None,
    *,
    tile: bool = False,
    seed: int = 0,
    extra: Mapping[str, np.ndarray] | None = None,
    config: SynthesisConfig | None = None,
    progress: ProgressCallback | None = None,
    exemplar_wrap: str | bool | tuple[bool, bool] = "auto",
    canvas: Canvas | None = None,
    budget: Budget | None = None,
) -> SynthesisResult:
    """Synthesize a new texture of ``size`` = ``(height, width)`` from ``exemplar``.

    The k-coherence discrete solver (Han et al. 2006) as mazzolini2012 §4.1 and laitoch2018
    §3.3 describe it, coarse to fine, in appearance space, with an occurrence cost, copy-size
    control and seam optimisation (see :mod:`barkgen.synth._solver`). The output is an image of
    references into the exemplar, so it is exactly as sharp as the exemplar.

    Parameters
    ----------
    exemplar : ndarray
        ``(h, w)`` or ``(h, w, C)`` array (uint8, uint16 or float), C = 1 or 3.
    size : int or tuple of int
        Output ``(height, width)`` (numpy order), or an int for a square (or ``canvas``).
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
        (:func:`barkgen.synth.exemplar_wraps`); ``"yes"``, ``"no"``, or a
        ``(rows, columns)`` pair of bools.
    canvas : Canvas, optional
        The output as one object (:class:`barkgen.Canvas`), in place of ``size``, ``tile`` and
        ``exemplar_wrap``; it also carries the fields the texture follows: ``flow``, an
        ``(H, W)`` orientation field (at each output pixel, the angle in degrees,
        counter-clockwise as seen on screen, by which the exemplar is turned: 0 = as it is; an
        upright fissure then runs at 90° + angle; the matching, the k-coherence shifts and the
        up-sampling happen in that local frame, :mod:`barkgen.synth._flow`: the solver runs on
        an atlas of turned copies, as texture-by-numbers with one label per copy, with this
        function's config; a normal map among ``extra``, a name holding ``normal``, has its
        tangent components turned), ``flow_scale``, an ``(H, W)`` scale field (1 = the
        exemplar's scale; 2 = features twice as large, between 0.25 and 4), ``links``, output
        pixels that take the references of others while the solver runs (a texture atlas's
        gutters, so that texels on either side of a chart border are matched across it on the
        surface: :class:`barkgen.synth.OutputLinks`), and ``oriented``, the atlas of turned
        copies to use (one another synthesis shares: :func:`barkgen.synth.orient_exemplar`).
    budget : Budget, optional
        The run's seed, progress callback and analysis cache as one object
        (:class:`barkgen.Budget`), in place of ``seed`` and ``progress``.

    Returns
    -------
    SynthesisResult
        The image (same dtype and channels as the exemplar), the ``(H, W, 2)`` references and
        the extra maps, resolved in the gradient domain. Along a flow field the references
        point into the atlas of turned copies, ``result.orientation``
        (:meth:`~barkgen.synth.OrientedExemplar.atlas` turns any map of the exemplar into it).

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
    >>> canvas = barkgen.Canvas((96, 128), tile=True, flow=np.full((96, 128), 30.0))
    >>> barkgen.synthesize(exemplar, canvas=canvas, budget=barkgen.Budget(seed=1)).image.shape
    (96, 128, 3)
    """
    canvas = canvas or Canvas(parse_output_shape(size), tile=tile, exemplar_wrap=exemplar_wrap)  # type: ignore[arg-type]  # None: refused
    budget = budget or Budget(seed=seed, progress=progress)
    config = config or SynthesisConfig()
    if canvas.along:
        from barkgen.synth._tbn import along_flow

        return along_flow(exemplar, None, extra, canvas, budget, config=config)
    return set_up(exemplar, extra, config, canvas, budget).solve()


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
    if refs.size and (refs.min() < 0 or refs[:, :, 0].max() >= img.shape[0] or refs[:, :, 1].max() >= img.shape[1]):
        raise InvalidInputError(
            f"the reference map points outside a {img.shape[1]}x{img.shape[0]} image; "
            "apply it to a map of the exemplar's size"
        )
    return img[refs[:, :, 0], refs[:, :, 1]]
