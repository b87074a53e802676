"""``warm-up``: compile the numba kernels into their on-disk cache before the first real run;
a thin front end over :func:`barkgen.warm_up` (:mod:`barkgen.pipeline.warmup`), which says
what it runs and why. The quickstart runs it right after the install.
"""

from __future__ import annotations

from typing import Annotated

import typer

from barkgen.cli._common import QuietOption

#: :data:`barkgen.pipeline.warmup.STAGES` (not imported here: ``barkgen --help`` stays cheap)
STAGES = ("synth", "generate", "preview", "cracks", "bilayer")


def warm_up_command(
    stages: Annotated[
        str, typer.Option("--stages", help=f"Comma-separated stages to compile: {', '.join(STAGES)}.")
    ] = ",".join(STAGES),
    quiet: QuietOption = False,
) -> None:
    """Compile the kernels every front end runs, once (the quickstart's set-up step): synth, generate
    and its material set, the trunk preview and relief editor, crack networks and bi-layer textures;
    in two processes on two cores or more."""
    from barkgen.errors import InvalidInputError
    from barkgen.pipeline.warmup import check_stages, warm_up

    try:
        wanted = check_stages(stages)
    except InvalidInputError as exc:
        raise InvalidInputError(f"--stages: {exc}") from None

    def report(stage: str, seconds: float) -> None:
        typer.echo(f"warm-up: {stage} compiled in {seconds:.1f} s", err=True)

    warm_up(wanted, on_stage=None if quiet else report)


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (("warm-up", warm_up_command),)
