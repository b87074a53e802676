"""The one-click pipeline: photo -> new bark (laitoch2018 §1, Figure 1.2).

1. input label map of the photo (:mod:`barkgen.labels`, §3.5),
2. output label map of the requested size (:mod:`barkgen.shapes`, §3.6; by default the joint
   strategy, which matches the photo's colours along the labels),
3. texture-by-numbers of the photo from the input onto the output label map, with any extra maps
   synthesized along (:func:`barkgen.synth.texture_by_numbers`, §3.3–3.4), started from the
   output label map's own references into the photo when it has them (engine strategies): at
   the finest level for the joint strategy, whose references already fit together in colour,
   two levels above for the label-only engine.

Arrays in, arrays out; :mod:`barkgen.pipeline.files` encodes the files, the front ends write them.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from barkgen._shared.arrays import ProgressCallback
from barkgen._shared.checks import MAX_PHOTO_PIXELS
from barkgen._shared.memory import check_memory_budget
from barkgen._shared.options import option_fields
from barkgen._shared.threads import in_budget, thread_budget
from barkgen.errors import InvalidInputError
from barkgen.pipeline.labelmaps import ANALYSIS_SEED, check_variant, output_label_map, with_edge_labels
from barkgen.pipeline.materials import output_material, photo_material
from barkgen.pipeline.options import GenerateOptions, analysis_key
from barkgen.pipeline.progress import ANALYSIS_SHARES, share_spans, stage_progress
from barkgen.pipeline.report import run_report
from barkgen.pipeline.variants import Exemplar, add_noise, bilayer_layers, prepare_exemplar
from barkgen.synth import resolve_exemplar_wrap

if TYPE_CHECKING:
    from barkgen.branching import Structure
    from barkgen.io import ScannedSet
    from barkgen.material import HeightEdit, MaterialSet
    from barkgen.synth import AnalysisCache, OutputLinks

#: the pyramid level texture-by-numbers takes up each strategy's label-map references at
#: (measured on the ten bark photos: joint at level 0/1/2 gave oak coherence 1.21/1.28/1.35x
#: plain synthesis; the label-only engine's references need two levels to fit in colour)
_INIT_LEVELS = {"joint": 0, "engine": 2}


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
    material : MaterialSet or None
        With ``options.material``, the output's :class:`~barkgen.material.MaterialSet`.
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
    material: MaterialSet | None = None
    orientation: Any = None
    cracks: Any = None
    layers: dict = field(default_factory=dict)


#: bytes per output pixel of the material stage (height, normals, AO, roughness, albedo and the
#: gradient-domain solves' transforms; the 4096x4096 set peaked at 2.7 GiB with the texture)
MATERIAL_BYTES_PER_PIXEL = 48


def check_generate_memory(
    photo: np.ndarray, options: GenerateOptions, extra: Mapping[str, np.ndarray] | None = None
) -> int:
    """The estimated peak memory of :func:`generate` (bytes), checked against
    ``options.max_memory`` before any work: texture-by-numbers' solver, the largest of the run,
    and the material set (each stage frees what it made before the next starts). A photo of
    more than :data:`~barkgen._shared.checks.MAX_PHOTO_PIXELS` is refused whatever the budget.

    Raises
    ------
    ImageTooLargeError
        The photo has more than :data:`~barkgen._shared.checks.MAX_PHOTO_PIXELS`.
    MemoryBudgetError
        The run would not fit the budget.
    """
    from barkgen.errors import ImageTooLargeError
    from barkgen.synth import TBN_CONFIG, estimate_memory

    shape = np.shape(photo)
    if shape[0] * shape[1] > MAX_PHOTO_PIXELS:
        raise ImageTooLargeError(
            f"the photo is {shape[1]}x{shape[0]} px ({shape[0] * shape[1] / 1e6:.0f} megapixels), more "
            f"than the {MAX_PHOTO_PIXELS / 1e6:.0f} megapixels a photo's analysis takes in bounded "
            f"time; scale it down (bark's detail rarely needs more than 2 px per mm)"
        )
    channels = 1 if len(shape) == 2 else shape[2]
    extra_channels = sum(1 if np.ndim(e) == 2 else np.shape(e)[2] for e in (extra or {}).values())
    itemsize = max([np.asarray(photo).dtype.itemsize] + [np.asarray(e).dtype.itemsize for e in (extra or {}).values()])
    n_ex, n_out = shape[0] * shape[1], options.size[0] * options.size[1]
    need = estimate_memory(
        shape[:2],
        options.size,
        channels + extra_channels,
        itemsize,
        (3 if channels >= 3 else 1) + 1 + extra_channels,
        TBN_CONFIG,
    )
    need += 24 * (n_ex + n_out)  # label pyramids and tables
    if options.material:
        need += MATERIAL_BYTES_PER_PIXEL * (n_ex + n_out)
    h, w = options.size
    return check_memory_budget(need, options.max_memory, f"output {w}x{h} from a {shape[1]}x{shape[0]} photo")


def _check_analysis(
    analysis: PhotoAnalysis, photo: np.ndarray, options: GenerateOptions, labels_in: np.ndarray | None
) -> None:
    """Refuse a shared :class:`PhotoAnalysis` that does not belong to this photo and options."""
    if labels_in is not None:
        raise InvalidInputError("give the label map to analyze_photo, not with an analysis")
    if analysis.options is not None and analysis_key(analysis.options) != analysis_key(options):
        names = ", ".join(f.name for f in option_fields(GenerateOptions) if f.info.analysis)
        raise InvalidInputError(f"the photo analysis was made with other options (of {names}); analyse the photo again")
    if analysis.labels_in.shape[:2] != np.asarray(photo).shape[:2]:
        raise InvalidInputError("the photo analysis belongs to a photo of another size")


def _within(progress: ProgressCallback, end: float) -> ProgressCallback:
    """``progress`` of a step that fills ``0 .. end`` of the run, in 1000ths."""
    return lambda done, total: progress(round(1000 * end * done / max(total, 1)), 1000)


def _check_scan(scan: ScannedSet | None, photo: np.ndarray, options: GenerateOptions) -> None:
    """A scanned set belongs to the photo (its colour) and goes into a material set."""
    if scan is None:
        return
    if not options.material:
        raise InvalidInputError("a scanned set's maps go into the material set: turn material on")
    if tuple(scan.shape) != tuple(np.shape(photo)[:2]):
        raise InvalidInputError("the scanned set is not the photo's: their sizes differ")


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
    from barkgen.labels import color_regions, texton_regions
    from barkgen.labels.regions import grey_label_map
    from barkgen.material.illumination import equalize_light
    from barkgen.shapes import analyse_label_map
    from barkgen.synth import TBN_CONFIG, AnalysisCache, analyse_texture_by_numbers

    options = options or GenerateOptions()
    check_generate_memory(photo, options, extra)
    _check_scan(scan, photo, options)
    steps = share_spans(ANALYSIS_SHARES, options.material)

    def report(step: str) -> None:  # the end of the step's share of the analysis, in 1000ths
        if progress and step in steps:
            progress(round(1000 * steps[step][1]), 1000)

    # every pool sized, BLAS at one thread; a second thread for the photo's material set
    with thread_budget(options.threads), ThreadPoolExecutor(max_workers=1) as pool:
        t0 = time.perf_counter()
        # every analysis of the photo runs across its edges where it tiles
        wrap = resolve_exemplar_wrap(options.exemplar_wrap, photo)
        if scan is not None and options.model == "bilayer":
            raise InvalidInputError("a bi-layer texture's material set is its structure layer's: give no scanned set")
        # the photo's broad light out before anything learns from it (a scan's colour is its
        # albedo already)
        equalization = options.equalize_light if scan is None else 0.0
        photo, illumination = equalize_light(photo, equalization, tile=wrap)
        # (a bi-layer analysis, the longest step of its run, reports within the label map's share)
        within = None if progress is None else _within(progress, steps["labels"][1])
        exemplar = prepare_exemplar(photo, options, labels_in, ANALYSIS_SEED, within, cracks)
        photo, labels_in = exemplar.image, exemplar.labels_in
        if labels_in is None:
            regions = color_regions if options.method == "color" else texton_regions
            labels_in = regions(photo, options.k, seed=ANALYSIS_SEED, wrap=wrap)
        labels_in = grey_label_map(labels_in)  # a colour map: one grey value per colour
        if labels_in.shape[:2] != np.asarray(photo).shape[:2]:
            raise InvalidInputError(
                f"the label map is {labels_in.shape[1]}x{labels_in.shape[0]} px but the photo is "
                f"{photo.shape[1]}x{photo.shape[0]} px; they must match"
            )
        report("labels")
        # the photo's material set needs only the photo and its labels: it is made on the
        # second thread while the two solvers analyse the photo, which keep 1.3 of 2 cores busy
        # (the quickstart's analysis without its label map: 5.3 s one after the other, 4.2 s so)
        material = (
            pool.submit(in_budget, options.threads, photo_material, photo, labels_in, options, wrap, scan, illumination)
            if options.material
            else None
        )
        cache = AnalysisCache()
        if solvers and options.strategy in _INIT_LEVELS and options.structure != "cracks":
            analyse_label_map(
                labels_in, options.size, cache, photo=photo if options.strategy == "joint" else None, exemplar_wrap=wrap
            )
        report("label_map")
        tbn_labels_in, _ = with_edge_labels(labels_in, labels_in, options, wrap=wrap)
        if solvers:
            analyse_texture_by_numbers(
                photo,
                tbn_labels_in,
                options.size,
                cache,
                feature_weight=options.feature_weight,
                extra=extra,
                config=dataclasses.replace(TBN_CONFIG, threads=options.threads),
                exemplar_wrap=wrap,
            )
        report("texture")
        material = material.result() if material is not None else None
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
    flow: np.ndarray | None = None,
    flow_scale: np.ndarray | None = None,
    links: OutputLinks | None = None,
    edits: Iterable[HeightEdit] = (),
    cracks: Structure | None = None,
) -> GenerateResult:
    """Turn a bark photo into new bark of ``options.size`` (laitoch2018 Figure 1.2).

    Parameters
    ----------
    photo : ndarray, shape (h, w, 3) or (h, w)
        The bark photo (uint8, uint16 or float).
    options : GenerateOptions, optional
        Default: 1024x1024, k = 3, colour labels, joint label maps, not tileable, seed 0.
    extra : dict of str to ndarray, optional
        Maps aligned with the photo (height, ...), synthesized along.
    labels_in : ndarray, optional
        The photo's label map, when the user has one (``k`` and ``method`` are then unused).
    resume : ndarray or (int, ndarray), optional
        An edited level of the output label map to continue from
        (:func:`~barkgen.shapes.synthesize_label_map`).
    progress : callable, optional
        ``progress(done, total)`` callback over the whole run.
    analysis : PhotoAnalysis, optional
        :func:`analyze_photo` of the same photo, extras and options (the seed aside): skips
        the per-photo work, and the result is the same bytes as without it.
    scan : ScannedSet, optional
        A scanned set whose colour is ``photo``: the output's material set carries the scan's
        own maps (normals as unit vectors, AO, roughness, metalness, opacity, its relief)
        through the reference map instead of estimating them (needs ``options.material``).
    flow, flow_scale : ndarray, optional
        ``(H, W)`` orientation field (degrees, counter-clockwise on screen: the photo's turn at
        each output pixel; an upright fissure runs at 90° + angle) and scale field (1 = the
        photo's): the label map (engine and joint strategies) and the texture follow them
        (mazzolini2012 §3.1.3; :func:`barkgen.synthesize`), the material's normals turned with
        the bark.
    links : OutputLinks, optional
        Output pixels that take the references of others while the solvers run (a texture
        atlas's gutters; :class:`barkgen.synth.OutputLinks`, with a flow field).
    edits : iterable of HeightEdit, default ()
        Height edits on the output's relief, in its pixels, replayed on its material set
        (wang2003 §3.3; :func:`barkgen.material.edit_material`; needs ``options.material``).
    cracks : Structure, optional
        The photo's crack network to learn from, edited by the user (:func:`analyze_photo`;
        give it there when an ``analysis`` is given).

    Returns
    -------
    GenerateResult
    """
    from barkgen.synth import TBN_CONFIG, texture_by_numbers

    options = options or GenerateOptions()
    timings: dict[str, float] = {}
    check_generate_memory(photo, options, extra)
    check_variant(options, flow is not None or flow_scale is not None, resume is not None)
    edits = list(edits)
    if edits and (not options.material or scan is not None):
        raise InvalidInputError("height edits apply to an estimated material set: turn material on, give no scan")
    if analysis is None:
        analysis = analyze_photo(
            photo,
            options,
            extra=extra,
            labels_in=labels_in,
            progress=stage_progress(progress, "analysis", options.material),
            scan=scan,
            # along a field the solvers analyse the photo's turned copies, not the photo
            solvers=flow is None and flow_scale is None,
            cracks=cracks,
        )
    else:
        _check_analysis(analysis, photo, options, labels_in)
        if cracks is not None:
            raise InvalidInputError("give the crack network to analyze_photo, not with an analysis")
    labels_in = analysis.labels_in
    t1 = time.perf_counter()
    timings["analysis"] = analysis.seconds
    wrap = resolve_exemplar_wrap(options.exemplar_wrap, photo)
    exemplar = analysis.exemplar
    if exemplar is not None:  # what the solvers copy: a bi-layer texture's structure layer
        photo = exemplar.image
    along = flow is not None or flow_scale is not None

    with thread_budget(options.threads):  # every pool sized, BLAS at one thread
        label_result, grown = output_label_map(
            labels_in, photo, options, analysis, wrap, resume, progress, (flow, flow_scale, links)
        )
        tbn_in, tbn_out = with_edge_labels(
            labels_in, label_result.label_map, options, wrap=wrap, tbn_labels_in=analysis.tbn_labels_in
        )
        t2 = time.perf_counter()
        timings["labels_out"] = t2 - t1

        config = dataclasses.replace(
            TBN_CONFIG, threads=options.threads, max_memory=options.max_memory, blend=options.blend
        )
        # the engines' label maps copy exemplar label pieces: the same pieces of the photo are a
        # label-exact, coherent start for texture-by-numbers (else its smart initialisation)
        init = label_result.references if label_result.references is not None else "smart"
        if along and label_result.synthesis is not None and not extra:
            # along a field the joint label map's own run is the texture: the photo and its labels
            # matched together on the turned copies (a second, texture-by-numbers solve on them
            # cost as much again and only re-made what the map already follows)
            result = label_result.synthesis
        else:
            result = texture_by_numbers(
                photo,
                tbn_in,
                tbn_out,
                label_weight=options.label_weight,
                feature_weight=options.feature_weight,
                init=init,
                init_level=0 if along else _INIT_LEVELS.get(options.strategy, 0),
                tile=options.tile,
                seed=options.seed,
                extra=extra,
                config=config,
                progress=stage_progress(progress, "texture", options.material),
                cache=analysis.cache,
                exemplar_wrap=wrap,
                flow=flow,
                flow_scale=flow_scale,
                links=links,
            )
        t3 = time.perf_counter()
        timings["texture"] = t3 - t2
        material = None
        if options.material:
            material = output_material(photo, labels_in, options, wrap, scan, analysis, result)
            timings["material"] = time.perf_counter() - t3
            if progress:
                progress(1000, 1000)
    # the analysis' own cost counts whether it ran here or was shared
    timings["total"] = analysis.seconds + time.perf_counter() - t1

    texture, layers, material = _finished(result, material, exemplar, options, edits, label_result.label_map)
    report = run_report(photo, options, wrap, labels_in, label_result, result, material, timings)
    report["height_edits"] = len(edits)
    if exemplar is not None and exemplar.cracks is not None:  # what the crack model learned from
        report["crack_model"] = dict(exemplar.cracks.meta)
    return GenerateResult(
        texture=texture,
        labels_in=tbn_in,
        labels_out=tbn_out,
        references=result.references,
        extras=result.extras,
        label_levels=label_result.levels,
        report=report,
        material=material,
        orientation=result.orientation,
        cracks=grown,
        layers=layers,
    )


def _finished(result, material, exemplar: Exemplar | None, options: GenerateOptions, edits, label_map):
    """The texture, a bi-layer texture's layers and the material set as the run gives them: a
    bi-layer texture's new noise added (guingo2017 eq. 6: P' + sum M'_k N_k, the material's
    albedo too), the height edits replayed on the material set (wang2003 §3.3)."""
    texture, layers = result.image, {}
    if exemplar is not None and exemplar.bilayer is not None:
        noise, masks = bilayer_layers(exemplar.bilayer, result.references, options.seed)
        texture, layers = add_noise(result.image, noise), {"structure": result.image, "noise": noise, "masks": masks}
        if material is not None:  # the structure layer's maps; its albedo with the new noise
            material = dataclasses.replace(material, color=np.clip(material.color + noise, 0.0, 1.0))
    if edits and material is not None:
        from barkgen.material import edit_material

        material = edit_material(material, edits, texture=texture, label_map=label_map)
    return texture, layers, material
