"""Branching-structure files: the JSON form of :class:`barkgen.branching.Structure`."""

from __future__ import annotations

import json
import os
from pathlib import Path

from barkgen.branching.structure import Structure
from barkgen.errors import ImageReadError, InvalidInputError


def read_structure(path: str | os.PathLike) -> Structure:
    """Read and validate a structure file; every problem is one clear line."""
    path = Path(path)
    if not path.exists():
        raise ImageReadError(f"{path}: no such file")
    if path.is_dir():
        raise ImageReadError(f"{path} is a folder, not a structure file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InvalidInputError(f"{path}: cannot read a JSON structure ({exc.__class__.__name__})") from None
    if not text.strip():
        raise InvalidInputError(f"{path}: the file is empty")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InvalidInputError(f"{path}: malformed JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
    return Structure.from_dict(data, where=str(path))


def encode_structure(structure: Structure) -> bytes:
    """The structure as compact, human-readable JSON bytes (one branch per line)."""
    d = structure.to_dict()
    head = {k: v for k, v in d.items() if k != "branches"}
    lines = [json.dumps(b, separators=(",", ":")) for b in d["branches"]]
    text = json.dumps(head)[:-1] + ', "branches": [\n' + ",\n".join(lines) + "\n]}\n"
    return text.encode("utf-8")
