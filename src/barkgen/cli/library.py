"""``barkgen library``: the exemplar library (bark photos by species, their analyses and
generated results; :class:`barkgen.library.Library`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from barkgen.cli._common import LibraryOption

#: help of the ``library`` group
HELP = (
    "The exemplar library: bark photos by species, their analyses and generated results "
    "(SQLite + files; --library PATH or $BARKGEN_LIBRARY, default in your data folder)."
)


def _open_library(path: Path | None):
    """The library at ``path`` (None: $BARKGEN_LIBRARY, else the user data folder's)."""
    from barkgen.library import Library

    return Library(path)


def add_command(
    photo: Annotated[
        Path,
        typer.Argument(
            help="Bark photo (PNG, JPEG, TIFF, WebP, TGA, EXR, HDR, PPM, ...), or a scanned material set: its folder or its zip "
            "(ambientCG, Poly Haven or Megascans names; its maps make the material of every result)."
        ),
    ],
    name: Annotated[Optional[str], typer.Option("--name", help="Display name (default: the file name).")] = None,
    species: Annotated[Optional[str], typer.Option("--species", help="Tree species, e.g. oak.")] = None,
    bark_type: Annotated[Optional[str], typer.Option("--bark-type", help="e.g. furrowed, plated, scaly.")] = None,
    licence: Annotated[Optional[str], typer.Option("--licence", help="Licence of the photo, e.g. CC0.")] = None,
    source: Annotated[Optional[str], typer.Option("--source", help="Where the photo comes from.")] = None,
    library: LibraryOption = None,
) -> None:
    """Add a bark photo (or a scanned set) to the library and print its id (the same photo twice
    gives one entry)."""
    from barkgen.io import read_image_bytes

    lib = _open_library(library)
    if photo.is_dir() or photo.suffix.lower() == ".zip":
        exemplar = lib.add_scanned_set(
            _set_files(photo),
            name,
            species=species,
            bark_type=bark_type,
            licence=licence,
            source=source or one_line(str(photo)),
            where=str(photo),
        )
        maps = " + ".join(["colour", *exemplar.maps])
        typer.echo(f"{exemplar.id}\t{exemplar.name}\t(a scanned set: {maps})")
        return
    data = read_image_bytes(photo)
    existing = lib.find_exemplar(data)
    exemplar = existing or lib.add_exemplar(
        data,
        name or one_line(photo.stem),
        species=species,
        bark_type=bark_type,
        licence=licence,
        source=source or one_line(str(photo)),
    )
    note = "" if existing is None else " (already in the library)"
    typer.echo(f"{exemplar.id}\t{exemplar.name}{note}")


def one_line(text: str) -> str:
    """A file name or path as one line of printable text, for an entry's name or source when
    the user gave none: bytes that are no UTF-8 (kept by Python as lone surrogates) become
    U+FFFD, and each run of control characters and spaces (a newline, a tab) one space."""
    import re

    text = text.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
    return re.sub(r"\s+", " ", "".join(c if c.isprintable() else " " for c in text)).strip() or "photo"


def _set_files(path: Path) -> dict[str, bytes]:
    """A scanned set's files by name, from its folder or its zip."""
    from barkgen.errors import ImageReadError
    from barkgen.io import IMAGE_EXTENSIONS, read_image_bytes, read_set_zip

    if path.is_dir():
        return {
            p.name: read_image_bytes(p) for p in path.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_EXTENSIONS
        }
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ImageReadError(f"{path}: cannot read it ({exc.strerror or exc})") from None
    return read_set_zip(data, max_unpacked_bytes=2**31, where=str(path))


def list_command(library: LibraryOption = None) -> None:
    """List the exemplars: id, name, species, bark type, size, results, licence."""
    lib = _open_library(library)
    counts: dict[int, int] = {}
    for result in lib.results():
        counts[result.exemplar_id] = counts.get(result.exemplar_id, 0) + 1
    rows = [("id", "name", "species", "type", "size", "results", "licence")]
    rows += [
        (
            str(e.id),
            e.name,
            e.species or "-",
            e.bark_type or "-",
            f"{e.width}x{e.height}",
            str(counts.get(e.id, 0)),
            e.licence or "-",
        )
        for e in lib.exemplars()
    ]
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        typer.echo("  ".join(cell.ljust(width) for cell, width in zip(row, widths)).rstrip())
    typer.echo(f"library: {lib.path}", err=True)


def show_command(
    exemplar_id: Annotated[int, typer.Argument(metavar="ID", help="Exemplar id (see `barkgen library list`).")],
    library: LibraryOption = None,
) -> None:
    """Show one exemplar and its results."""
    import json

    lib = _open_library(library)
    exemplar = lib.exemplar(exemplar_id)
    results = [
        {"id": r.id, "created": r.created, "params": r.params, "files": sorted(r.files), "timings_s": r.timings}
        for r in lib.results(exemplar_id)
    ]
    typer.echo(json.dumps({**exemplar.to_dict(), "results": results}, indent=2))


def rm_command(
    exemplar_id: Annotated[int, typer.Argument(metavar="ID", help="Exemplar id to remove.")],
    library: LibraryOption = None,
) -> None:
    """Remove an exemplar with its analyses and results."""
    lib = _open_library(library)
    name = lib.exemplar(exemplar_id).name
    lib.remove_exemplar(exemplar_id)
    typer.echo(f"removed {exemplar_id}\t{name}")


#: (command name, function) of the group, in the order of ``barkgen library --help``
COMMANDS = (
    ("add", add_command),
    ("list", list_command),
    ("show", show_command),
    ("rm", rm_command),
)
