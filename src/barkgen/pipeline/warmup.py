"""Compile the numba kernels into their on-disk cache before the first real run:
:func:`warm_up` (``barkgen.warm_up()``; ``barkgen warm-up`` on the command line).

Numba compiles a kernel the first time it is called with a new type signature and keeps the
machine code on disk (``cache=True``, in ``__pycache__`` beside the package, or under
``NUMBA_CACHE_DIR``). On a new install the first ``generate`` therefore spends most of its
time compiling (the quickstart: 31 s cold against 7 s warm, 2026-12-03), and says so once
(:mod:`barkgen._shared.compile_notice`). :func:`warm_up` runs each stage once on a small crop of
the bundled sample, through the same code and with the same types as the front ends' runs (the
command line, the Python API, the web app's server and worker, the batch's workers), so that a
set-up step pays for the compilation once:

- ``synth``: the solver, tiled and not, on an exemplar that wraps and one that does not;
- ``generate``: the main job (labels, tiled, the material set), on both exemplars;
- ``preview``: the trunk preview and the web app's relief editor, on ``generate``'s files;
- ``cracks``: the crack network of a photo (the web app's crack view and its bark kinds, which
  the server extracts itself), an edited one, and ``structure="cracks"`` on both exemplars;
- ``bilayer``: ``model="bilayer"``.

A signature is a kernel's argument types, the memory layout of each array included: an array
that is sometimes a contiguous copy and sometimes a strided view (an exemplar that wraps is
read through a view of its torus) is two signatures, each compiled once; the stages run both.

Numba compiles one function at a time in a process (a global lock), so on two cores or more
the stages run in two processes at once: a child runs ``synth``, ``generate`` and
``preview`` (the solver's kernels) while this process extracts and grows crack networks (the
branching kernels, which the solver never calls), then runs what is left (``cracks`` and
``bilayer``, whose solver kernels are cached by then); on a very busy machine, in one. No kernel is compiled by both processes at once:
numba's cache index of a kernel is rewritten whole by whoever compiles it, so two writers
could drop each other's signatures; if they ever overlap, the overlapping kernels' indexes
are dropped and every stage runs again in a new process, which compiles them once more.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from barkgen.errors import InvalidInputError

#: the stages that can be warmed up, in order; the default is all of them
STAGES = ("synth", "generate", "preview", "cracks", "bilayer")
#: the stages run in the child process when the warm-up runs in two (the solver's kernels)
CHILD_STAGES = ("synth", "generate", "preview")
#: a warm-up runs in one process when the load average is this many times the cores or more:
#: its two processes then get no more CPU than one, and the second interpreter's imports are
#: more work (2 cores, 2026-12-07: at a load of 2, 43 s in two processes against 63 s in one;
#: at 5-7, 94 s against 78 s)
BUSY_LOAD_PER_CORE = 2.0
#: the size (height, width) of the crack networks grown (:func:`_crack_networks`)
CRACKS_SIZE = (160, 224)


def check_stages(stages: str | Iterable[str] | None) -> list[str]:
    """The stages asked for, checked: names, or one string of them separated by commas (None:
    all of them)."""
    if isinstance(stages, str):
        stages = stages.split(",")
    wanted = list(STAGES) if stages is None else [s.strip() for s in stages if s.strip()]
    unknown = sorted(set(wanted) - set(STAGES))
    if unknown or not wanted:
        raise InvalidInputError(f"unknown stage {unknown[0] if unknown else ''!r}; choose from {', '.join(STAGES)}")
    return wanted


def _crop():
    """A 128 px crop of the bundled sample (it does not tile itself)."""
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image

    return read_image(sample_exemplar_path())[300:428, 400:528]


def _synth(crop) -> None:
    from barkgen.synth import synthesize

    grey = crop.mean(axis=2).astype(crop.dtype)
    for wrap in ("no", "yes"):
        synthesize(crop, (96, 80), tile=True, seed=0, extra={"grey": grey}, exemplar_wrap=wrap)
        synthesize(crop, (80, 96), seed=0, exemplar_wrap=wrap)


def _generate(crop, folder: Path) -> None:
    from barkgen.io import write_folder_atomic
    from barkgen.pipeline.core import generate
    from barkgen.pipeline.files import encode_generate
    from barkgen.pipeline.options import GenerateOptions

    for wrap in ("no", "yes"):
        options = GenerateOptions(size=(96, 96), tile=True, seed=0, material=True, exemplar_wrap=wrap)
        result = generate(crop, options)
    write_folder_atomic(folder, encode_generate(crop, result, "warm-up", name="bark"))


def _preview(folder: Path) -> None:
    """The trunk preview of ``generate``'s set, and a height edit on it as the web app's relief
    editor makes one (from the set's files: texture, output labels, displacement)."""
    from barkgen._shared.arrays import Boundary
    from barkgen.io import read_image, read_material
    from barkgen.material import HeightEditor
    from barkgen.render import TrunkView, render_trunk

    material, _ = read_material(folder)
    render_trunk(material, (96, 96), TrunkView())
    labels = read_image(folder / "labels_out.png")
    labels = labels[..., 0] if labels.ndim == 3 else labels
    editor = HeightEditor(read_image(folder / "texture.png"), material.height, labels, boundary=Boundary(True))
    editor.edit(10, 20, 1.0, 4, 0.5)


def _crack_networks() -> None:
    """The branching kernels alone: a crack network extracted (as the web app's server does for
    its crack view and its bark kinds), the same network through its JSON form (an edited one,
    as a page sends it) and new networks grown from their statistics, tiled and not
    (sibbing2010 §3-4). A 256 px crop of the sample whose growth continues from one-vertex
    histories as well as longer ones: the growth kernel then sees both layouts of its history
    (a strided column, or a contiguous one when it has one element)."""
    from barkgen.branching import GrowOptions, Structure, extract_structure, fit_model, grow_structure
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image

    source = extract_structure(read_image(sample_exemplar_path())[300:556, :256])
    edited = Structure.from_dict(json.loads(json.dumps(source.to_dict())), "warm-up")
    height, width = CRACKS_SIZE
    for network, tile in ((source, True), (edited, False)):
        grow_structure(fit_model(network), (width, height), seed=0, options=GrowOptions(), tile=tile)


def _cracks(crop, networks_grown: bool = False) -> None:
    """``structure="cracks"`` on both exemplars, and the analysis of an edited network (the web
    app's crack view)."""
    from barkgen.branching import Structure, extract_structure
    from barkgen.pipeline.core import analyze_photo, generate
    from barkgen.pipeline.options import GenerateOptions

    if not networks_grown:
        _crack_networks()
    for wrap in ("no", "yes"):
        options = GenerateOptions(
            size=(96, 96), tile=True, seed=0, material=True, structure="cracks", exemplar_wrap=wrap
        )
        generate(crop, options)
    edited = Structure.from_dict(json.loads(json.dumps(extract_structure(crop).to_dict())), "warm-up")
    analyze_photo(crop, options, cracks=edited)


def _bilayer(crop) -> None:
    from barkgen.pipeline.core import generate
    from barkgen.pipeline.options import GenerateOptions

    generate(crop, GenerateOptions(size=(96, 96), tile=True, seed=0, material=True, model="bilayer"))


def _run_stage(stage: str, crop, folder: Path, networks_grown: bool = False) -> None:
    if stage == "synth":
        _synth(crop)
    elif stage == "generate":
        _generate(crop, folder)
    elif stage == "preview":
        _preview(folder)
    elif stage == "cracks":
        _cracks(crop, networks_grown)
    else:
        _bilayer(crop)


class _Compiles:
    """The barkgen functions this process compiles (numba's ``numba:compile`` event), as
    ``module.qualname``."""

    def __init__(self) -> None:
        from numba.core import event

        self.names: set[str] = set()
        names = self.names

        class _Listener(event.Listener):
            def on_start(self, ev) -> None:
                func = getattr(ev.data["dispatcher"], "py_func", None)
                module = getattr(func, "__module__", "") or ""
                if module.startswith("barkgen."):
                    names.add(f"{module}.{getattr(func, '__qualname__', '')}")

            def on_end(self, ev) -> None:
                pass

        self.listener = _Listener()
        event.register("numba:compile", self.listener)

    def close(self) -> None:
        from numba.core import event

        event.unregister("numba:compile", self.listener)


def _load() -> float:
    """The last minute's load average (0 where there is none: Windows)."""
    try:
        return os.getloadavg()[0]
    except (AttributeError, OSError):
        return 0.0


def _child_main(stages: list[str], folder: str) -> None:
    """The child process of a warm-up in two: run ``stages``, print ``{"seconds", "compiled"}``
    as one JSON line."""
    from barkgen._shared.compile_notice import quiet

    crop = _crop()
    compiles = _Compiles()
    seconds = {}
    with quiet():
        for stage in stages:
            t0 = time.perf_counter()
            _run_stage(stage, crop, Path(folder))
            seconds[stage] = time.perf_counter() - t0
    print(json.dumps({"seconds": seconds, "compiled": sorted(compiles.names)}))


def _start_child(stages: list[str], folder: Path) -> subprocess.Popen:
    """The child process of a warm-up in two (a new interpreter: nothing of this one's main
    module runs again, unlike multiprocessing's spawn), with this process's environment."""
    return subprocess.Popen(
        [sys.executable, "-m", "barkgen.pipeline.warmup", ",".join(stages), str(folder)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ),
    )


def _drop_indexes(names: Iterable[str]) -> None:
    """Forget what numba's cache holds of these functions (``module.qualname``): their next
    call compiles them again and writes a whole index."""
    from importlib import import_module

    for name in names:
        module_name, _, qualname = name.rpartition(".")
        dispatcher = getattr(import_module(module_name), qualname, None)
        cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
        index = getattr(cache_file, "_index_path", None)
        if index is not None and os.path.exists(index):
            os.remove(index)


def _in_two(wanted: list[str], folder: Path, report: Callable[[str, float], None]) -> tuple[list[str], float | None]:
    """Run the child's stages in a child process while this one grows crack networks; the
    stages left to run here, and the seconds the networks took (None: not grown). A child
    that fails leaves its stages to this process (which then raises what went wrong, with its
    traceback)."""
    child_stages = [s for s in CHILD_STAGES if s in wanted]
    try:
        child = _start_child(child_stages, folder)
    except OSError:  # no interpreter to start (an embedded Python): all of it here
        return list(wanted), None
    compiles = _Compiles()
    grown = None
    try:
        if "cracks" in wanted:
            t0 = time.perf_counter()
            _crack_networks()
            grown = time.perf_counter() - t0
        out, _ = child.communicate()
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
        compiles.close()
    if child.returncode != 0:
        return list(wanted), grown
    answer = json.loads(out.strip().splitlines()[-1])
    for stage in child_stages:
        report(stage, answer["seconds"][stage])
    overlap = compiles.names & set(answer["compiled"])
    if overlap:  # never by design (see the module's docstring); made good if it happens: in a
        # new process, which holds none of them in memory, so that it compiles and saves them
        _drop_indexes(overlap)
        again = _start_child(list(wanted), folder)
        again.communicate()
        return ([] if again.returncode == 0 else list(wanted)), grown
    return [s for s in wanted if s not in child_stages], grown


def warm_up(
    stages: str | Iterable[str] | None = None,
    *,
    on_stage: Callable[[str, float], None] | None = None,
    parallel: bool | None = None,
) -> dict[str, float]:
    """Compile barkgen's numba kernels into their on-disk cache, so that the first real run is
    as fast as later ones, in every front end (about 40 s once per install on two cores;
    seconds when the cache is warm).

    Parameters
    ----------
    stages : str or iterable of str, optional
        Some of :data:`STAGES` (``"synth"``, ``"generate"``, ``"preview"``, ``"cracks"``,
        ``"bilayer"``), or a string of them separated by commas; default all.
        ``"preview"`` reads the files of ``"generate"``, which then runs too.
    on_stage : callable, optional
        ``on_stage(stage, seconds)`` after each stage.
    parallel : bool, optional
        Run the stages in two processes at once (default: on two cores or more, unless the
        machine is very busy (:data:`BUSY_LOAD_PER_CORE`), when the stages asked for have
        kernels of both kinds).

    Returns
    -------
    dict
        Seconds per stage run, in :data:`STAGES` order.

    Examples
    --------
    >>> import barkgen
    >>> barkgen.warm_up(["synth"])  # doctest: +SKIP
    {'synth': 21.3}
    """
    from barkgen._shared.compile_notice import quiet

    wanted = check_stages(stages)
    if "preview" in wanted and "generate" not in wanted:
        wanted.append("generate")
    wanted = [s for s in STAGES if s in wanted]
    if parallel is None:
        cores = os.cpu_count() or 1
        parallel = cores >= 2 and _load() < BUSY_LOAD_PER_CORE * cores
    parallel = parallel and any(s in CHILD_STAGES for s in wanted) and any(s not in CHILD_STAGES for s in wanted)
    crop = _crop()
    seconds: dict[str, float] = {}

    def report(stage: str, took: float) -> None:
        seconds[stage] = seconds.get(stage, 0.0) + took
        if on_stage is not None:
            on_stage(stage, seconds[stage])

    with tempfile.TemporaryDirectory(prefix="barkgen-warm-up-") as tmp, quiet():
        folder = Path(tmp) / "set"
        here, grown = _in_two(wanted, folder, report) if parallel else (wanted, None)
        if grown is not None:  # the cracks stage's first part (reported with the rest)
            seconds["cracks"] = grown
        for stage in here:
            t0 = time.perf_counter()
            _run_stage(stage, crop, folder, grown is not None)
            report(stage, time.perf_counter() - t0)
    return {s: seconds[s] for s in STAGES if s in seconds}


if __name__ == "__main__":  # the child process of a warm-up in two (_start_child)
    _child_main(sys.argv[1].split(","), sys.argv[2])
