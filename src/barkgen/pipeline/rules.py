"""The rules of a :func:`~barkgen.pipeline.generate` run, checked in one place before any work
(laitoch2018 Figure 1.2's steps each assume them): what the memory budget allows, which
variants go together (cracks, bi-layer textures, the edge label, a flow field, a resumed label
map), what a scanned set, height edits, a user's label map or crack network and a shared photo
analysis need. :func:`check_run` is called once by :func:`~barkgen.pipeline.generate`;
:func:`check_photo_inputs`, its per-photo part, once by
:func:`~barkgen.pipeline.analyze_photo`; :func:`check_combinations`, the options that go
together, by :class:`~barkgen.pipeline.GenerateOptions` as it is made (each option's own value
is checked where it is declared)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from barkgen._shared.checks import MAX_PHOTO_PIXELS
from barkgen._shared.memory import check_memory_budget
from barkgen._shared.options import option_fields
from barkgen.errors import InvalidInputError

if TYPE_CHECKING:
    from barkgen._shared.canvas import Canvas
    from barkgen.io import ScannedSet

#: a :class:`~barkgen.pipeline.GenerateOptions` (its module imports this one, which therefore
#: names the class without importing it)
Options = Any

#: bytes per output pixel of the material stage (height, normals, AO, roughness, albedo and the
#: gradient-domain solves' transforms; the 4096x4096 set peaked at 2.7 GiB with the texture)
MATERIAL_BYTES_PER_PIXEL = 48
#: outputs of more than this many pixels are made window by window under ``windowed="auto"``
#: (issue 69): a 4096² run already peaks at 3 GB whole
WINDOWED_PIXELS = 4096 * 4096
#: bytes per output pixel of a run made window by window, beside its windows' own: what it still
#: holds whole (the label stage's maps, the reference map, the texture, the target's guide
#: channels; ``bench_windows.py --large``: 1920 MiB at 4096², 14866 MiB at 16384², 55 B a pixel
#: over the photo's analysis, and a margin for another photo's labels)
WINDOWED_BYTES_PER_PIXEL = 72


@dataclass(frozen=True)
class PhotoInputs:
    """What the user gives with the photo, beside the options: maps synthesized along
    (``extra``), the photo's label map (``labels_in``), a scanned set (``scan``) and an edited
    crack network (``cracks``)."""

    extra: Mapping[str, np.ndarray] | None = None
    labels_in: np.ndarray | None = None
    scan: ScannedSet | None = None
    cracks: Any = None


def check_generate_memory(
    photo: np.ndarray,
    options: Options,
    extra: Mapping[str, np.ndarray] | None = None,
    *,
    along: bool = False,
    edits: bool = False,
) -> int:
    """The estimated peak memory of :func:`~barkgen.pipeline.generate` (bytes), checked against
    ``options.max_memory`` before any work: texture-by-numbers' solver, the largest of the run,
    and the material set (each stage frees what it made before the next starts); in a run made
    window by window (:func:`windowed_run` of its flow field, ``along``, and height ``edits``),
    the solver and the material set of one window and :data:`WINDOWED_BYTES_PER_PIXEL` of the
    output. A photo of more than :data:`~barkgen._shared.checks.MAX_PHOTO_PIXELS` is refused
    whatever the budget.

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
    solved = options.size
    if windowed_run(options, along, edits):
        from barkgen.pipeline.windowed import MATERIAL_HALO, WINDOW

        side = WINDOW + 2 * MATERIAL_HALO  # the largest window any pass holds
        solved = (min(side, options.size[0]), min(side, options.size[1]))
    n_solved = solved[0] * solved[1]
    need = estimate_memory(
        shape[:2],
        solved,
        channels + extra_channels,
        itemsize,
        (3 if channels >= 3 else 1) + 1 + extra_channels,
        TBN_CONFIG,
    )
    need += 24 * (n_ex + n_solved)  # label pyramids and tables
    if options.material:
        need += MATERIAL_BYTES_PER_PIXEL * (n_ex + n_solved)
    if solved != options.size:
        need += WINDOWED_BYTES_PER_PIXEL * n_out
    h, w = options.size
    return check_memory_budget(need, options.max_memory, f"output {w}x{h} from a {shape[1]}x{shape[0]} photo")


def analysis_key(options: Options) -> tuple:
    """The options a :class:`~barkgen.pipeline.PhotoAnalysis` depends on (the fields declared
    ``analysis=True``), as a hashable tuple: two runs whose keys agree may share one analysis."""
    return tuple((f.name, getattr(options, f.name)) for f in option_fields(type(options)) if f.info.analysis)


def check_combinations(options: Options) -> None:
    """The options that go together, checked as the options are made
    (:class:`~barkgen.pipeline.GenerateOptions`, each value checked there): a bi-layer texture
    has its own structure layer and 1 to 8 noises; light, relief and width in metres belong to
    a material set."""
    if options.model == "bilayer" and options.structure == "cracks":
        raise InvalidInputError("a bi-layer texture has its own structure layer: use one of cracks and bilayer")
    if options.model == "bilayer" and options.k > 8:
        raise InvalidInputError(f"a bi-layer texture has 1 to 8 noises (k), not {options.k}")
    if not options.material and (options.light is not None or options.relief != 1.0 or options.width_m is not None):
        raise InvalidInputError(
            "light, relief and width in metres apply to the material set: turn material on "
            "(--material; material: true in a spec)"
        )


def check_run(
    photo: np.ndarray,
    options: Options,
    fields: Canvas | None,
    given: PhotoInputs,
    analysis: Any = None,
    resume: Any = None,
    edits: list | tuple = (),
) -> None:
    """Every rule of a :func:`~barkgen.pipeline.generate` run, before any work: the memory
    budget, the ``fields`` (the user's canvas: its flow and scale fields and links) on the
    options' output, the variants that go together, height edits, and either the per-photo inputs
    (:func:`check_photo_inputs`) or a shared ``analysis`` that must belong to this photo and
    options.

    Raises
    ------
    InvalidInputError, ImageTooLargeError, MemoryBudgetError
        The first rule the run breaks, in one line.
    """
    along = fields is not None and fields.along
    check_generate_memory(photo, options, given.extra, along=along, edits=bool(edits))
    if fields is not None and (fields.shape != options.size or fields.tile != options.tile):
        h, w = options.size
        raise InvalidInputError(
            f"the canvas is {fields.shape[1]}x{fields.shape[0]} px{', tiled' if fields.tile else ''} but the "
            f"output is {w}x{h} px{', tiled' if options.tile else ''}: give Canvas(options.size, "
            "tile=options.tile, flow=...)"
        )
    _check_variant(options, along, resume is not None)
    if edits and (not options.material or given.scan is not None):
        raise InvalidInputError("height edits apply to an estimated material set: turn material on, give no scan")
    _check_windows(options, along, bool(edits))
    if analysis is None:
        check_photo_inputs(photo, options, given, memory=False)
    else:
        _check_analysis(analysis, photo, options, given)


def windowed_run(options: Options, along: bool, edits: bool) -> bool:
    """Whether the run is made window by window (``options.windowed``; issue 69): its finest
    levels solved and its colour blended in windows (``SynthesisConfig.window``), its material
    set a :class:`~barkgen.pipeline.WindowedMaterial`. ``auto``: for an output of more than
    :data:`WINDOWED_PIXELS` whose run needs nothing whole (:func:`whole_run_needs`: along a
    flow field, ``along``, or with height ``edits``); ``yes`` is refused with those by
    :func:`check_run`."""
    if options.windowed != "auto":
        return options.windowed == "yes"
    h, w = options.size
    return whole_run_needs(options, along, edits) is None and h * w > WINDOWED_PIXELS


def whole_run_needs(options: Options, along: bool, edits: bool) -> str | None:
    """What of a run needs it made whole (not window by window, ``GenerateOptions.windowed``:
    its solver's levels, its colour blend, its material set), or None."""
    if along:
        return "a flow field"
    if options.model == "bilayer":
        return "a bi-layer texture"
    return "height edits" if edits else None


def _check_windows(options: Options, along: bool, edits: bool) -> None:
    """``windowed="yes"`` only where the run may be made window by window."""
    if options.windowed == "yes":
        needs = whole_run_needs(options, along, edits)
        if needs is not None:
            raise InvalidInputError(f"{needs} is made whole: leave out --windowed yes")


def check_photo_inputs(photo: np.ndarray, options: Options, given: PhotoInputs, memory: bool = True) -> None:
    """The rules of a photo's analysis (:func:`~barkgen.pipeline.analyze_photo`): the memory
    budget (with ``memory``), a scanned set that belongs to the photo and a material set but no
    bi-layer texture, a crack network for ``structure="cracks"`` of the photo's size, no label
    map for a bi-layer texture (its labels are its noise clusters) and a label map of the
    photo's size."""
    if memory:
        check_generate_memory(photo, options, given.extra)
    scan, cracks = given.scan, given.cracks
    if scan is not None:
        if not options.material:
            raise InvalidInputError("a scanned set's maps go into the material set: turn material on")
        if tuple(scan.shape) != tuple(np.shape(photo)[:2]):
            raise InvalidInputError("the scanned set is not the photo's: their sizes differ")
    if scan is not None and options.model == "bilayer":
        raise InvalidInputError("a bi-layer texture's material set is its structure layer's: give no scanned set")
    if cracks is not None:
        _check_cracks(cracks, photo, options)
    if options.model == "bilayer" and given.labels_in is not None:
        raise InvalidInputError("a bi-layer texture's labels are its noise clusters: give no label map")
    labels_in = given.labels_in
    if labels_in is not None and np.ndim(labels_in) >= 2 and np.shape(labels_in)[:2] != np.shape(photo)[:2]:
        (h, w), (ph, pw) = np.shape(labels_in)[:2], np.shape(photo)[:2]
        raise InvalidInputError(f"the label map is {w}x{h} px but the photo is {pw}x{ph} px; they must match")


def _check_variant(options: Options, along: bool, resume: bool) -> None:
    """What goes together: cracks and bi-layer textures go their own ways
    (:mod:`barkgen.pipeline.variants`), and neither they nor the edge label follow a flow field;
    a crack network is not resumed."""
    variant = (
        "cracks" if options.structure == "cracks" else "a bi-layer texture" if options.model == "bilayer" else None
    )
    if variant and along:
        raise InvalidInputError(f"{variant} does not follow a flow field yet: leave out the flow field")
    if along and options.edges:
        raise InvalidInputError("the edge label does not follow a flow field yet: leave out edges or the flow field")
    if resume and options.structure == "cracks":
        raise InvalidInputError("a crack network is grown, not resumed: leave out the label map to resume from")


def _check_analysis(analysis: Any, photo: np.ndarray, options: Options, given: PhotoInputs) -> None:
    """Refuse a shared :class:`~barkgen.pipeline.PhotoAnalysis` that does not belong to this
    photo and options, or inputs that belong to the analysis."""
    if given.labels_in is not None:
        raise InvalidInputError("give the label map to analyze_photo, not with an analysis")
    if analysis.options is not None and analysis_key(analysis.options) != analysis_key(options):
        names = ", ".join(f.name for f in option_fields(type(options)) if f.info.analysis)
        raise InvalidInputError(f"the photo analysis was made with other options (of {names}); analyse the photo again")
    if analysis.labels_in.shape[:2] != np.asarray(photo).shape[:2]:
        raise InvalidInputError("the photo analysis belongs to a photo of another size")
    if options.structure == "cracks" and (analysis.exemplar is None or analysis.exemplar.cracks is None):
        raise InvalidInputError("the photo analysis has no crack network: analyse it with structure='cracks'")


def _check_cracks(cracks: Any, photo: np.ndarray, options: Options) -> None:
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
