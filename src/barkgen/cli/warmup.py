"""``warm-up``: compile the numba kernels into their on-disk cache before the first real run.

Numba compiles a kernel the first time it is called with a new type signature and keeps the
machine code on disk (``cache=True``, in ``__pycache__`` beside the package). On a new install
the first ``generate`` therefore spends most of its time compiling (the quickstart: 31 s cold
against 7 s warm, 2026-12-03). ``barkgen warm-up`` runs each stage once on a small crop of the
bundled sample, through the same code and with the same types as a real run (tiled and not,
an exemplar that wraps and one that does not, the material set, the trunk preview read back
from its files), so the set-up step pays for the compilation once; the quickstart runs it
right after the install.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Annotated

import typer

from barkgen.cli._common import QuietOption

#: the stages that can be warmed up, in order; the default is all of them
STAGES = ("synth", "generate", "preview")


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
    from barkgen.pipeline import GenerateOptions, encode_generate, generate

    for wrap in ("no", "yes"):
        options = GenerateOptions(size=(96, 96), tile=True, seed=0, material=True,
                                  exemplar_wrap=wrap)
        result = generate(crop, options)
    write_folder_atomic(folder, encode_generate(crop, result, "warm-up", name="bark"))


def _preview(folder: Path) -> None:
    from barkgen.io import read_material
    from barkgen.render import TrunkView, render_trunk

    material, _ = read_material(folder)
    render_trunk(material, (96, 96), TrunkView())


def warm_up_command(
    stages: Annotated[str, typer.Option(
        "--stages", help=f"Comma-separated stages to compile: {', '.join(STAGES)}.")] = ",".join(STAGES),
    quiet: QuietOption = False,
) -> None:
    """Compile the kernels of synth, generate and preview once (the quickstart's set-up step)."""
    from barkgen.errors import InvalidInputError

    wanted = [s.strip() for s in stages.split(",") if s.strip()]
    unknown = sorted(set(wanted) - set(STAGES))
    if unknown or not wanted:
        raise InvalidInputError(f"--stages: unknown stage {unknown[0] if unknown else stages!r}; "
                                f"choose from {', '.join(STAGES)}")
    crop = _crop()
    with tempfile.TemporaryDirectory(prefix="barkgen-warm-up-") as tmp:
        folder = Path(tmp) / "set"
        for stage in STAGES:
            if stage not in wanted and not (stage == "generate" and "preview" in wanted):
                continue
            t0 = time.perf_counter()
            if stage == "synth":
                _synth(crop)
            elif stage == "generate":
                _generate(crop, folder)
            else:
                _preview(folder)
            if not quiet:
                typer.echo(f"warm-up: {stage} compiled in {time.perf_counter() - t0:.1f} s", err=True)


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (
    ("warm-up", warm_up_command),
)
