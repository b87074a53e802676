"""The optional parts of barkgen and what each needs (``pyproject.toml``'s extras).

The core (``pip install barkgen``) holds the algorithms and the Python API; the front ends and
the formats that need more bring their own dependencies: ``[cli]`` (the ``barkgen`` command),
``[web]`` (``barkgen serve``), ``[batch]`` (Dask batches and their YAML specs), ``[gltf]``
(glTF export), ``[tree]`` (``barkgen tree``: meshes and their UV atlases) and ``[all]``. A front end whose extra is missing says so in one line.
"""

from __future__ import annotations

from importlib.util import find_spec

from barkgen.errors import MissingExtraError

#: the modules each extra brings (their import names)
EXTRAS: dict[str, tuple[str, ...]] = {
    "cli": ("typer", "rich"),
    "web": ("fastapi", "uvicorn", "multipart"),
    "batch": ("distributed", "dask", "yaml"),
    "gltf": ("trimesh",),
    "tree": ("trimesh", "xatlas"),
    "materialx": ("MaterialX",),
    "exr": ("OpenEXR",),
}


def missing_modules(extra: str) -> list[str]:
    """The modules of ``extra`` that cannot be imported here (found without importing them)."""
    missing = []
    for name in EXTRAS[extra]:
        try:
            found = find_spec(name) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            missing.append(name)
    return missing


def require_extra(extra: str, feature: str) -> None:
    """Raise :class:`~barkgen.errors.MissingExtraError` naming the ``pip install`` that brings
    ``feature`` when a module of ``extra`` is missing."""
    missing = missing_modules(extra)
    if missing:
        raise MissingExtraError(
            f"{feature} needs barkgen's [{extra}] extra ({', '.join(missing)} not installed): "
            f"pip install 'barkgen[{extra}]'"
        )
