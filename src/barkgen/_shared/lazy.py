"""Packages whose public names are imported on first use: the list of names lives in the
package's ``__init__.pyi`` (what type checkers and editors read), and ``__init__.py`` imports
each name's module only when the name is asked for, so that importing the package (the CLI's
start-up, every command's) costs nothing for the parts a run does not use."""

from __future__ import annotations

import ast
from collections.abc import Callable
from importlib import import_module
from pathlib import Path
from typing import Any


def stub_names(init_file: str, skip: tuple[str, ...] = ()) -> dict[str, str]:
    """Public name -> its module, from the ``__init__.pyi`` beside ``init_file`` (its
    ``from MODULE import NAME`` lines; modules in ``skip`` left out)."""
    tree = ast.parse((Path(init_file).with_suffix(".pyi")).read_text(encoding="utf-8"))
    return {
        alias.asname or alias.name: node.module
        for node in tree.body
        if isinstance(node, ast.ImportFrom) and node.module and node.module not in skip
        for alias in node.names
    }


def lazy_getattr(package: str, names: dict[str, str], on_import: Callable[[], None] | None = None):
    """A module ``__getattr__`` for ``package`` that imports a public name's module on first
    use (``on_import`` called after)."""

    def __getattr__(name: str) -> Any:
        if name in names:
            value = getattr(import_module(names[name]), name)
            if on_import is not None:
                on_import()
            return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return __getattr__
