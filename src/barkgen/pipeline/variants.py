"""The bark :func:`~barkgen.pipeline.generate` makes beyond the photo's labels in new shapes:

- ``structure="cracks"``: the photo's crack network is extracted (sibbing2010 §3), its statistics
  fitted (§4.1) and a new network grown at the output size (§4.2-4.5), on the torus when the
  output tiles. Its raster is the output label map (cracks the darkest label, so the material's
  height is low in them) and texture-by-numbers fills it with the photo's bark: the core engine
  in place of the paper's fragment rendering (§5), which the benchmark shows coherent where
  fragments were 3-13x less (docs/benchmarks/variants.md).
- ``model="bilayer"``: the photo is split into a structure layer and spatially varying noise
  (guingo2017 §3); the engine synthesizes the structure layer like a photo (tileable, with a
  reference map, so the material set is the structure's, carried through it), the masks come
  through the same reference map, and new noise of the photo's spectra is laid under them on
  the output's torus (eq. 6). The analysis keeps the :class:`~barkgen.bilayer.BilayerModel`,
  whose :meth:`~barkgen.bilayer.BilayerModel.window` streams the model's unbounded texture (by
  its own tile-based synthesis, §4: the same model, not the engine's pixels).

Each variant is one object, chosen once per run (:func:`variants`): the structure,
:class:`PhotoLabels` or :class:`Cracks` (its exemplar, its solver analysis, its output label
map, its report), and the model, :class:`Patches` or :class:`Bilayer` (its exemplar, how the
run's texture is finished). :class:`Run` is what every stage of
:func:`~barkgen.pipeline.generate` reads: the options, the Canvas, the Budget and the two
variants.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from barkgen._shared.arrays import ProgressCallback, unit_float

if TYPE_CHECKING:
    from barkgen._shared.canvas import Budget, Canvas
    from barkgen.bilayer import AnalysisOptions, BilayerModel
    from barkgen.branching import GrowOptions
    from barkgen.pipeline.options import GenerateOptions
    from barkgen.shapes import LabelMapResult

#: seed of the photo's own analysis (the k-means of its label map, the bi-layer clusters): the
#: photo's labels belong to the photo, not to a variant, so every seed's output of one photo
#: shares one analysis
ANALYSIS_SEED = 0

#: the pyramid level texture-by-numbers takes up each strategy's label-map references at
#: (measured on the ten bark photos: joint at level 0/1/2 gave oak coherence 1.21/1.28/1.35x
#: plain synthesis; the label-only engine's references need two levels to fit in colour); the
#: strategies whose exemplar analysis the photo's analysis makes
INIT_LEVELS = {"joint": 0, "engine": 2}

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


@dataclass(frozen=True)
class Run:
    """One :func:`~barkgen.pipeline.generate` run as its stages see it: the options, the
    :class:`~barkgen.Canvas` and :class:`~barkgen.Budget` built once at its top (the budget's
    ``progress`` is the whole run's), and its two variants, chosen once (:func:`variants`)."""

    options: GenerateOptions
    canvas: Canvas
    budget: Budget
    structure: PhotoLabels | Cracks
    model: Patches | Bilayer

    def resolved(self, photo: np.ndarray) -> Run:
        """The run with the photo's wrap resolved from the options' mode
        (:func:`barkgen.synth.resolve_exemplar_wrap`): every stage reads the same axes."""
        from barkgen.synth import resolve_exemplar_wrap

        wrap = resolve_exemplar_wrap(self.options.exemplar_wrap, photo)
        return dataclasses.replace(self, canvas=self.canvas.replace(exemplar_wrap=wrap))

    def progress(self, stage: str) -> ProgressCallback | None:
        """The progress callback of ``stage``'s share of the run."""
        from barkgen.pipeline.progress import stage_progress

        return stage_progress(self.budget.progress, stage, self.options.material)

    def stage_budget(self, stage: str, cache: Any = None) -> Budget:
        """The budget a stage hands its solver: the run's seed, the stage's progress and the
        photo analysis' ``cache``."""
        return self.budget.replace(progress=self.progress(stage), cache=cache)


class PhotoLabels:
    """``structure="labels"``: the photo's label map, and an output label map synthesized from
    it by ``options.strategy`` (:func:`barkgen.shapes.synthesize_label_map`, laitoch2018 §3.6)."""

    #: no label is a thin line: texture-by-numbers matches the labels' areas only
    thin_labels: tuple = ()

    def exemplar(self, photo: np.ndarray, labels_in: np.ndarray | None, cracks: Any = None) -> Exemplar:
        """The photo as it is, with the user's label map if any."""
        return Exemplar(photo, labels_in)

    def analyse(self, labels_in: np.ndarray, photo: np.ndarray, cache: Any, run: Run) -> None:
        """The engine strategies' exemplar analysis into ``cache`` (mazzolini2012 §4.1.2)."""
        from barkgen.shapes import analyse_label_map

        strategy = run.options.strategy
        if strategy in INIT_LEVELS:
            analyse_label_map(
                labels_in,
                run.canvas.shape,
                cache,
                photo=photo if strategy == "joint" else None,
                exemplar_wrap=run.canvas.exemplar_wrap,
            )

    def label_map(
        self, labels_in: np.ndarray, photo: np.ndarray, analysis: Any, run: Run, resume: Any, window: int = 0
    ):
        """The output label map and no grown network (its large finest levels solved window by
        window of ``window`` px, 0: whole)."""
        from barkgen.shapes import synthesize_label_map

        # (the run's memory was checked as a whole, check_generate_memory)
        budget = run.stage_budget("label_map", analysis.cache).replace(max_memory=None)
        result = synthesize_label_map(
            labels_in,
            strategy=run.options.strategy,
            photo=photo,
            canvas=run.canvas,
            budget=budget,
            rotations=run.options.rotations,
            resume=resume,
            window=window,
        )
        return result, None

    def report(self, exemplar: Exemplar) -> dict:
        """Nothing beyond the run's report."""
        return {}


class Cracks:
    """``structure="cracks"``: the photo's crack network is extracted (sibbing2010 §3), its
    statistics fitted (§4.1) and a new network grown at the output size (§4.2-4.5), on the
    torus when the output tiles; its raster is the output label map, its lines matched at
    every level by their proximity and direction too (``thin_labels``)."""

    #: the crack label is a 1-3 px line: texture-by-numbers matches its proximity and direction
    thin_labels = (CRACK_VALUE,)

    def exemplar(self, photo: np.ndarray, labels_in: np.ndarray | None, cracks: Any = None) -> Exemplar:
        """The crack network's statistics (learned from ``cracks``, the user's edited network,
        or the one extracted from the photo: with a user's label map, its darkest label is the
        cracks) and its raster as the photo's label map."""
        from barkgen.branching import extract_structure, fit_model, rasterize

        source = cracks if cracks is not None else extract_structure(photo, labels_in)
        return Exemplar(photo, crack_labels(rasterize(source, np.shape(photo)[:2])), cracks=fit_model(source))

    def analyse(self, labels_in: np.ndarray, photo: np.ndarray, cache: Any, run: Run) -> None:
        """Nothing: a network is grown, not synthesized."""

    def label_map(
        self, labels_in: np.ndarray, photo: np.ndarray, analysis: Any, run: Run, resume: Any, window: int = 0
    ):
        """The grown network's raster and the network (``window``: not used, the raster is
        drawn whole)."""
        return crack_label_map(analysis.exemplar.cracks, run.options, run.canvas, run.progress("label_map"))

    def report(self, exemplar: Exemplar) -> dict:
        """What the crack model learned from (``crack_model``: branches, vertices, furcations,
        merges, source length)."""
        return {"crack_model": dict(exemplar.cracks.meta)} if exemplar.cracks is not None else {}


class Patches:
    """``model="patches"``: the engine copies the photo's pixels; the texture is its result."""

    def exemplar(self, photo: np.ndarray, options: GenerateOptions, progress=None) -> Exemplar | None:
        """None: the structure variant's exemplar is the photo's."""
        return None

    def finish(
        self, result: Any, material: Any, exemplar: Exemplar | None, budget: Budget
    ) -> tuple[np.ndarray, dict, Any]:
        """The texture, no layers, the material set as it is."""
        return result.image, {}, material


class Bilayer:
    """``model="bilayer"``: the photo is split into a structure layer and spatially varying
    noise (guingo2017 §3); the engine synthesizes the structure layer, and new noise of the
    photo's spectra is laid under its masks on the output's torus (eq. 6)."""

    def exemplar(self, photo: np.ndarray, options: GenerateOptions, progress=None) -> Exemplar:
        """The photo's bi-layer model, its structure layer what the engine copies
        (``progress``: the analysis' ``(done, total)``)."""
        return _bilayer_exemplar(photo, options, progress)

    def finish(
        self, result: Any, material: Any, exemplar: Exemplar | None, budget: Budget
    ) -> tuple[np.ndarray, dict, Any]:
        """The new noise added (guingo2017 eq. 6: P' + sum M'_k N_k, the material's albedo
        too; its white noise from the run's seed); the layers ``structure``, ``noise`` and
        ``masks``."""
        assert exemplar is not None and exemplar.bilayer is not None  # the analysis made the model
        noise, masks = bilayer_layers(exemplar.bilayer, result.references, budget.seed)
        texture = add_noise(result.image, noise)
        if material is not None:  # the structure layer's maps; its albedo with the new noise
            material = dataclasses.replace(material, color=np.clip(material.color + noise, 0.0, 1.0))
        return texture, {"structure": result.image, "noise": noise, "masks": masks}, material


def variants(options: GenerateOptions) -> tuple[PhotoLabels | Cracks, Patches | Bilayer]:
    """The run's structure and model variants (:class:`GenerateOptions` refuses cracks with a
    bi-layer texture)."""
    structure = Cracks() if options.structure == "cracks" else PhotoLabels()
    return structure, Bilayer() if options.model == "bilayer" else Patches()


def _bilayer_exemplar(photo: np.ndarray, options: GenerateOptions, progress=None) -> Exemplar:
    """The photo's bi-layer model (its clusters from :data:`ANALYSIS_SEED`: the photo's own, not
    a variant's); its structure layer in the photo's dtype, and its clusters as a label map,
    darkest cluster first (the height's label cue)."""
    from barkgen.bilayer import analyze
    from barkgen.labels.regions import order_by_luminance, to_label_image

    model = analyze(photo, bilayer_options(options), progress=progress)
    structure = from_unit(model.structure, np.asarray(photo).dtype)
    if np.ndim(photo) == 2:
        structure = structure[:, :, 0]
    luma = model.structure @ np.array([0.2126, 0.7152, 0.0722], np.float32)  # Rec. 709
    codes = order_by_luminance(model.labels.astype(np.int32), luma, model.k)
    return Exemplar(structure, to_label_image(codes, model.k), bilayer=model)


def bilayer_options(options: GenerateOptions) -> AnalysisOptions:
    """The bi-layer analysis' options of a run (``report.json`` lists them)."""
    from barkgen.bilayer import AnalysisOptions

    return AnalysisOptions(k=options.k, seed=ANALYSIS_SEED, max_memory=options.max_memory)


def growth_options(options: GenerateOptions) -> GrowOptions:
    """The crack network's growth options of a run (``report.json`` lists them)."""
    from barkgen.branching import GrowOptions

    return GrowOptions(max_memory=options.max_memory)


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
    cracks: Any, options: GenerateOptions, canvas: Canvas, progress: ProgressCallback | None = None
) -> tuple[LabelMapResult, Any]:
    """A new crack network grown from the photo's statistics at ``canvas.shape`` (on the torus
    when it tiles; sibbing2010 §4), and its raster as the output label map.

    Returns
    -------
    (LabelMapResult, Structure)
        The label map (cracks :data:`CRACK_VALUE`) and the grown network.
    """
    from barkgen.branching import grow_structure, rasterize
    from barkgen.shapes import LabelMapResult

    h, w = canvas.shape
    grown = grow_structure(
        cracks,
        (w, h),
        seed=options.seed,
        options=growth_options(options),
        progress=progress,
        tile=canvas.tile,
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
