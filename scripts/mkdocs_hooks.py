"""MkDocs hooks of the documentation site (``mkdocs.yml``'s ``hooks``): the CLI reference page,
``cli.md``, is made from the Typer app as the site is built (``scripts/cli_reference.py``), so it
always says what ``barkgen --help`` says and no copy of it is kept to regenerate."""

from __future__ import annotations

import importlib.util
from pathlib import Path

from mkdocs.structure.files import File, Files

PAGE = "cli.md"


def _cli_reference():
    path = Path(__file__).with_name("cli_reference.py")
    spec = importlib.util.spec_from_file_location("cli_reference", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def on_files(files: Files, config) -> Files:
    """The site's files with the CLI reference made now (a stale local ``docs/cli.md`` replaced)."""
    old = files.get_file_from_path(PAGE)
    if old is not None:
        files.remove(old)
    page = File(PAGE, src_dir=None, dest_dir=config["site_dir"], use_directory_urls=config["use_directory_urls"])
    page.content_string = _cli_reference().render()
    files.append(page)
    return files
