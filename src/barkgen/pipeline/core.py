"""The one-click pipeline: photo -> new bark (laitoch2018 §1, Figure 1.2), a short chain of stages
that each read the run's :class:`~barkgen.Canvas` and :class:`~barkgen.Budget`, built once at
its top, and its two variants, chosen once (:mod:`barkgen.pipeline.variants`):

1. analysis (:func:`analyze_photo`): the photo's broad light out, the input label map of the
   photo (:mod:`barkgen.labels`, §3.5), or the variant's (a bi-layer texture's clusters, a crack
   network's raster), and the solvers' analyses,
2. labels or cracks: the output label map of the requested size (:mod:`barkgen.shapes`, §3.6;
   by default the joint strategy, which matches the photo's colours along the labels), or a
   grown crack network's raster,
3. texture or bi-layer: texture-by-numbers of the photo from the input onto the output label
   map, with any extra maps synthesized along (:func:`barkgen.synth.texture_by_numbers`,
   §3.3–3.4), started from the output label map's own references into the photo when it has
   them (engine strategies): at the finest level for the joint strategy, whose references
   already fit together in colour, two levels above for the label-only engine; a bi-layer
   texture's new noise added after,
4. material: the photo's material set carried through the reference map,
5. report.

The rules of a run are checked once, first (:mod:`barkgen.pipeline.rules`). Arrays in, arrays
out; :mod:`barkgen.pipeline.files` encodes the files, the front ends write them.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from barkgen._shared.arrays import ProgressCallback
from barkgen._shared.canvas import Budget, Canvas
from barkgen._shared.memory import give_back_freed_memory
from barkgen._shared.threads import in_budget, thread_budget, worker_pool
from barkgen.pipeline.labelmaps import with_edge_labels
from barkgen.pipeline.materials import WindowedMaterial, output_material, photo_material
from barkgen.pipeline.options import GenerateOptions
from barkgen.pipeline.progress import ANALYSIS_SHARES, share_spans
from barkgen.pipeline.report import run_report
from barkgen.pipeline.rules import PhotoInputs, check_photo_inputs, check_run, windowed_run
from barkgen.pipeline.rules import check_generate_memory as check_generate_memory
from barkgen.pipeline.variants import ANALYSIS_SEED, INIT_LEVELS, Exemplar, Run, variants

if TYPE_CHECKING:
    from barkgen.branching import Structure
    from barkgen.io import ScannedSet
    from barkgen.material import HeightEdit, MaterialSet
    from barkgen.shapes import LabelMapResult
    from barkgen.synth import AnalysisCache, SynthesisResult

__all__ = ["ANALYSIS_SEED", "GenerateResult", "PhotoAnalysis", "analyze_photo", "check_generate_memory", "generate"]


@dataclass
class GenerateResult:
    """What :func:`generate` makes.

    Attributes
    ----------
    texture : ndarray, shape (H, W, C)
        The new bark, the photo's dtype.
    labels_in, labels_out : ndarray of uint8
        The photo's label map and the output's, as texture-by-numbers followed them (with
        ``options.edges``, both with the edge label, laitoch2018 §3.5.5).
    references : ndarray of int32, shape (H, W, 2)
        The reference map: output -> photo ``(y, x)``.
    extras : dict of str to ndarray
        The extra maps, synthesized along.
    label_levels : list of ndarray
        Every level of the output label map, finest first.
    report : dict
        JSON-ready parameters, label areas and timings.
    material : MaterialSet, WindowedMaterial or None
        With ``options.material``, the output's :class:`~barkgen.material.MaterialSet`; a
        :class:`~barkgen.pipeline.WindowedMaterial` in a windowed run (``options.windowed``, a
        large output's: made as its files are written, or whole by its ``whole()``).
    orientation : OrientedExemplar or None
        Along a flow field, the atlas of the photo's turned copies that ``references`` point
        into (:class:`barkgen.synth.OrientedExemplar`).
    cracks : Structure or None
        With ``structure="cracks"``, the grown crack network (:class:`barkgen.branching.Structure`).
    layers : dict of str to ndarray
        A bi-layer texture's synthesized ``structure`` (``P'``; ``references`` point into the
        photo's structure layer), ``noise`` and ``masks``; empty otherwise.
    """

    texture: np.ndarray
    labels_in: np.ndarray
    labels_out: np.ndarray
    references: np.ndarray
    extras: dict
    label_levels: list
    report: dict = field(default_factory=dict)
    material: MaterialSet | WindowedMaterial | None = None
    orientation: Any = None
    cracks: Any = None
    layers: dict = field(default_factory=dict)


def _within(progress: ProgressCallback, end: float) -> ProgressCallback:
    """``progress`` of a step that fills ``0 .. end`` of the run, in 1000ths."""
    return lambda done, total: progress(round(1000 * end * done / max(total, 1)), 1000)


@dataclass
class PhotoAnalysis:
    """What :func:`generate` needs from a photo whatever the seed.

    laitoch2018 Figure 1.2's per-photo steps: made once by :func:`analyze_photo`, it serves any
    number of seeds (:mod:`barkgen.batch` ships it to its workers).

    Attributes
    ----------
    labels_in : ndarray of uint8, shape (h, w)
        The input label map.
    cache : AnalysisCache
        The k-coherence analyses of the label-map and texture solvers (mazzolini2012 §4.1.2).
    material : MaterialSet or None
        With ``options.material``, the photo's own material set.
    options : GenerateOptions or None
        The options it was made with.
    seconds : float
        What it cost.
    exemplar : Exemplar or None
        What the solvers copy from (the photo, or a bi-layer texture's structure layer) and the
        crack network's statistics or the bi-layer model (:mod:`barkgen.pipeline.variants`);
        ``exemplar.bilayer.window`` streams a bi-layer texture without bounds.
    tbn_labels_in : ndarray of uint8 or None
        With ``options.edges``, the input label map with the edge label (laitoch2018 §3.5.5):
        what texture-by-numbers matches; ``None``: ``labels_in`` itself.
    illumination : ndarray of float32 or None
        The photo's broad light (:func:`barkgen.material.estimate_illumination`), of which
        ``equalization`` (0 to 1) was taken out of the photo before everything else.
    steps : dict of str to float
        Seconds of each step of the analysis: ``labels`` (the light out and the label map),
        ``label_map`` and ``texture`` (the two solvers' analyses), ``material`` (the wait for
        the photo's material set after them) and ``material_own`` (its own time, on the
        second thread beside the solvers').

    References
    ----------
    .. [1] laitoch2018, Figure 1.2.
    .. [2] mazzolini2012, §4.1.2 (the k-coherence analysis phase).
    """

    labels_in: np.ndarray
    cache: AnalysisCache
    material: MaterialSet | None = None
    options: GenerateOptions | None = None
    seconds: float = 0.0
    exemplar: Exemplar | None = None
    tbn_labels_in: np.ndarray | None = None
    illumination: np.ndarray | None = None
    equalization: float = 0.0
    steps: dict[str, float] = field(default_factory=dict)


def analyze_photo(
    photo: np.ndarray,
    options: GenerateOptions | None = None,
    *,
    extra: Mapping[str, np.ndarray] | None = None,
    labels_in: np.ndarray | None = None,
    progress: ProgressCallback | None = None,
    scan: ScannedSet | None = None,
    solvers: bool = True,
    cracks: Structure | None = None,
) -> PhotoAnalysis:
    """The per-photo part of :func:`generate`; the seed plays no part.

    The input label map (``options.k`` labels by ``options.method``, laitoch2018 §3.5, unless
    ``labels_in`` is given), the exemplar analyses of the output-label-map and
    texture-by-numbers solvers for outputs of ``options.size``, and with ``options.material``
    the photo's material set (wang2003 §3.3-3.4).

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        The bark photo (uint8, uint16 or float).
    options : GenerateOptions, optional
        The options of the runs it will serve (their seeds aside).
    extra : dict of str to ndarray, optional
        Maps aligned with the photo, synthesized along.
    labels_in : ndarray, shape (h, w) or (h, w, 3), optional
        The photo's label map, when the user has one: one grey value per label, or one colour
        per label (renumbered to grey, darkest first).
    progress : callable, optional
        ``progress(done, total)`` callback.
    scan : ScannedSet, optional
        A scanned set whose colour is ``photo`` (:func:`barkgen.io.read_scanned_set`): its own
        maps make the material set (:func:`barkgen.material.scanned_material`), nothing is
        estimated that it has.
    solvers : bool, default True
        Analyse the photo for the solvers too (not for a run along a flow field, whose solvers
        analyse the photo's turned copies).
    cracks : Structure, optional
        With ``structure="cracks"``, the photo's crack network as the user edited it
        (:mod:`barkgen.branching.edit`, sibbing2010 §6): the model is learned from it instead
        of from the network extracted from the photo. Of the photo's size.

    Returns
    -------
    PhotoAnalysis
        Give it to :func:`generate` for every seed.

    Raises
    ------
    InvalidInputError
        A label map of another size than the photo, or bad options.

    References
    ----------
    .. [1] laitoch2018, Figure 1.2 and §3.5.
    .. [2] mazzolini2012, §4.1.2 (analysis once, synthesis many times).

    Examples
    --------
    >>> import barkgen
    >>> photo = barkgen.read_image(barkgen.sample_exemplar_path())[:64, :64]
    >>> analysis = analyze_photo(photo, GenerateOptions(size=(64, 64)))
    >>> generate(photo, GenerateOptions(size=(64, 64), seed=1), analysis=analysis).texture.shape
    (64, 64, 3)
    """
    options = options or GenerateOptions()
    given = PhotoInputs(extra, labels_in, scan, cracks)
    check_photo_inputs(photo, options, given)
    return _analysis_stage(photo, _run(options, progress).resolved(photo), given, solvers, progress)


def _run(options: GenerateOptions, progress: ProgressCallback | None, fields: Canvas | None = None) -> Run:
    """The run's :class:`~barkgen.Canvas` (the options' size and tiling, the photo's wrap mode,
    the ``fields``' flow, scale and links) and :class:`~barkgen.Budget`, built once, and its
    variants, chosen once."""
    fields = fields or Canvas(options.size)
    canvas = fields.replace(shape=options.size, tile=options.tile, exemplar_wrap=options.exemplar_wrap)
    budget = Budget(options.seed, options.threads, options.max_memory, progress)
    return Run(options, canvas, budget, *variants(options))


def _analysis_stage(
    photo: np.ndarray, run: Run, given: PhotoInputs, solvers: bool, progress: ProgressCallback | None
) -> PhotoAnalysis:
    """The analysis stage (:func:`analyze_photo`, its inputs checked): the photo's broad light
    out, the variant's exemplar, the photo's label map, the solvers' analyses and the photo's
    material set; ``progress`` the analysis' own ``(done, total)``."""
    from barkgen.labels import color_regions, texton_regions
    from barkgen.labels.regions import grey_label_map
    from barkgen.material import Boundary
    from barkgen.material.illumination import equalize_light
    from barkgen.synth import TBN_CONFIG, AnalysisCache, analyse_texture_by_numbers

    options, wrap, scan = run.options, run.canvas.exemplar_wrap, given.scan
    steps = share_spans(ANALYSIS_SHARES, options.material)

    step_seconds: dict[str, float] = {}
    mark = [time.perf_counter()]

    def report(step: str) -> None:  # the end of the step's share of the analysis, in 1000ths
        now = time.perf_counter()
        if step in steps:  # (the material set's only with it)
            step_seconds[step], mark[0] = now - mark[0], now
            if progress:
                progress(round(1000 * steps[step][1]), 1000)

    def timed_material(*args) -> MaterialSet:  # the photo's material set, on its own thread
        t = time.perf_counter()
        made = in_budget(options.threads, photo_material, *args)
        step_seconds["material_own"] = time.perf_counter() - t
        return made

    # every pool sized, BLAS at one thread; a second thread for the photo's material set
    with thread_budget(options.threads), worker_pool(1) as pool:
        t0 = time.perf_counter()
        # the photo's broad light out before anything learns from it (a scan's colour is its
        # albedo already); every analysis of the photo runs across its edges where it tiles
        equalization = options.equalize_light if scan is None else 0.0
        photo, illumination = equalize_light(photo, equalization, boundary=Boundary(wrap))
        # (a bi-layer analysis, the longest step of its run, reports within the label map's share)
        within = None if progress is None else _within(progress, steps["labels"][1])
        exemplar = run.model.exemplar(photo, options, within) or run.structure.exemplar(
            photo, given.labels_in, given.cracks
        )
        photo, labels_in = exemplar.image, exemplar.labels_in
        if labels_in is None:
            regions = color_regions if options.method == "color" else texton_regions
            labels_in = regions(photo, options.k, seed=ANALYSIS_SEED, wrap=wrap)
        labels_in = grey_label_map(labels_in)  # a colour map: one grey value per colour
        report("labels")
        # the photo's material set needs only the photo and its labels: it is made on the
        # second thread while the two solvers analyse the photo, which keep 1.3 of 2 cores busy
        # (the quickstart's analysis without its label map: 5.3 s one after the other, 4.2 s so)
        making = (
            pool.submit(timed_material, photo, labels_in, options, wrap, scan, illumination)
            if options.material
            else None
        )
        cache = AnalysisCache()
        if solvers:
            run.structure.analyse(labels_in, photo, cache, run)
        report("label_map")
        tbn_labels_in, _ = with_edge_labels(labels_in, labels_in, run)
        if solvers:
            analyse_texture_by_numbers(
                photo,
                tbn_labels_in,
                options.size,
                cache,
                feature_weight=options.feature_weight,
                extra=given.extra,
                config=dataclasses.replace(TBN_CONFIG, threads=options.threads),
                exemplar_wrap=wrap,
            )
        report("texture")
        material = making.result() if making is not None else None
        report("material")
        return PhotoAnalysis(
            labels_in=labels_in,
            cache=cache,
            material=material,
            options=options,
            seconds=time.perf_counter() - t0,
            exemplar=exemplar,
            tbn_labels_in=tbn_labels_in if options.edges else None,
            illumination=illumination,
            equalization=equalization,
            steps=step_seconds,
        )


def generate(
    photo: np.ndarray,
    options: GenerateOptions | None = None,
    *,
    extra: Mapping[str, np.ndarray] | None = None,
    labels_in: np.ndarray | None = None,
    resume: np.ndarray | tuple[int, np.ndarray] | None = None,
    progress: ProgressCallback | None = None,
    analysis: PhotoAnalysis | None = None,
    scan: ScannedSet | None = None,
    canvas: Canvas | None = None,
    edits: Iterable[HeightEdit] = (),
) -> GenerateResult:
    """Turn a bark photo into new bark of ``options.size`` (laitoch2018 Figure 1.2).

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        The bark photo (uint8, uint16 or float).
    options : GenerateOptions, optional
        Default: 1024x1024, k = 3, colour labels, joint label maps, not tileable, seed 0.
    extra, labels_in, scan, progress
        As for :func:`analyze_photo` (to which an edited crack network is given); ``scan``'s
        own maps are carried to the output's material set; ``progress`` covers the whole run.
    resume : ndarray or (int, ndarray), optional
        An edited level of the output label map to continue from (:func:`~barkgen.shapes.synthesize_label_map`).
    analysis : PhotoAnalysis, optional
        :func:`analyze_photo` of the same photo, extras and options (the seed aside): skips
        the per-photo work; the result is the same bytes as without it.
    canvas : Canvas, optional
        ``Canvas(options.size, tile=options.tile, flow=...)``: the ``flow`` and ``flow_scale``
        fields (degrees counter-clockwise on screen, the photo's turn at each output pixel; 1 =
        the photo's scale) the label map, the texture and the material's normals follow
        (mazzolini2012 §3.1.3), and ``links`` (a texture atlas's gutters, :class:`~barkgen.synth.OutputLinks`).
    edits : iterable of HeightEdit, default ()
        Height edits on the output's relief, replayed on its material set (wang2003 §3.3;
        :func:`barkgen.material.edit_material`; needs ``options.material``).

    Returns
    -------
    GenerateResult
    """
    options, edits, given = options or GenerateOptions(), list(edits), PhotoInputs(extra, labels_in, scan)
    run = _run(options, progress, canvas)
    check_run(photo, options, canvas, given, analysis, resume, edits)
    run = run.resolved(photo)
    if analysis is None:  # along a field the solvers analyse the photo's turned copies, not the photo
        analysis = _analysis_stage(photo, run, given, not run.canvas.along, run.progress("analysis"))
    source = analysis.exemplar.image if analysis.exemplar is not None else photo  # what is copied
    timings, t1 = {"analysis": analysis.seconds}, time.perf_counter()
    timings.update({f"analysis_{step}": seconds for step, seconds in analysis.steps.items()})
    with thread_budget(options.threads):  # every pool sized, BLAS at one thread
        windowed = windowed_run(options, run.canvas.along, bool(edits))
        labels = _label_stage(run, analysis, source, resume, windowed)
        give_back_freed_memory()  # (each stage's freed working arrays not kept beside the next's)
        timings["labels_out"] = time.perf_counter() - t1
        result = _texture_stage(run, analysis, source, labels, extra, windowed)
        give_back_freed_memory()
        timings["texture"] = time.perf_counter() - t1 - timings["labels_out"]
        material = _material_stage(run, analysis, source, scan, result, timings, windowed)
    # the analysis' own cost counts whether it ran here or was shared
    timings["total"] = analysis.seconds + time.perf_counter() - t1
    return _finished(run, analysis, source, labels, result, material, edits, timings)


@dataclass
class _Labels:
    """The label stage's output: the output label map (``result``), the grown crack network
    (None but for cracks) and both maps as texture-by-numbers matches them."""

    result: LabelMapResult
    grown: Any
    tbn_in: np.ndarray
    tbn_out: np.ndarray
    #: the label map came with references into the photo (texture-by-numbers starts from them)
    referenced: bool = False

    def hand_over(self) -> np.ndarray:
        """The label map's references, taken from its result: whoever takes them holds the
        only reference (issue 69: the texture stage lets them go once its start is made)."""
        references, self.result.references = self.result.references, None
        assert references is not None  # (handed over once, when the label map has them)
        return references


def _label_stage(run: Run, analysis: PhotoAnalysis, source: np.ndarray, resume, windowed: bool) -> _Labels:
    """Labels or cracks: the structure variant's output label map (``windowed``: its large
    finest levels solved window by window, :data:`~barkgen.pipeline.windowed.WINDOW`), then the
    edge label on both maps (laitoch2018 §3.5.5)."""
    from barkgen.pipeline.windowed import WINDOW

    labels_in = analysis.labels_in
    result, grown = run.structure.label_map(labels_in, source, analysis, run, resume, WINDOW if windowed else 0)
    tbn_in, tbn_out = with_edge_labels(labels_in, result.label_map, run, analysis.tbn_labels_in)
    return _Labels(result, grown, tbn_in, tbn_out, result.references is not None)


def _texture_stage(
    run: Run, analysis: PhotoAnalysis, source: np.ndarray, labels: _Labels, extra, windowed: bool
) -> SynthesisResult:
    """The texture (or a bi-layer texture's structure layer): texture-by-numbers from the
    photo's label map onto the output's (laitoch2018 §3.3-3.4); ``windowed``: its finest levels
    solved and its colour blended window by window (:data:`~barkgen.pipeline.windowed.WINDOW`)."""
    from barkgen.pipeline.windowed import WINDOW
    from barkgen.synth import TBN_CONFIG, texture_by_numbers

    options, along, label_result = run.options, run.canvas.along, labels.result
    if along and label_result.synthesis is not None and not extra:
        # along a field the joint label map's own run is the texture: the photo and its labels
        # matched together on the turned copies (a second, texture-by-numbers solve on them
        # cost as much again and only re-made what the map already follows)
        return label_result.synthesis
    config = dataclasses.replace(
        TBN_CONFIG,
        threads=options.threads,
        max_memory=options.max_memory,
        blend=options.blend,
        window=WINDOW if windowed else 0,
    )
    # the engines' label maps copy exemplar label pieces: the same pieces of the photo are a
    # label-exact, coherent start for texture-by-numbers (else its smart initialisation); handed
    # over, not held through its solve (8 B a pixel)
    level = 0 if along else INIT_LEVELS.get(options.strategy, 0)
    return texture_by_numbers(
        source,
        labels.tbn_in,
        labels.tbn_out,
        label_weight=options.label_weight,
        feature_weight=options.feature_weight,
        init="smart" if labels.result.references is None else (labels.hand_over(), level),
        thin_labels=() if along else run.structure.thin_labels,
        extra=extra,
        config=config,
        canvas=run.canvas,
        budget=run.stage_budget("texture", analysis.cache),
    )


def _material_stage(
    run: Run, analysis: PhotoAnalysis, source, scan, result, timings: dict, windowed: bool
) -> MaterialSet | WindowedMaterial | None:
    """The output's material set (wang2003 §3.3-3.4), with ``options.material``: the photo's
    carried through the texture's reference map (``windowed``: as its files are written)."""
    if not run.options.material:
        return None
    t0 = time.perf_counter()
    material = output_material(source, run.options, run.canvas, scan, analysis, result, windowed)
    timings["material"] = time.perf_counter() - t0
    if run.budget.progress:
        run.budget.progress(1000, 1000)
    return material


def _finished(run: Run, analysis: PhotoAnalysis, source, labels: _Labels, result, material, edits, timings):
    """The :class:`GenerateResult`: the model variant's texture, layers and material set (a
    bi-layer texture's new noise added), the height edits replayed on the material set
    (wang2003 §3.3), and the report."""
    options, exemplar = run.options, analysis.exemplar
    texture, layers, material = run.model.finish(result, material, exemplar, run.budget)
    if edits and material is not None:
        from barkgen.material import edit_material

        material = edit_material(material, edits, texture=texture, label_map=labels.result.label_map)
    wrap = run.canvas.exemplar_wrap
    report = run_report(
        source,
        options,
        wrap,
        analysis.labels_in,
        labels.result,
        result,
        material,
        timings,
        referenced=labels.referenced,
    )
    report["height_edits"] = len(edits)
    report.update(run.structure.report(exemplar) if exemplar is not None else {})
    return GenerateResult(
        texture=texture,
        labels_in=labels.tbn_in,
        labels_out=labels.tbn_out,
        references=result.references,
        extras=result.extras,
        label_levels=labels.result.levels,
        report=report,
        material=material,
        orientation=result.orientation,
        cracks=labels.grown,
        layers=layers,
    )
