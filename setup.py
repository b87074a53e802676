"""setuptools' build (pyproject.toml says the rest) with one step more: three.js goes inside the
wheel, so that ``pip install 'barkgen[web]'`` serves the web app's 3D trunk.

The repository does not keep three.js (``src/barkgen/web/static/vendor/`` is git-ignored).
Building a wheel, from the tree or from the sdist, runs :mod:`barkgen.web.assets`' own code
(loaded from its file: the build has none of barkgen's dependencies): it downloads the pinned
release from the npm registry, checks its SHA-512 integrity and writes the files into the
build, unless the tree already holds them (``python -m barkgen.web.assets``). A build that
cannot fetch them fails, saying why and how to go on:

``BARKGEN_THREE_TARBALL=PATH-OR-URL``
    fetch from a copy of ``three-VERSION.tgz`` (an offline build; the integrity check stays);
``BARKGEN_BUILD_WITHOUT_THREE=1``
    build a wheel without three.js; its ``barkgen serve`` then warns that the 3D view is off.

An editable install (``pip install -e``) fetches into the tree, and only warns when it cannot.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.errors import SetupError

ASSETS = Path(__file__).resolve().parent / "src" / "barkgen" / "web" / "assets.py"


def _assets():
    """barkgen.web.assets, loaded from its file (importing barkgen.web needs the [web] extra)."""
    spec = importlib.util.spec_from_file_location("_barkgen_build_assets", ASSETS)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class BuildPyWithThree(build_py):
    """build_py, then three.js into the built package (or the tree, for an editable install)."""

    def run(self) -> None:
        super().run()
        assets = _assets()
        editable = bool(getattr(self, "editable_mode", False))
        target = assets.VENDOR if editable else Path(self.build_lib, "barkgen", "web", "static", "vendor", "three")
        if assets.assets_present(target):
            return
        url = os.environ.get("BARKGEN_THREE_TARBALL") or assets.THREE_TARBALL
        if "://" not in url:
            url = Path(url).resolve().as_uri()
        try:
            assets.fetch_three(target, url=url)
        except Exception as exc:  # network down, registry refused, integrity failed, ...
            problem = f"could not fetch three.js {assets.THREE_VERSION} for the web app ({exc})"
            if editable or os.environ.get("BARKGEN_BUILD_WITHOUT_THREE") == "1":
                print(
                    f"barkgen: warning: {problem}; building without it: `barkgen serve` will have no 3D trunk view",
                    file=sys.stderr,
                )
                return
            raise SetupError(
                f"barkgen: {problem}. Build where registry.npmjs.org answers, or set "
                f"BARKGEN_THREE_TARBALL to a copy of three-{assets.THREE_VERSION}.tgz, or set "
                "BARKGEN_BUILD_WITHOUT_THREE=1 for a wheel without the web app's 3D view"
            ) from exc
        print(
            f"barkgen: three.js {assets.THREE_VERSION} (MIT, npm registry, integrity checked) -> {target}",
            file=sys.stderr,
        )


setup(cmdclass={"build_py": BuildPyWithThree})
