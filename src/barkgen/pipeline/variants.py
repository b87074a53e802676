"""The bark :func:`~barkgen.pipeline.generate` makes beyond the photo's labels in new shapes:

- ``structure="cracks"``: the photo's crack network is extracted (sibbing2010 §3), its statistics
  fitted (§4.1) and a new network grown at the output size (§4.2-4.5), on the torus when the
  output tiles. Its raster is the output label map (cracks the darkest label, so the material's
  height is low in them) and texture-by-numbers fills it with the photo's bark: the core engine
  in place of the paper's fragment rendering (§5), which the benchmark shows coherent where
  fragments were 3-13x less (docs/benchmarks/pipeline.md).
- ``model="bilayer"``: the photo is split into a structure layer and spatially varying noise
  (guingo2017 §3); the engine synthesizes the structure layer like a photo (tileable, with a
  reference map, so the material set is the structure's, carried through it), the masks come
  through the same reference map, and new noise of the photo's spectra is laid under them on
  the output's torus (eq. 6). The analysis keeps the :class:`~barkgen.bilayer.BilayerModel`,
  whose :meth:`~barkgen.bilayer.BilayerModel.window` streams the model's unbounded texture (by
  its own tile-based synthesis, §4: the same model, not the engine's pixels).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from barkgen._shared.arrays import ProgressCallback, unit_float
from barkgen.errors import InvalidInputError

if TYPE_CHECKING:
    from barkgen.bilayer import BilayerModel
    from barkgen.pipeline.options import GenerateOptions
    from barkgen.shapes import LabelMapResult

#: grey values of the crack label maps: cracks the darkest label (low in the height's cue)
CRACK_VALUE, BARK_VALUE = 0, 255


@dataclass
class Exemplar:
    """What the solvers copy from and what else a variant needs of the photo.

    Attributes
    ----------
    image : ndarray
        The photo, or for a bi-layer texture its structure layer (the photo's dtype).
    labels_in : ndarray or None
        The label map that goes with it (None: the photo's labels, made by the analysis).
    bilayer : BilayerModel or None
        The bi-layer model (``model="bilayer"``).
    cracks : BranchModel or None
        The photo's crack network's statistics (``structure="cracks"``).
    """

    image: np.ndarray
    labels_in: np.ndarray | None
    bilayer: BilayerModel | None = None
    cracks: Any = None


def prepare_exemplar(
    photo: np.ndarray,
    options: GenerateOptions,
    labels_in: np.ndarray | None,
    seed: int = 0,
    progress: ProgressCallback | None = None,
    cracks: Any = None,
) -> Exemplar:
    """The variant's exemplar of the photo (:class:`Exemplar`), made once per photo; ``seed``:
    the photo's analysis' own (the bi-layer clusters'), not a variant's; ``progress``: the
    bi-layer analysis' ``(done, total)``; ``cracks``: the photo's crack network as the user
    edited it (a :class:`~barkgen.branching.Structure` of the photo's size, sibbing2010 §6),
    learned from instead of the one extracted.

    Raises
    ------
    InvalidInputError
        A label map with a bi-layer texture (its labels are its noise clusters), a photo in
        which no crack is found, or a crack network for another variant or another size.
    """
    if cracks is not None:
        _check_cracks(cracks, photo, options)
    if options.model == "bilayer":
        if labels_in is not None:
            raise InvalidInputError("a bi-layer texture's labels are its noise clusters: give no label map")
        return _bilayer_exemplar(photo, options, seed, progress)
    if options.structure == "cracks":
        from barkgen.branching import extract_structure, fit_model, rasterize

        # a user's label map: its darkest label in the photo is the cracks (extract_structure)
        source = cracks if cracks is not None else extract_structure(photo, labels_in)
        return Exemplar(photo, crack_labels(rasterize(source, np.shape(photo)[:2])), cracks=fit_model(source))
    return Exemplar(photo, labels_in)


def _check_cracks(cracks: Any, photo: np.ndarray, options: GenerateOptions) -> None:
    """A given crack network goes with ``structure="cracks"`` and the photo's size."""
    from barkgen.branching import Structure

    if options.structure != "cracks" or options.model == "bilayer":
        raise InvalidInputError("a crack network is learned from with structure='cracks' only")
    if not isinstance(cracks, Structure):
        raise InvalidInputError(f"the crack network must be a barkgen.branching.Structure, got {type(cracks).__name__}")
    h, w = np.shape(photo)[:2]
    if tuple(cracks.size) != (w, h):
        raise InvalidInputError(
            f"the crack network is of a {cracks.width}x{cracks.height} px image but the photo is {w}x{h} px"
        )
    cracks.validate("the crack network")


def _bilayer_exemplar(photo: np.ndarray, options: GenerateOptions, seed: int, progress=None) -> Exemplar:
    """The photo's bi-layer model; its structure layer in the photo's dtype, and its clusters
    as a label map, darkest cluster first (the height's label cue)."""
    from barkgen.bilayer import AnalysisOptions, analyze
    from barkgen.labels.regions import order_by_luminance, to_label_image

    model = analyze(photo, AnalysisOptions(k=options.k, seed=seed, max_memory=options.max_memory), progress=progress)
    structure = from_unit(model.structure, np.asarray(photo).dtype)
    if np.ndim(photo) == 2:
        structure = structure[:, :, 0]
    luma = model.structure @ np.array([0.2126, 0.7152, 0.0722], np.float32)  # Rec. 709
    codes = order_by_luminance(model.labels.astype(np.int32), luma, model.k)
    return Exemplar(structure, to_label_image(codes, model.k), bilayer=model)


def from_unit(image: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """A float image in [0, 1] in ``dtype`` (integers rounded, clipped)."""
    dtype = np.dtype(dtype)
    if dtype.kind == "f":
        return np.clip(image, 0.0, 1.0).astype(dtype)
    top = float(np.iinfo(dtype).max)
    return (np.clip(image, 0.0, 1.0) * top + 0.5).astype(dtype)


def crack_labels(mask: np.ndarray) -> np.ndarray:
    """A crack mask as a two-label map: cracks :data:`CRACK_VALUE`, bark :data:`BARK_VALUE`."""
    return np.where(mask, CRACK_VALUE, BARK_VALUE).astype(np.uint8)


def crack_label_map(
    cracks: Any, options: GenerateOptions, progress: ProgressCallback | None = None
) -> tuple[LabelMapResult, Any]:
    """A new crack network grown from the photo's statistics at ``options.size`` (on the torus
    with ``options.tile``; sibbing2010 §4), and its raster as the output label map.

    Returns
    -------
    (LabelMapResult, Structure)
        The label map (cracks :data:`CRACK_VALUE`) and the grown network.
    """
    from barkgen.branching import GrowOptions, grow_structure, rasterize
    from barkgen.shapes import LabelMapResult

    h, w = options.size
    grown = grow_structure(
        cracks,
        (w, h),
        seed=options.seed,
        options=GrowOptions(max_memory=options.max_memory),
        progress=progress,
        tile=options.tile,
    )
    labels = crack_labels(rasterize(grown))
    return LabelMapResult(label_map=labels, levels=[labels], strategy="cracks"), grown


def bilayer_layers(model: BilayerModel, references: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The masks and the noise of a bi-layer output (guingo2017 eq. 6) whose structure layer
    the engine synthesized with ``references`` into the model's: the masks read through the
    references (exactly), and new noise under them on the output's torus (so it tiles when the
    structure does), its white noise from ``seed``.

    Returns
    -------
    (noise, masks)
        ``sum_k M'_k N_k`` ``(H, W, 3)`` and ``M'_k`` ``(H, W, K)``, float32.
    """
    masks = model.masks[references[..., 0], references[..., 1]]
    noise = model.noise_on_torus(masks, np.random.default_rng([int(seed), 0xB1]))
    return noise, masks


def add_noise(structure: np.ndarray, noise: np.ndarray) -> np.ndarray:
    """The synthesized structure layer (any dtype) plus the noise layer, in the structure's
    dtype and channels."""
    base = unit_float(np.asarray(structure))
    grey = base.ndim == 2
    if grey:
        base = base[:, :, None]
    total = base + (noise.mean(axis=2, keepdims=True) if base.shape[2] == 1 else noise[:, :, : base.shape[2]])
    out = from_unit(total, np.asarray(structure).dtype)
    return out[:, :, 0] if grey else out
