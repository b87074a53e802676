"""Bundled data: one permissively licensed bark photo (see SAMPLE_LICENSE.txt)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def sample_exemplar_path() -> Path:
    """Path of the bundled sample bark photo (pine, 1024x1024 JPEG, MIT; see SAMPLE_LICENSE.txt)."""
    return Path(str(resources.files("barkgen.data").joinpath("sample_bark.jpg")))
