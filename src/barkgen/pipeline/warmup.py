"""Compile the numba kernels into their on-disk cache before the first real run:
:func:`warm_up` (``barkgen.warm_up()``; ``barkgen warm-up`` on the command line).

Numba compiles a kernel the first time it is called with a new type signature and keeps the
machine code on disk (``cache=True``, in ``__pycache__`` beside the package). On a new install
the first ``generate`` therefore spends most of its time compiling (the quickstart: 31 s cold
against 7 s warm, 2026-12-03), and says so once (:mod:`barkgen._shared.compile_notice`).
:func:`warm_up` runs each stage once on a small crop of the bundled sample, through the same
code and with the same types as a real run (tiled and not, an exemplar that wraps and one that
does not, the material set, the trunk preview read back from its files), so that a set-up step
pays for the compilation once.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from barkgen.errors import InvalidInputError

#: the stages that can be warmed up, in order; the default is all of them
STAGES = ("synth", "generate", "preview")


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
    from barkgen.io import read_material
    from barkgen.render import TrunkView, render_trunk

    material, _ = read_material(folder)
    render_trunk(material, (96, 96), TrunkView())


def warm_up(
    stages: str | Iterable[str] | None = None, *, on_stage: Callable[[str, float], None] | None = None
) -> dict[str, float]:
    """Compile barkgen's numba kernels into their on-disk cache, so that the first real run is
    as fast as later ones (about 30 s once per install; seconds when the cache is warm).

    Parameters
    ----------
    stages : str or iterable of str, optional
        Some of :data:`STAGES` (``"synth"``, ``"generate"``, ``"preview"``), or a string of
        them separated by commas; default all.
        ``"preview"`` renders the files of ``"generate"``, which then runs too.
    on_stage : callable, optional
        ``on_stage(stage, seconds)`` after each stage.

    Returns
    -------
    dict
        Seconds per stage run, in order.

    Examples
    --------
    >>> import barkgen
    >>> barkgen.warm_up(["synth"])  # doctest: +SKIP
    {'synth': 29.3}
    """
    from barkgen._shared.compile_notice import quiet

    wanted = check_stages(stages)
    if "preview" in wanted and "generate" not in wanted:
        wanted.append("generate")
    crop = _crop()
    seconds: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="barkgen-warm-up-") as tmp, quiet():
        folder = Path(tmp) / "set"
        for stage in (s for s in STAGES if s in wanted):
            t0 = time.perf_counter()
            if stage == "synth":
                _synth(crop)
            elif stage == "generate":
                _generate(crop, folder)
            else:
                _preview(folder)
            seconds[stage] = time.perf_counter() - t0
            if on_stage is not None:
                on_stage(stage, seconds[stage])
    return seconds
