"""``evaluate``: barkgen's own quality measures of a ``barkgen generate`` folder against its
photo; a thin front end over :func:`barkgen.evaluate.evaluate_folder` (the guide:
``docs/guide/evaluate.md``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer


def evaluate_command(
    folder: Annotated[
        Path, typer.Argument(help="The folder barkgen generate wrote (texture.png, reference.png, ...).")
    ],
    photo: Annotated[Path, typer.Option("--photo", help="The photo the result was made from.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the measures as JSON instead of a table.")] = False,
) -> None:
    """Measure a result against its photo: patch coherence and completeness, sharpness, colour,
    largest copied piece, longest straight seam and line, step ratios across piece borders."""
    from barkgen.errors import ImageReadError
    from barkgen.evaluate import evaluate_folder

    if not photo.is_file():
        raise ImageReadError(f"--photo {str(photo)!r}: no such file")
    result = evaluate_folder(folder, photo)
    if as_json:
        typer.echo(json.dumps(result.as_dict(), indent=2))
    else:
        typer.echo(result.table())


#: (command name, function) of this group (the root orders ``barkgen --help``)
COMMANDS = (("evaluate", evaluate_command),)
